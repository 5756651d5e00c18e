// Deferred lighting (issue 34): the attenuation window, the tiled path against the
// brute-force oracle bit for bit (camera inside a light, a light across the near plane, spot
// cones narrow and wide, lights behind the camera), the deferred output against the forward
// evaluation (1e-5 relative), thread-count independence, the culling's reach, and the
// G-buffer against the tracer's forward ground truth on the scene `lights`.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <numbers>

#include "dofkit/error.hpp"
#include "dofkit/light.hpp"
#include "metrics/metrics.hpp"
#include "scene/raytracer.hpp"
#include "scene/scene.hpp"

using namespace dofkit;

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

struct Buffers {
  Image depth, normals, albedo, specular, gloss, emissive;
  double hfov = 60;
  GBufferRef ref() const { return {&depth, &normals, &albedo, &specular, &gloss, &emissive}; }
};

// The scene `lights` rendered into a G-buffer at a small size.
Buffers scene_buffers(int w, int h, scene::Scene* out_scene = nullptr, scene::LensCamera* out_cam = nullptr) {
  const scene::Scene sc = scene::build_scene("lights");
  scene::SceneOptions o;
  o.width = w;
  o.height = h;
  const scene::LensCamera cam = scene::camera_for(sc, o);
  scene::GBuffer g = scene::render_gbuffer(sc, cam);
  Buffers b;
  b.depth = std::move(g.z);
  b.normals = std::move(g.normal);
  b.albedo = std::move(g.albedo);
  b.specular = std::move(g.specular);
  b.gloss = std::move(g.gloss);
  b.emissive = std::move(g.emissive);
  b.hfov = cam.hfov_deg;
  if (out_scene) *out_scene = sc;
  if (out_cam) *out_cam = cam;
  return b;
}

// A hostile synthetic G-buffer: depth steps between 0.06 m and 40 m, sky holes, random
// unnormalised normals (some facing away), random materials, a few zero normals.
Buffers random_buffers(int w, int h, std::uint32_t seed) {
  Buffers b;
  b.depth = Image(w, h, 1);
  b.normals = Image(w, h, 3);
  b.albedo = Image(w, h, 3);
  b.specular = Image(w, h, 3);
  b.gloss = Image(w, h, 1);
  b.emissive = Image(w, h, 3, 0.0f);
  std::uint32_t s = seed;
  const auto rnd = [&] {
    s = s * 1664525u + 1013904223u;
    return (s >> 8) * (1.0f / 16777216.0f);
  };
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const int block = (x / 7 + 3 * (y / 5)) % 6;
      float z = 0.06f + 0.3f * block * block + 0.05f * rnd();
      if (block == 5 && x % 3 == 0) z = kInf;
      b.depth.at(x, y) = z;
      for (int c = 0; c < 3; ++c) {
        b.normals.at(x, y, c) = rnd() * 2 - 1;
        b.albedo.at(x, y, c) = rnd();
        b.specular.at(x, y, c) = 0.2f * rnd();
      }
      b.normals.at(x, y, 2) += 0.5f;  // mostly towards the camera
      if ((x * 31 + y * 17) % 97 == 0)
        for (int c = 0; c < 3; ++c) b.normals.at(x, y, c) = 0;
      b.gloss.at(x, y) = rnd();
      if (z == kInf) b.emissive.at(x, y, 2) = 0.5f;
    }
  return b;
}

Light point_light(std::array<double, 3> at, double radius, std::array<double, 3> colour = {1, 0.8, 0.6}) {
  Light l;
  l.kind = Light::Kind::point;
  l.position_m = at;
  l.radius_m = radius;
  l.color = colour;
  l.intensity = 2;
  return l;
}

Light spot_light(std::array<double, 3> at, std::array<double, 3> dir, double radius, double inner, double outer) {
  Light l = point_light(at, radius, {0.5, 1, 0.7});
  l.kind = Light::Kind::spot;
  l.direction = dir;
  l.inner_deg = inner;
  l.outer_deg = outer;
  l.intensity = 5;
  return l;
}

