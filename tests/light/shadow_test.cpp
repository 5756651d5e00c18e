// Translucent shadows (StarCraft II §5.8, issue 34): the lookup rules on hand-made maps, and the
// scene `shadows` lit from its G-buffer with maps rendered from the light against the tracer's
// shadow rays — one slab (its colour), two overlapping slabs (the product), no self-shadow on a
// slab, an opaque caster over a slab (black), PSNR outside a band of a few texels around the
// shadow edges, the one-translucent-depth limit measured apart; tiled = brute and the same
// output for any thread count with maps.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>

#include "core/parallel.hpp"
#include "dofkit/error.hpp"
#include "dofkit/light.hpp"
#include "scene/raytracer.hpp"
#include "scene/scene.hpp"

using namespace dofkit;

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

// Identity view, orthographic projection: a point (x, y, z) in camera space looks up texel
// ((x + 1)/2 · W, (1 − y)/2 · H) at light depth −z.
ShadowMaps tiny_maps() {
  ShadowMaps m;
  m.opaque_depth = Image(2, 1, 1, kInf);
  m.translucent_depth = Image(2, 1, 1, kInf);
  m.translucent_color = Image(2, 1, 3, 1.0f);
  m.opaque_depth.at(0, 0) = 5;  // left texel: a translucent caster at 2 m, an opaque one at 5 m
  m.translucent_depth.at(0, 0) = 2;
  m.translucent_color.at(0, 0, 0) = 0.5f;
  m.translucent_color.at(0, 0, 1) = 0.25f;
  m.translucent_color.at(0, 0, 2) = 1.0f;
  m.bias_m = 0.01;
  return m;
}

std::array<double, 3> at(double x, double depth) { return {x, 0, -depth}; }

}  // namespace

TEST(Shadow, LookupFollowsTheChaptersRules) {
  const ShadowMaps m = tiny_maps();
  using A = std::array<double, 3>;
  EXPECT_EQ(shadow_factor(m, at(-0.5, 1.0)), (A{1, 1, 1}));       // passes both tests: light not coloured
  EXPECT_EQ(shadow_factor(m, at(-0.5, 2.005)), (A{1, 1, 1}));     // within the bias of the translucent caster
  EXPECT_EQ(shadow_factor(m, at(-0.5, 3.0)), (A{0.5, 0.25, 1}));  // fails the translucent test only: coloured
  EXPECT_EQ(shadow_factor(m, at(-0.5, 6.0)), (A{0, 0, 0}));       // fails the opaque test: no light
  EXPECT_EQ(shadow_factor(m, at(0.5, 100.0)), (A{1, 1, 1}));      // the right texel holds no caster
  EXPECT_EQ(shadow_factor(m, at(1.5, 6.0)), (A{1, 1, 1}));        // outside the map: not shadowed
  ShadowMaps opaque_only = m;                                     // a plain shadow map
  opaque_only.translucent_depth = Image();
  opaque_only.translucent_color = Image();
  EXPECT_EQ(shadow_factor(opaque_only, at(-0.5, 3.0)), (A{1, 1, 1}));
  EXPECT_EQ(shadow_factor(opaque_only, at(-0.5, 6.0)), (A{0, 0, 0}));
  // Validation names the field.
  ShadowMaps bad = m;
  bad.translucent_color = Image(3, 1, 3, 1.0f);
  try {
    validate_shadow_maps(bad, "maps");
    FAIL() << "wrong size accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("maps.translucent_color"), std::string::npos) << e.what();
  }
  bad = m;
  bad.view[3] = std::nan("");
  EXPECT_THROW(validate_shadow_maps(bad, "maps"), Error);
  bad = m;
  bad.translucent_color.at(1, 0, 1) = 1.5f;
  EXPECT_THROW(validate_shadow_maps(bad, "maps"), Error);
}

namespace {

struct ShadowCase {
  scene::Scene sc;
  scene::LensCamera cam;
  Image depth, normals, albedo, specular, gloss, emissive;
  std::vector<Light> lights;      // with the maps
  std::vector<Light> unshadowed;  // the same lights without
  std::shared_ptr<const ShadowMaps> maps;
  int key = -1;
  GBufferRef ref() const { return {&depth, &normals, &albedo, &specular, &gloss, &emissive}; }
};

ShadowCase make_case(int w, int h, int map_px) {
  ShadowCase c;
  c.sc = scene::build_scene("shadows");
  scene::SceneOptions o;
  o.width = w;
  o.height = h;
  c.cam = scene::camera_for(c.sc, o);
  scene::GBuffer g = scene::render_gbuffer(c.sc, c.cam);
  c.depth = std::move(g.z);
  c.normals = std::move(g.normal);
  c.albedo = std::move(g.albedo);
  c.specular = std::move(g.specular);
  c.gloss = std::move(g.gloss);
  c.emissive = std::move(g.emissive);
  c.lights = c.sc.lights;
  c.unshadowed = c.sc.lights;
  for (std::size_t k = 0; k < c.lights.size(); ++k)
    if (c.lights[k].casts_shadows) {
      c.key = static_cast<int>(k);
      c.maps = std::make_shared<const ShadowMaps>(scene::render_shadow_maps(c.sc, c.lights[k], map_px, 0.03));
      c.lights[k].shadow = c.maps;
    }
  return c;
}

bool close3(const std::array<double, 3>& a, const std::array<double, 3>& b, double tol) {
  for (int k = 0; k < 3; ++k)
    if (std::abs(a[k] - b[k]) > tol) return false;
  return true;
}

}  // namespace

