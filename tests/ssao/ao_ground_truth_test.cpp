// The tracer's ambient-occlusion ground truth and G-buffer (issue 33): closed forms, the
// oriented box and the scene pitch it relies on, determinism, and the G-buffer channels.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "core/parallel.hpp"
#include "dofkit/error.hpp"
#include "metrics/ao_metrics.hpp"
#include "scene/raytracer.hpp"
#include "scene/scene.hpp"

using namespace dofkit;
using namespace dofkit::scene;
namespace core = dofkit::core;

namespace {

constexpr double kPi = std::numbers::pi;

Texture grey() {
  Texture t;
  t.octaves = 0;
  return t;
}

// A floor (y = 1, normal up: −y) and nothing else.
Scene floor_only() {
  Scene s;
  s.prims.push_back(Primitive::plane({0, 1, 0}, {0, -1, 0}, {1, 0, 0}, grey(), "floor"));
  return s;
}

// The closed form of a floor point at distance h from an infinite wall, radius r, a = h / r < 1.
double wall_ao(double a) { return 1 - (std::acos(a) - a * std::sqrt(1 - a * a)) / kPi; }

}  // namespace

TEST(AoGroundTruth, FloorPointNearAnInfiniteWallMatchesTheClosedForm) {
  const Vec3 p{0, 1, 5}, up{0, -1, 0};
  for (double a : {0.1, 0.3, 0.5, 0.8, 0.95}) {
    Scene s = floor_only();
    const double r = 0.7;
    s.prims.push_back(Primitive::plane({a * r, 0, 0}, {-1, 0, 0}, {0, 0, 1}, grey(), "wall"));
    const double ao = ao_at(s, {}, p, up, r, 4096, 7);
    EXPECT_NEAR(ao, wall_ao(a), 3e-3) << "a = " << a;
  }
  // Beyond the radius the wall does not occlude at all.
  Scene s = floor_only();
  s.prims.push_back(Primitive::plane({1.2, 0, 0}, {-1, 0, 0}, {0, 0, 1}, grey(), "wall"));
  EXPECT_EQ(ao_at(s, {}, p, up, 1.0, 1024, 7), 1.0);
}

TEST(AoGroundTruth, PointUnderASphereMatchesTheClosedForm) {
  const Vec3 p{0.3, 1, 4}, up{0, -1, 0};
  const double inf = std::numeric_limits<double>::infinity();
  for (double ratio : {1.5, 2.0, 4.0}) {
    Scene s = floor_only();
    const double R = 0.25, d = ratio * R;
    s.prims.push_back(Primitive::sphere(p + up * d, R, grey(), "ball"));
    EXPECT_NEAR(ao_at(s, {}, p, up, inf, 4096, 3), 1 - (R / d) * (R / d), 3e-3) << "d / R = " << ratio;
  }
}

TEST(AoGroundTruth, RenderedFloorBesideAWallFollowsTheClosedFormPerPixel) {
  // A level camera 1 m above the floor looking along +z at a wall x = 0.4 on the right; every
  // pixel that sees the floor has a = (0.4 − x) / r.
  Scene s = floor_only();
  s.prims.push_back(Primitive::plane({0.4, 0, 0}, {-1, 0, 0}, {0, 0, 1}, grey(), "wall"));
  LensCamera cam;
  cam.width = 48;
  cam.height = 32;
  cam.hfov_deg = 70;
  const double r = 0.5;
  const Image ao = render_ao(s, cam, r, 2048, 1);
  const Frame pin = render_pinhole(s, cam, 0);
  const double f = cam.f_px();
  int checked = 0;
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) {
      const double z = pin.depth.at(x, y);
      const double px = (x + 0.5 - 0.5 * cam.width) / f * z, py = (y + 0.5 - 0.5 * cam.height) / f * z;
      if (std::abs(py - 1) > 1e-6 || px > 0.4 - 1e-6) continue;  // not on the floor
      const double a = (0.4 - px) / r;
      EXPECT_NEAR(ao.at(x, y), a >= 1 ? 1.0 : wall_ao(a), 5e-3) << x << "," << y;
      ++checked;
    }
  EXPECT_GT(checked, 100);
}

TEST(AoGroundTruth, SkyIsOneAndTheResultDoesNotDependOnThreads) {
  const Scene s = build_scene("ao_shelf");
  SceneOptions o;
  o.width = 40;
  o.height = 24;
  const LensCamera cam = camera_for(s, o);
  Image a, b;
  core::with_threads(1, [&] { a = render_ao(s, cam, 0.3, 16, 5); });
  core::with_threads(2, [&] { b = render_ao(s, cam, 0.3, 16, 5); });
  EXPECT_EQ(a.data(), b.data());
  // A scene with sky: the background pixels are 1.
  Scene open = floor_only();
  LensCamera up = cam;
  const Image ao = render_ao(open, up, 0.5, 16, 1);
  const Frame pin = render_pinhole(open, up, 0);
  for (std::size_t i = 0; i < ao.plane_size(); ++i)
    if (std::isinf(pin.depth.plane(0)[i])) EXPECT_EQ(ao.plane(0)[i], 1.0f);
}

TEST(AoGroundTruth, TwoSeedsAgreeOnAnAoScene) {
  const Scene s = build_scene("ao_corner");
  SceneOptions o;
  o.width = 64;
  o.height = 36;
  const LensCamera cam = camera_for(s, o);
  const Image a = render_ao(s, cam, 0.5, 1024, 1), b = render_ao(s, cam, 0.5, 1024, 2);
  const Frame pin = render_pinhole(s, cam, 0);
  EXPECT_GE(metrics::compare_ao(a, b, pin.depth).psnr_db, 40.0);
}