// Lights for the hard cases: camera inside, across the near plane, behind the camera,
// spots narrow / wide / 90°, tiny lights, a spot whose apex holds the camera, a directional
// and an ambient light between them (the order of the sum matters).
std::vector<Light> hard_lights() {
  std::vector<Light> ls;
  ls.push_back(point_light({0.1, -0.05, -0.2}, 3.0));              // camera inside
  ls.push_back(point_light({0.0, 0.2, 0.4}, 0.9, {0.3, 0.5, 1}));  // centre behind the camera, crosses z = 0
  ls.push_back(point_light({-0.3, 0.1, -1.5}, 0.35, {1, 0.2, 0.2}));
  ls.push_back(point_light({2.0, 1.0, 1.5}, 1.2));  // behind the camera, out of view
  Light d;
  d.kind = Light::Kind::directional;
  d.direction = {0.3, -1, -0.4};
  d.intensity = 0.5;
  ls.push_back(d);
  ls.push_back(spot_light({0, 0, 0.3}, {0, 0, -1}, 6, 3, 8));             // camera inside a narrow cone
  ls.push_back(spot_light({0.5, 0.6, -1}, {-0.3, -1, -0.6}, 3, 30, 80));  // wide cone
  ls.push_back(spot_light({-0.8, -0.2, -2}, {1, 0.1, 0.2}, 2.5, 0, 90));  // a half space
  ls.push_back(spot_light({0.2, 0.2, -0.5}, {0.1, 0.2, 1}, 2, 10, 20));   // points back at the camera
  Light a;
  a.kind = Light::Kind::ambient;
  a.intensity = 0.1;
  a.ao = true;
  ls.push_back(a);
  ls.push_back(point_light({0.05, 0.0, -0.06}, 0.02));  // tiny, at the near depth
  for (int k = 0; k < 12; ++k)
    ls.push_back(point_light({-2 + 0.37 * k, -1 + 0.15 * k, -0.5 - 0.9 * k}, 0.2 + 0.1 * k, {0.2, 0.4, 1.0}));
  return ls;
}

bool same_bits(const Image& a, const Image& b) {
  return a.same_size(b) && a.channels() == b.channels() &&
         std::memcmp(a.data().data(), b.data().data(), a.data().size() * sizeof(float)) == 0;
}

}  // namespace

TEST(Light, WindowIsExactlyZeroAtTheRadius) {
  Light l = point_light({0, 0, -2}, 1.5);
  validate_light(l, "test");
  const std::array<double, 3> n{0, 0, 1}, v{0, 0, 1}, white{1, 1, 1}, spec{0.1, 0.1, 0.1};
  for (double d : {1.5, 1.5000001, 2.0, 10.0}) {
    const auto c = shade_light(l, {0, 0, -2 - d}, n, v, white, spec, 0.5);
    EXPECT_EQ(c[0], 0.0) << d;
    EXPECT_EQ(c[2], 0.0) << d;
  }
  const auto inside = shade_light(l, {0, 0, -2 - 1.4999}, n, v, white, spec, 0.5);
  EXPECT_GT(inside[0], 0.0);
  EXPECT_LT(inside[0], 1e-6);  // the window's value just inside: (1 − x⁴)² ≈ 0
  // Far from the edge the window is ≈ 1: radiance ≈ albedo/π · I · cos / d² (+ specular).
  const auto near = shade_light(l, {0, 0, -2.1}, n, v, white, {0, 0, 0}, 0.5);
  const double d = 0.1, x = d / 1.5;
  EXPECT_NEAR(near[0], 1 / std::numbers::pi * 2 * std::pow(1 - std::pow(x, 4), 2) / (d * d), 1e-12);
}

TEST(Light, SpotFalloffBetweenTheCones) {
  Light l = spot_light({0, 0, 0}, {0, 0, -1}, 10, 10, 20);
  l.intensity = 1;
  l.color = {1, 1, 1};
  validate_light(l, "test");
  const std::array<double, 3> n{0, 0, 1}, white{1, 1, 1}, none{0, 0, 0};
  const auto at_angle = [&](double deg) {
    const double a = deg * std::numbers::pi / 180;
    const std::array<double, 3> p{2 * std::sin(a), 0, -2 * std::cos(a)};
    return shade_light(l, p, {-std::sin(a), 0, std::cos(a)}, n, white, none, 0)[0];
  };
  const double full = at_angle(5);
  EXPECT_NEAR(at_angle(10), full, 1e-12);
  EXPECT_EQ(at_angle(20.001), 0.0);
  EXPECT_EQ(at_angle(40), 0.0);
  const double t = (std::cos(15 * std::numbers::pi / 180) - std::cos(20 * std::numbers::pi / 180)) /
                   (std::cos(10 * std::numbers::pi / 180) - std::cos(20 * std::numbers::pi / 180));
  EXPECT_NEAR(at_angle(15) / full, t * t, 1e-9);
}