TEST(Shadow, SceneAgainstTheTracersShadowRays) {
  const int w = 192, h = 108;
  const ShadowCase c = make_case(w, h, 512);
  ASSERT_GE(c.key, 0);
  const Light& key = c.sc.lights[c.key];
  LightSettings s;
  s.hfov_deg = c.cam.hfov_deg;
  s.layers = true;
  const LightResult lit = deferred_lighting(c.ref(), c.lights, s);
  const LightResult open = deferred_lighting(c.ref(), c.unshadowed, s);
  const Image truth = scene::render_lit(c.sc, c.cam);
  const Image band = scene::shadow_band(c.sc, c.cam, key, *c.maps, 3);
  const Image ids = scene::primitive_ids(c.sc, c.cam);
  int red = -1, blue = -1, yellow = -1;
  for (int i = 0; i < static_cast<int>(c.sc.prims.size()); ++i) {
    if (c.sc.prims[i].name == "red slab") red = i;
    if (c.sc.prims[i].name == "blue slab") blue = i;
    if (c.sc.prims[i].name == "yellow slab") yellow = i;
  }
  ASSERT_TRUE(red >= 0 && blue >= 0 && yellow >= 0);
  const auto filter = [&](int i) {
    const scene::Rgb f = c.sc.prims[i].filter;
    return std::array<double, 3>{f.r, f.g, f.b};
  };
  const std::array<double, 3> red_f = filter(red), blue_f = filter(blue), yellow_f = filter(yellow);
  const std::array<double, 3> both = {blue_f[0] * yellow_f[0], blue_f[1] * yellow_f[1], blue_f[2] * yellow_f[2]};
  const double f_px = c.cam.f_px();
  const Image& shadowed_layer = lit.layers[c.key];
  const Image& open_layer = open.layers[c.key];
  int n_one = 0, n_two = 0, n_black_on_slab = 0, n_self = 0, n_limit = 0, n_band = 0, n_lit = 0;
  int bad_one = 0, bad_two = 0, bad_black = 0, bad_self = 0, limit_as_expected = 0;
  double sse = 0, n = 0, sse_limit = 0, n_limit_values = 0, sse_band = 0, n_band_values = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const int id = static_cast<int>(ids.at(x, y));
      if (id < 0) continue;
      const scene::Vec3 dir{(x + 0.5 - 0.5 * w) / f_px, (y + 0.5 - 0.5 * h) / f_px, 1.0};
      const scene::Rgb t = scene::shadow_transmittance(c.sc, key, dir * static_cast<double>(c.depth.at(x, y)), id);
      const std::array<double, 3> T{t.r, t.g, t.b};
      const bool slab = c.sc.prims[id].translucent;
      // A receiver that is itself a slab under another slab: the one-translucent-depth limit.
      const bool limit = slab && !close3(T, {1, 1, 1}, 1e-9) && !close3(T, {0, 0, 0}, 1e-9);
      const bool in_band = band.at(x, y) > 0.5f;
      n_band += in_band;
      for (int ch = 0; ch < 3; ++ch) {
        const double e = static_cast<double>(lit.lit.at(x, y, ch)) - truth.at(x, y, ch);
        if (in_band) {
          sse_band += e * e;
          n_band_values += 1;
          continue;
        }
        if (limit) {
          sse_limit += e * e;
          n_limit_values += 1;
        } else {
          sse += e * e;
          n += 1;
        }
      }
      if (in_band) continue;
      bool lit_here = true;
      std::array<double, 3> factor{};
      for (int ch = 0; ch < 3; ++ch) {
        const double o = open_layer.at(x, y, ch);
        lit_here = lit_here && o > 1e-6;
        factor[ch] = o > 0 ? shadowed_layer.at(x, y, ch) / o : 0;
      }
      if (!lit_here) continue;
      ++n_lit;
      if (limit) {
        ++n_limit;
        limit_as_expected += id == yellow && close3(T, blue_f, 1e-6) && close3(factor, both, 1e-5);
      } else if (!slab && close3(T, red_f, 1e-6)) {
        ++n_one;
        bad_one += !close3(factor, red_f, 1e-5);
      } else if (!slab && close3(T, both, 1e-6)) {
        ++n_two;
        bad_two += !close3(factor, both, 1e-5);
      } else if (id == red && close3(T, {0, 0, 0}, 0)) {
        ++n_black_on_slab;
        bad_black +=
            !(shadowed_layer.at(x, y, 0) == 0 && shadowed_layer.at(x, y, 1) == 0 && shadowed_layer.at(x, y, 2) == 0);
      } else if (slab && close3(T, {1, 1, 1}, 0)) {
        ++n_self;
        bad_self += !close3(factor, {1, 1, 1}, 1e-6);
      }
    }
  const double db = 10 * std::log10(n / sse), db_limit = 10 * std::log10(n_limit_values / sse_limit);
  const double db_band = 10 * std::log10(n_band_values / sse_band);
  const double db_all = 10 * std::log10((n + n_limit_values + n_band_values) / (sse + sse_limit + sse_band));
  std::printf(
      "shadows %dx%d, 512^2 maps: deferred vs tracer outside a 3-texel band: %.2f dB (linear, peak 1); band %d px; "
      "one slab %d px, two slabs %d px, opaque over a slab %d px, unshadowed slab %d px; receivers between two slabs "
      "(the one-depth limit) %d px: %.2f dB; inside the band %.2f dB; whole image %.2f dB\n",
      w, h, db, n_band, n_one, n_two, n_black_on_slab, n_self, n_limit, db_limit, db_band, db_all);
  EXPECT_GE(db, 35.0);
  // Each case is present in the image and right at every pixel outside the band.
  EXPECT_GT(n_one, 20);
  EXPECT_GT(n_two, 20);
  EXPECT_GT(n_black_on_slab, 5);
  EXPECT_GT(n_self, 50);
  EXPECT_GT(n_limit, 5);
  EXPECT_EQ(bad_one, 0);
  EXPECT_EQ(bad_two, 0);
  EXPECT_EQ(bad_black, 0);
  EXPECT_EQ(bad_self, 0);
  // The limit: a slab under another slab gets both filters (the colour map holds every
  // translucent caster in front of the opaque depth), where the tracer has only the upper one.
  EXPECT_EQ(limit_as_expected, n_limit);
  EXPECT_LT(n_band, w * h / 4);
}