TEST(AoGroundTruth, BadArgumentsAreUsageErrors) {
  const Scene s = floor_only();
  LensCamera cam;
  cam.width = 8;
  cam.height = 8;
  for (double r : {0.0, -1.0, std::nan("")}) {
    try {
      render_ao(s, cam, r, 16, 1);
      ADD_FAILURE() << "radius " << r << " accepted";
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::usage);
    }
  }
  EXPECT_THROW(render_ao(s, cam, 0.5, 0, 1), Error);
}

TEST(OrientedBox, AxisAlignedOrientedBoxRendersLikeTheBox) {
  Scene a, b;
  a.prims.push_back(Primitive::box({-0.4, -0.3, 2.0}, {0.5, 0.6, 2.7}, grey()));
  b.prims.push_back(Primitive::oriented_box({0.05, 0.15, 2.35}, {0.45, 0.45, 0.35}, {1, 0, 0}, {0, 1, 0}, grey()));
  LensCamera cam;
  cam.width = 64;
  cam.height = 48;
  const Frame fa = render_pinhole(a, cam, 0), fb = render_pinhole(b, cam, 0);
  int hits = 0;
  for (std::size_t i = 0; i < fa.depth.plane_size(); ++i) {
    const float za = fa.depth.plane(0)[i], zb = fb.depth.plane(0)[i];
    ASSERT_EQ(std::isinf(za), std::isinf(zb)) << i;
    if (std::isinf(za)) continue;
    EXPECT_NEAR(za, zb, 1e-5f * za);
    ++hits;
  }
  EXPECT_GT(hits, 500);
}

TEST(OrientedBox, NormalsPointOutOfEachFace) {
  const Vec3 u{std::cos(0.5), 0, std::sin(0.5)}, v{0, 1, 0};
  const Primitive p = Primitive::oriented_box({1, 2, 3}, {0.2, 0.3, 0.4}, u, v, grey());
  const Vec3 w{u.y * v.z - u.z * v.y, u.z * v.x - u.x * v.z, u.x * v.y - u.y * v.x};
  const Vec3 c{1, 2, 3};
  EXPECT_NEAR(dot(normal_at(p, c + u * 0.2), u), 1, 1e-12);
  EXPECT_NEAR(dot(normal_at(p, c - v * 0.3), v), -1, 1e-12);
  EXPECT_NEAR(dot(normal_at(p, c + w * 0.4), w), 1, 1e-12);
  // A ray towards the centre enters through the face it aims at.
  const Vec3 o = c + u * 2.0;
  EXPECT_NEAR(intersect(p, o, u * -1.0), 1.8, 1e-12);
}

TEST(PitchScene, TurningDownAndBackRestoresThePicture) {
  Scene s = build_scene("ao_corner");
  Scene back = s;
  pitch_scene(back, -s.pitch_deg);
  pitch_scene(back, s.pitch_deg);
  EXPECT_DOUBLE_EQ(back.pitch_deg, s.pitch_deg);
  LensCamera cam;
  cam.width = 48;
  cam.height = 27;
  cam.hfov_deg = s.hfov_deg;
  const Frame a = render_pinhole(s, cam, 0), b = render_pinhole(back, cam, 0);
  int differ = 0;
  for (std::size_t i = 0; i < a.depth.plane_size(); ++i)
    if (std::abs(a.depth.plane(0)[i] - b.depth.plane(0)[i]) > 1e-4f * a.depth.plane(0)[i]) ++differ;
  EXPECT_LE(differ, 2);  // only pixels exactly on an edge may flip
}

TEST(GBuffer, ChannelsAreConsistentWithThePinholeRender) {
  for (const std::string& name : ao_scene_names()) {
    const Scene s = build_scene(name);
    SceneOptions o;
    o.width = 64;
    o.height = 36;
    const LensCamera cam = camera_for(s, o);
    const GBuffer g = render_gbuffer(s, cam);
    const Frame pin = render_pinhole(s, cam, 0);
    EXPECT_EQ(g.z.data(), pin.depth.data()) << name;
    const double f = cam.f_px();
    for (int y = 0; y < cam.height; ++y)
      for (int x = 0; x < cam.width; ++x) {
        if (std::isinf(g.z.at(x, y))) continue;
        const double nx = g.normal.at(x, y, 0), ny = g.normal.at(x, y, 1), nz = g.normal.at(x, y, 2);
        EXPECT_NEAR(nx * nx + ny * ny + nz * nz, 1.0, 1e-5);
        // Facing the camera: the direction to the camera in the files' space is
        // −((x + 0.5 − W/2)/f, −(y + 0.5 − H/2)/f, −1).
        const double to_cam = -(nx * (x + 0.5 - 0.5 * cam.width) / f - ny * (y + 0.5 - 0.5 * cam.height) / f - nz);
        EXPECT_GT(to_cam, 0.0) << name << " " << x << "," << y;
        for (int c = 0; c < 3; ++c) {
          EXPECT_GE(g.albedo.at(x, y, c), 0.0f);
          EXPECT_LE(g.albedo.at(x, y, c), 1.0f);
        }
      }
  }
}

TEST(AoScenes, HaveNoSkyAndAKnownRadius) {
  for (const std::string& name : ao_scene_names()) {
    const Scene s = build_scene(name);
    EXPECT_GT(s.ao_radius_m, 0) << name;
    SceneOptions o;
    o.width = 96;
    o.height = 54;
    const Frame pin = render_pinhole(s, camera_for(s, o), 0);
    for (float z : pin.depth.data()) ASSERT_TRUE(std::isfinite(z)) << name << " shows the sky";
  }
}