TEST(Light, TiledMatchesBruteForceBitForBit) {
  for (int variant = 0; variant < 2; ++variant) {
    const Buffers b = variant == 0 ? scene_buffers(96, 54) : random_buffers(83, 61, 7);
    std::vector<Light> lights = hard_lights();
    if (variant == 0) {
      const scene::Scene sc = scene::build_scene("lights");
      lights.insert(lights.end(), sc.lights.begin(), sc.lights.end());
    }
    Image ao(b.depth.width(), b.depth.height(), 1);
    for (std::size_t i = 0; i < ao.plane_size(); ++i) ao.plane(0)[i] = 0.25f + 0.5f * ((i * 7) % 11) / 10.0f;
    LightSettings s;
    s.hfov_deg = variant == 0 ? b.hfov : 75;
    s.layers = true;
    s.ao = &ao;
    s.impl = "brute";
    const LightResult brute = deferred_lighting(b.ref(), lights, s);
    s.impl = "tiled";
    const LightResult tiled = deferred_lighting(b.ref(), lights, s);
    EXPECT_TRUE(same_bits(brute.lit, tiled.lit)) << "variant " << variant;
    ASSERT_EQ(brute.layers.size(), lights.size());
    for (std::size_t k = 0; k < lights.size(); ++k)
      EXPECT_TRUE(same_bits(brute.layers[k], tiled.layers[k])) << "variant " << variant << " light " << k;
    // The culling did cull: the small lights touched few tiles and few pixels.
    long long brute_pixels = 0, tiled_pixels = 0;
    for (std::size_t k = 0; k < lights.size(); ++k) {
      brute_pixels += brute.stats.pixels_shaded[k];
      tiled_pixels += tiled.stats.pixels_shaded[k];
    }
    EXPECT_LT(tiled_pixels, brute_pixels / 2) << "variant " << variant;
    EXPECT_LT(tiled.stats.tiles_touched[2], tiled.stats.tiles) << "variant " << variant;
    EXPECT_EQ(tiled.stats.tiles_touched[3], 0) << "a light behind the camera reaches no tile";
  }
}

TEST(Light, DeferredMatchesTheForwardEvaluation) {
  for (int variant = 0; variant < 2; ++variant) {
    const Buffers b = variant == 0 ? scene_buffers(96, 54) : random_buffers(64, 48, 3);
    std::vector<Light> lights = hard_lights();
    const double hfov = variant == 0 ? b.hfov : 75;
    LightSettings s;
    s.hfov_deg = hfov;
    const Image deferred = deferred_lighting(b.ref(), lights, s).lit;
    const Image forward = forward_lighting(b.ref(), lights, hfov);
    double worst = 0;
    for (std::size_t i = 0; i < deferred.data().size(); ++i) {
      const double ref = forward.data()[i], got = deferred.data()[i];
      // Relative to the value, with a floor of 1e-6 (one float step of a value near 8).
      worst = std::max(worst, std::abs(got - ref) / std::max(std::abs(ref), 1e-6));
    }
    EXPECT_LE(worst, 1e-5) << "variant " << variant;
    std::printf("variant %d: largest relative difference deferred vs forward %.3g\n", variant, worst);
  }
}

TEST(Light, SameOutputForAnyThreadCount) {
  const Buffers b = random_buffers(70, 45, 11);
  const std::vector<Light> lights = hard_lights();
  LightSettings s;
  s.hfov_deg = 70;
  s.threads = 1;
  const Image one = deferred_lighting(b.ref(), lights, s).lit;
  for (int t : {2, 3}) {
    s.threads = t;
    EXPECT_TRUE(same_bits(one, deferred_lighting(b.ref(), lights, s).lit)) << t << " threads";
  }
}