TEST(Shadow, TiledEqualsBruteAndAnyThreadCount) {
  const ShadowCase c = make_case(80, 45, 128);
  LightSettings s;
  s.hfov_deg = c.cam.hfov_deg;
  s.threads = 1;
  s.impl = "brute";
  const Image brute = deferred_lighting(c.ref(), c.lights, s).lit;
  for (int t : {1, 2, 3}) {
    s.threads = t;
    s.impl = "tiled";
    EXPECT_EQ(deferred_lighting(c.ref(), c.lights, s).lit.data(), brute.data()) << t << " threads";
  }
  // The forward oracle with the same maps.
  const Image fwd = forward_lighting(c.ref(), c.lights, c.cam.hfov_deg);
  double worst = 0;
  for (std::size_t i = 0; i < fwd.data().size(); ++i)
    worst =
        std::max(worst, std::abs(fwd.data()[i] - brute.data()[i]) / std::max(1e-6, std::abs(double(fwd.data()[i]))));
  EXPECT_LE(worst, 1e-5);
  // The maps themselves: the same for 1 and 3 threads.
  ShadowMaps one, three;
  core::with_threads(1, [&] { one = scene::render_shadow_maps(c.sc, c.sc.lights[c.key], 96, 0.03); });
  core::with_threads(3, [&] { three = scene::render_shadow_maps(c.sc, c.sc.lights[c.key], 96, 0.03); });
  EXPECT_EQ(one.opaque_depth.data(), three.opaque_depth.data());
  EXPECT_EQ(one.translucent_depth.data(), three.translucent_depth.data());
  EXPECT_EQ(one.translucent_color.data(), three.translucent_color.data());
}

// The key transparency of the scene `shadows`: left out of the opaque buffers, written by
// render_transparency, and drawn over the opaque scene by the lit thin-lens render — with a
// pinhole-sized lens that render is the opaque lit image with the layer composited over it.
TEST(Shadow, KeyTransparencyIsCompositedByTheLitLensRender) {
  scene::Scene sc = scene::build_scene("shadows");
  scene::SceneOptions o;
  o.width = 96;
  o.height = 54;
  scene::LensCamera cam = scene::camera_for(sc, o);
  cam.k_px = 1e-9;  // a pinhole
  const Image opaque = scene::render_lit(sc, cam);
  const Image layer = scene::render_transparency(sc, cam);
  int covered = 0;
  for (std::size_t i = 0; i < layer.plane_size(); ++i) covered += layer.plane(3)[i] > 0;
  EXPECT_GT(covered, 100);
  sc.lit = true;
  const Image lens = scene::render_thin_lens(sc, cam, 1, 7);
  double worst = 0;
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) {
      const float a = layer.at(x, y, 3);
      for (int c = 0; c < 3; ++c) {
        const double want = opaque.at(x, y, c) * (1.0 - a) + layer.at(x, y, c);
        worst = std::max(worst, std::abs(want - lens.at(x, y, c)));
      }
    }
  EXPECT_LT(worst, 1e-4);
  // The pane is not in the G-buffer: its pixels show the opaque scene's depth.
  const scene::GBuffer g = scene::render_gbuffer(sc, cam);
  for (std::size_t i = 0; i < layer.plane_size(); ++i)
    if (layer.plane(3)[i] > 0) EXPECT_GT(g.z.plane(0)[i], layer.plane(4)[i]);
}