TEST(Light, CullingIsTight) {
  // The scene's small light (about 1 % of the frame) and its green spot at 320×180: the tiles a
  // light enters hold its pixels and little more, and the pixels it is evaluated at are the
  // pixels whose point lies inside its volume (counted here in double precision) up to the
  // relative 1e-6 growth of the volumes.
  const Buffers b = scene_buffers(320, 180);
  const scene::Scene sc = scene::build_scene("lights");
  const double f = 160 / std::tan(0.5 * b.hfov * std::numbers::pi / 180);
  for (int index : {3, 4}) {
    Light l = sc.lights[index];
    validate_light(l, "scene");
    LightSettings s;
    s.hfov_deg = b.hfov;
    const LightResult r = deferred_lighting(b.ref(), {l}, s);
    long long inside = 0;
    for (int y = 0; y < 180; ++y)
      for (int x = 0; x < 320; ++x) {
        const double z = b.depth.at(x, y);
        if (std::isinf(z)) continue;
        const double p[3] = {(x + 0.5 - 160) / f * z, -(y + 0.5 - 90) / f * z, -z};
        double d2 = 0, along = 0;
        for (int c = 0; c < 3; ++c) {
          d2 += (p[c] - l.position_m[c]) * (p[c] - l.position_m[c]);
          along += (p[c] - l.position_m[c]) * l.direction[c];
        }
        const bool in_cone =
            l.kind != Light::Kind::spot || along >= std::cos(l.outer_deg * std::numbers::pi / 180) * std::sqrt(d2);
        if (d2 < l.radius_m * l.radius_m && in_cone) ++inside;
      }
    const double tiles = static_cast<double>(r.stats.tiles_touched[0]) / r.stats.tiles;
    std::printf("light %d (%s): %lld pixels inside (%.2f %%), %lld evaluated, %.1f %% of the tiles\n", index,
                l.name.c_str(), inside, 100.0 * inside / (320 * 180), r.stats.pixels_shaded[0], 100 * tiles);
    EXPECT_GE(r.stats.pixels_shaded[0], inside);
    EXPECT_LE(r.stats.pixels_shaded[0], inside + inside / 100 + 10);
    // Each entered tile holds on average at least an eighth of a tile of the light's pixels.
    EXPECT_LE(r.stats.tiles_touched[0] * 256 / 8, inside) << index;
  }
  EXPECT_LT(sc.lights[3].radius_m, 0.5);
}

TEST(Light, GBufferAgainstTheTracersForwardGroundTruth) {
  scene::Scene sc;
  scene::LensCamera cam;
  const Buffers b = scene_buffers(160, 90, &sc, &cam);
  // The key light holds the camera.
  const Light& key = sc.lights[0];
  EXPECT_LT(std::hypot(key.position_m[0], key.position_m[1], key.position_m[2]), key.radius_m);
  LightSettings s;
  s.hfov_deg = b.hfov;
  const Image deferred = deferred_lighting(b.ref(), sc.lights, s).lit;
  const Image truth = scene::render_lit(sc, cam);
  const double db = metrics::psnr_linear(truth, deferred);
  std::printf("lights 160x90: deferred from the float G-buffer vs the tracer's forward lighting: %.2f dB\n", db);
  EXPECT_GE(db, 45.0);
}

TEST(Light, RefusesBadLightsAndBuffers) {
  const Buffers b = random_buffers(16, 16, 1);
  LightSettings s;
  s.hfov_deg = 60;
  const auto code = [&](std::vector<Light> ls, const GBufferRef& g) {
    try {
      deferred_lighting(g, ls, s);
    } catch (const Error& e) {
      return e.exit_code();
    }
    return 0;
  };
  Light bad = point_light({0, 0, -1}, -1);
  EXPECT_EQ(code({bad}, b.ref()), 3);
  bad = point_light({std::nan(""), 0, -1}, 1);
  EXPECT_EQ(code({bad}, b.ref()), 3);
  bad = spot_light({0, 0, 0}, {0, 0, -1}, 1, 30, 20);
  EXPECT_EQ(code({bad}, b.ref()), 3);
  bad = spot_light({0, 0, 0}, {0, 0, 0}, 1, 10, 20);
  EXPECT_EQ(code({bad}, b.ref()), 3);
  EXPECT_EQ(code(std::vector<Light>(kMaxLights + 1, point_light({0, 0, -1}, 1)), b.ref()), 2);
  Buffers nan = b;
  nan.depth.at(3, 4) = std::nanf("");
  EXPECT_EQ(code({point_light({0, 0, -1}, 1)}, nan.ref()), 3);
  Buffers small = b;
  small.albedo = Image(8, 8, 3);
  EXPECT_EQ(code({point_light({0, 0, -1}, 1)}, small.ref()), 3);
}
