// Tests of the built-in scenes and the thin-lens ray tracer (issue 3 items 1-2).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "dofkit/error.hpp"
#include "metrics/metrics.hpp"
#include "scene/raytracer.hpp"
#include "scene/scene.hpp"

using namespace dofkit;
using namespace dofkit::scene;

namespace {

constexpr double kPi = std::numbers::pi;

Texture flat(Rgb c, double emission = 1) {
  Texture t;
  t.a = c;
  t.octaves = 0;
  t.emission = emission;
  return t;
}

// A black scene with one tiny emissive sphere on the optical axis at depth z whose pinhole
// image has radius s_px at width w (hfov 60°). With radiance above 2 the sphere is an HDR
// emitter and the ground truth samples its lens region separately (raytracer.cpp).
Scene point_scene(double z, double s_px, int w, double radiance = 100) {
  Scene s;
  s.name = "point";
  s.hfov_deg = 60;
  s.background.top = s.background.horizon = {0, 0, 0};
  s.background.clouds = flat({1, 1, 1});
  const double f = 0.5 * w / std::tan(kPi / 6);
  s.prims.push_back(Primitive::sphere({0, 0, z}, s_px * z / f, flat({1, 1, 1}, radiance), "point"));
  return s;
}

double energy(const Image& img) {
  double e = 0;
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x) e += img.at(x, y, 0);
  return e;
}

SceneOptions small(int w, int h, double focus, double k, int samples) {
  SceneOptions o;
  o.width = w;
  o.height = h;
  o.focus_m = focus;
  o.blur_at_infinity_px = k;
  o.samples = samples;
  return o;
}

// Radius of the blur disc of a point imaged at the image centre, from the second moment of
// the energy: a uniform disc of radius R has E[d²] = R²/2, and the image of a sphere whose
// pinhole image is a disc of radius s is the blur disc convolved with that small disc, whose
// second moments add: E[d²] = (R² + s²)/2. Uses every pixel, so it is robust to the noise of
// individual pixels.
double measured_disc_radius(const Image& img, double s_px) {
  const double cx = 0.5 * img.width(), cy = 0.5 * img.height();
  double e = 0, m = 0;
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x) {
      const double v = img.at(x, y, 0), dx = x + 0.5 - cx, dy = y + 0.5 - cy;
      e += v;
      m += v * (dx * dx + dy * dy);
    }
  return std::sqrt(std::max(0.0, 2 * m / e - s_px * s_px));
}

// Bilinear sample of plane 0 at continuous image position (x, y) (pixel centres at +0.5).
double bilinear(const Image& img, double x, double y) {
  x -= 0.5;
  y -= 0.5;
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  const double fx = x - x0, fy = y - y0;
  auto at = [&](int xi, int yi) {
    xi = std::clamp(xi, 0, img.width() - 1);
    yi = std::clamp(yi, 0, img.height() - 1);
    return static_cast<double>(img.at(xi, yi, 0));
  };
  return (1 - fy) * ((1 - fx) * at(x0, y0) + fx * at(x0 + 1, y0)) +
         fy * ((1 - fx) * at(x0, y0 + 1) + fx * at(x0 + 1, y0 + 1));
}

// Is the 3-D point x on the surface of p (within tol metres)? Written independently of the
// intersection code (implicit surface tests).
bool on_surface(const Primitive& p, Vec3 x, double tol) {
  switch (p.kind) {
    case Primitive::Kind::plane:
      return std::abs(dot(x - p.p0, p.p1)) < tol;
    case Primitive::Kind::sphere:
      return std::abs(std::sqrt(dot(x - p.p0, x - p.p0)) - p.radius) < tol;
    case Primitive::Kind::box: {
      const bool inside = x.x > p.p0.x - tol && x.x < p.p1.x + tol && x.y > p.p0.y - tol && x.y < p.p1.y + tol &&
                          x.z > p.p0.z - tol && x.z < p.p1.z + tol;
      const bool face = std::abs(x.x - p.p0.x) < tol || std::abs(x.x - p.p1.x) < tol || std::abs(x.y - p.p0.y) < tol ||
                        std::abs(x.y - p.p1.y) < tol || std::abs(x.z - p.p0.z) < tol || std::abs(x.z - p.p1.z) < tol;
      return inside && face;
    }
    case Primitive::Kind::cylinder: {
      const Vec3 ax = p.p1 - p.p0;
      const double len = std::sqrt(dot(ax, ax));
      const Vec3 u = ax * (1 / len);
      const double h = dot(x - p.p0, u);
      const Vec3 q = (x - p.p0) - u * h;
      const double rho = std::sqrt(dot(q, q));
      const bool side = std::abs(rho - p.radius) < tol && h > -tol && h < len + tol;
      const bool cap = rho < p.radius + tol && (std::abs(h) < tol || std::abs(h - len) < tol);
      return side || cap;
    }
  }
  return false;
}

}  // namespace

TEST(Camera, LensRadiusGivesBlurAtInfinity) {
  LensCamera cam;
  cam.width = 640;
  cam.hfov_deg = 60;
  cam.focus_m = 3;
  cam.k_px = 12;
  // F = 320 / tan 30° = 554.26 px; a = K z_F / F.
  EXPECT_NEAR(cam.f_px(), 554.256, 1e-3);
  EXPECT_NEAR(cam.lens_radius_m(), 12 * 3 / 554.256, 1e-6);
  EXPECT_DOUBLE_EQ(cam.coc_px(1.5), 12.0);
  EXPECT_DOUBLE_EQ(cam.coc_px(3), 0.0);
}

// A point at depth z images to a disc of radius K·|1 − z_F/z| (±0.5 px).
// Both estimators (plain lens samples; emitter regions for HDR spheres) are checked, and they
// must carry the same energy (the emitter partition is unbiased).
TEST(ThinLens, PointImagesToDiscOfTheCocRadius) {
  const int w = 48, h = 48;
  const double focus = 4, k = 10, s_px = 1.0;
  for (double z : {1.9, 2.6, 3.2, 6.0, 12.0, 40.0}) {
    const double r = k * std::abs(1 - focus / z);
    const Image plain = render_custom(point_scene(z, s_px, w, 1.5), small(w, h, focus, k, 2048), true).ground_truth;
    const Image hdr = render_custom(point_scene(z, s_px, w, 100), small(w, h, focus, k, 512), true).ground_truth;
    const double got_plain = measured_disc_radius(plain, s_px), got_hdr = measured_disc_radius(hdr, s_px);
    const double ratio = energy(hdr) / 100 / (energy(plain) / 1.5);
    std::printf(
        "z = %5.2f m: expected r = %6.3f px, measured %6.3f (plain) %6.3f (emitter regions) px, "
        "energy ratio %.4f\n",
        z, r, got_plain, got_hdr, ratio);
    EXPECT_NEAR(got_plain, r, 0.5) << "z = " << z;
    EXPECT_NEAR(got_hdr, r, 0.5) << "z = " << z;
    EXPECT_NEAR(ratio, 1.0, 0.01) << "z = " << z;  // measured within 0.42 %
  }
}

// A regular n-gon aperture gives polygonal bokeh: the boundary radius as a function of angle
// has n maxima at the vertex angles (2k+1)π/n − rotation in image axes (y down; the rotation
// turns counter-clockwise on screen, Blender's convention; far field: the aperture itself;
// near field: point-reflected), and follows the polygon within 0.7 px.
TEST(ThinLens, PolygonApertureGivesPolygonWithNCorners) {
  const int w = 64, h = 64;
  const double focus = 4, k = 16, s_px = 1.2;
  struct Case {
    int blades;
    double rot_deg, z;
  };
  for (const Case c : {Case{5, 10, 16}, Case{6, 0, 16}, Case{5, 10, 2.5}, Case{7, 25, 16}}) {
    SceneOptions opt = small(w, h, focus, k, 1024);
    opt.aperture.blades = c.blades;
    opt.aperture.rotation_deg = c.rot_deg;
    const double r = k * std::abs(1 - focus / c.z);
    const Image img = render_custom(point_scene(c.z, s_px, w), opt, true).ground_truth;
    // Interior level (centre) and the half-level boundary along 360 rays from the centre.
    double interior = 0;
    int n = 0;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        if (std::hypot(x + 0.5 - 0.5 * w, y + 0.5 - 0.5 * h) < 0.4 * r) {
          interior += img.at(x, y, 0);
          ++n;
        }
    interior /= n;
    const int m = 360;
    std::vector<double> rad(m);
    for (int i = 0; i < m; ++i) {
      const double phi = 2 * kPi * i / m;
      double t = 0.3 * r;
      while (t < 2 * r && bilinear(img, 0.5 * w + t * std::cos(phi), 0.5 * h + t * std::sin(phi)) > 0.5 * interior)
        t += 0.02;
      rad[i] = t;
    }
    const bool near = c.z < focus;
    // Counter-clockwise on screen is clockwise in these image axes (y down).
    const double rot = -c.rot_deg * kPi / 180 + (near ? kPi : 0);
    double worst = 0;
    for (int i = 0; i < m; ++i) {
      const double phi = 2 * kPi * i / m;
      // Polygon boundary: apothem / cos(angle from the nearest edge midpoint); edge midpoints
      // are at 2kπ/n + rot.
      double d = std::fmod(phi - rot, 2 * kPi / c.blades);
      if (d < 0) d += 2 * kPi / c.blades;
      d -= kPi / c.blades;
      // d is the angle from the vertex; convert to the angle from the edge midpoint.
      const double from_mid = kPi / c.blades - std::abs(d);
      const double expect = r * std::cos(kPi / c.blades) / std::cos(from_mid);
      worst = std::max(worst, std::abs(rad[i] - expect));
    }
    std::printf("%d blades, z = %.1f m: worst boundary deviation from the polygon %.3f px\n", c.blades, c.z, worst);
    // Measured 0.50 (5 blades far), 0.38, 0.40, 0.31 px. Allowed: the sphere's own 1.2 px image
    // rounds each corner by up to s·(1/sin(θ/2) − 1) ≈ 0.3 px, plus sampling noise.
    EXPECT_LT(worst, 0.75) << c.blades << " blades, z = " << c.z;
    // Count corners: circular local maxima of the smoothed boundary radius.
    std::vector<double> sm(m);
    for (int i = 0; i < m; ++i) {
      double s = 0;
      for (int j = -4; j <= 4; ++j) s += rad[(i + j + m) % m];
      sm[i] = s / 9;
    }
    int corners = 0;
    for (int i = 0; i < m; ++i) {
      bool is_max = true;
      for (int j = 1; j <= 360 / (3 * c.blades); ++j)
        if (sm[(i + j) % m] >= sm[i] || sm[(i - j + m) % m] > sm[i]) is_max = false;
      if (is_max) ++corners;
    }
    EXPECT_EQ(corners, c.blades) << c.blades << " blades, z = " << c.z;
  }
}

// A textured plane exactly at the focus distance is as sharp through the lens as through the
// pinhole: every lens ray of a pixel meets the plane at the pixel's focus-plane point.
TEST(ThinLens, InFocusPlaneIsSharp) {
  Scene s;
  s.name = "focus plane";
  Texture t;
  t.a = {0.9f, 0.6f, 0.2f};
  t.b = {0.1f, 0.2f, 0.5f};
  t.noise_scale_m = 0.3;
  t.octaves = 9;
  t.line_spacing_m = 0.05;
  t.line_width_m = 0.004;
  s.prims.push_back(Primitive::plane({0, 0, 3}, {0, 0, -1}, {1, 0, 0}, t));
  const SceneRender r = render_custom(s, small(160, 90, 3, 16, 64), true);
  double worst = 0;
  for (int c = 0; c < 3; ++c)
    for (int y = 0; y < 90; ++y)
      for (int x = 0; x < 160; ++x)
        worst =
            std::max(worst, static_cast<double>(std::abs(r.ground_truth.at(x, y, c) - r.pinhole.color.at(x, y, c))));
  EXPECT_LT(worst, 1e-5);
}

// In a built-in scene, the in-focus face of the occluder's box equals the pinhole image
// wherever no nearer object's blur disc can reach it.
TEST(ThinLens, InFocusRegionOfOccluderMatchesPinhole) {
  const SceneRender r = render_scene("occluder", [] {
    SceneOptions o;
    o.width = 160;
    o.height = 90;
    o.samples = 64;
    return o;
  }());
  const Image& z = r.pinhole.depth;
  int checked = 0;
  double worst = 0;
  const int reach = 7;  // > the largest near CoC at 160 px wide (18 / 4 = 4.5 px) + margin
  for (int y = 0; y < 90; ++y)
    for (int x = 0; x < 160; ++x) {
      if (z.at(x, y) != 3.0f) continue;
      bool clear = true;
      for (int dy = -reach; dy <= reach && clear; ++dy)
        for (int dx = -reach; dx <= reach; ++dx) {
          const int xx = std::clamp(x + dx, 0, 159), yy = std::clamp(y + dy, 0, 89);
          if (z.at(xx, yy) < 2.9f) clear = false;
        }
      if (!clear) continue;
      ++checked;
      for (int c = 0; c < 3; ++c)
        worst =
            std::max(worst, static_cast<double>(std::abs(r.ground_truth.at(x, y, c) - r.pinhole.color.at(x, y, c))));
    }
  EXPECT_GT(checked, 300);
  EXPECT_LT(worst, 1e-5);
}

// The pinhole pass point-samples pixel centres, so at every silhouette pixel the recorded
// colour is the radiance of the surface that lies at the recorded depth on the pixel-centre
// ray (checked with implicit surface tests, independent of the intersection code).
TEST(Pinhole, ColourAndDepthAgreeAtSilhouettes) {
  for (const std::string& name : scene_names()) {
    const Scene s = build_scene(name);
    SceneOptions o;
    o.width = 200;
    o.height = 112;
    const LensCamera cam = camera_for(s, o);
    const Frame f = render_pinhole(s, cam, 0);
    const double fpx = cam.f_px();
    int edges = 0;
    for (int y = 0; y < o.height; ++y)
      for (int x = 0; x < o.width; ++x) {
        const float z = f.depth.at(x, y);
        bool edge = false;
        const int nx[4] = {x - 1, x + 1, x, x}, ny[4] = {y, y, y - 1, y + 1};
        for (int k = 0; k < 4; ++k) {
          if (nx[k] < 0 || ny[k] < 0 || nx[k] >= o.width || ny[k] >= o.height) continue;
          const float z2 = f.depth.at(nx[k], ny[k]);
          if (std::isinf(z) != std::isinf(z2) || std::abs(z - z2) > 0.05f * std::min(z, z2)) edge = true;
        }
        if (!edge) continue;
        ++edges;
        const Vec3 d{(x + 0.5 - 0.5 * o.width) / fpx, (y + 0.5 - 0.5 * o.height) / fpx, 1};
        const float cr = f.color.at(x, y, 0), cg = f.color.at(x, y, 1), cb = f.color.at(x, y, 2);
        bool match = false;
        if (std::isinf(z)) {
          const Rgb bg = shade_background(s.background, d);
          match = bg.r == cr && bg.g == cg && bg.b == cb;
        } else {
          // Depth is stored as float, so the hit lies within half an ulp of z along the ray;
          // try points across [z − ulp, z + ulp] (a texture edge may pass through the exact
          // hit point, e.g. a line boundary at a pixel centre).
          const double ulp = std::nextafter(z, INFINITY) - z;
          for (int k = -2; k <= 2; ++k) {
            const Vec3 p = d * (static_cast<double>(z) + 0.5 * k * ulp);
            for (const Primitive& prim : s.prims) {
              if (!on_surface(prim, p, 2e-6 * z + 1e-9)) continue;
              const Rgb c = shade_at(prim, p);
              const double tol = 1e-4 * std::max(1.0, static_cast<double>(prim.tex.emission));
              if (std::abs(c.r - cr) < tol && std::abs(c.g - cg) < tol && std::abs(c.b - cb) < tol) match = true;
            }
          }
        }
        EXPECT_TRUE(match) << name << ": pixel " << x << "," << y << " z " << z;
        if (!match) return;
      }
    EXPECT_GT(edges, 50) << name;
  }
}

TEST(Pinhole, LayersSortedAndLayerZeroIsVisible) {
  for (const std::string& name : scene_names()) {
    SceneOptions o;
    o.width = 160;
    o.height = 90;
    o.layers = 4;
    const SceneRender r = render_pinhole(name, o);
    const Frame& f = r.pinhole;
    ASSERT_EQ(f.layer_color.size(), 4u);
    ASSERT_EQ(f.layer_depth.size(), 4u);
    EXPECT_EQ(f.layer_color[0].data(), f.color.data()) << name;
    EXPECT_EQ(f.layer_depth[0].data(), f.depth.data()) << name;
    int hidden = 0;
    for (int y = 0; y < 90; ++y)
      for (int x = 0; x < 160; ++x) {
        bool missing = false;
        for (int l = 0; l < 4; ++l) {
          const float a = f.layer_color[l].at(x, y, 3), z = f.layer_depth[l].at(x, y);
          if (l > 0) EXPECT_GE(z, f.layer_depth[l - 1].at(x, y)) << name << " " << x << "," << y << " layer " << l;
          if (a == 0) {
            missing = true;
            EXPECT_TRUE(std::isinf(z));
            EXPECT_EQ(f.layer_color[l].at(x, y, 0), 0.0f);
          } else {
            EXPECT_EQ(a, 1.0f);
            EXPECT_FALSE(missing) << "a present layer after a missing one";
            if (l > 0 && !std::isinf(z)) ++hidden;
          }
        }
      }
    EXPECT_GT(hidden, 100) << name << ": expected hidden surfaces behind the visible ones";
  }
}

TEST(Scenes, DeterministicForASeedAndAnyThreadCount) {
  SceneOptions o;
  o.width = 96;
  o.height = 54;
  o.samples = 16;
  o.layers = 2;
  o.seed = 7;
  for (const std::string& name : scene_names()) {
    o.threads = 1;
    const SceneRender a = render_scene(name, o);
    o.threads = 2;
    const SceneRender b = render_scene(name, o);
    EXPECT_EQ(a.ground_truth.data(), b.ground_truth.data()) << name;
    EXPECT_EQ(a.pinhole.color.data(), b.pinhole.color.data()) << name;
    EXPECT_EQ(a.pinhole.depth.data(), b.pinhole.depth.data()) << name;
    EXPECT_EQ(a.pinhole.layer_depth[1].data(), b.pinhole.layer_depth[1].data()) << name;
    o.seed = 8;
    const SceneRender c = render_scene(name, o);
    EXPECT_NE(a.ground_truth.data(), c.ground_truth.data()) << name << ": the seed must change the lens samples";
    o.seed = 7;
  }
}

TEST(Scenes, DefaultsScaleWithWidth) {
  for (const std::string& name : scene_names()) {
    SceneOptions a, b;
    b.width = 1280;
    b.height = 720;
    const SceneDefaults da = scene_defaults(name, a), db = scene_defaults(name, b);
    EXPECT_DOUBLE_EQ(db.blur_at_infinity_px, 2 * da.blur_at_infinity_px) << name;
    EXPECT_EQ(da.focus_m, db.focus_m);
    EXPECT_GE(da.blur_at_infinity_px, 8) << name;
    EXPECT_LE(da.blur_at_infinity_px, 16) << name;
    EXPECT_FALSE(scene_description(name).empty());
    // The camera handed to render() is the scene's thin lens at this width.
    const SceneRender r = render_pinhole(name, [] {
      SceneOptions o;
      o.width = 64;
      o.height = 36;
      return o;
    }());
    const auto* lens = std::get_if<BlurAtInfinity>(&r.camera.model);
    ASSERT_NE(lens, nullptr);
    EXPECT_DOUBLE_EQ(lens->blur_at_infinity_px, da.blur_at_infinity_px / 10);
  }
}

// Max CoC of every scene at its defaults stays within 40 px at 640 wide (the pinhole depth
// sets the visible CoCs).
TEST(Scenes, MaxCocWithinForty) {
  for (const std::string& name : scene_names()) {
    SceneOptions o;
    o.width = 320;
    o.height = 180;
    const SceneRender r = render_pinhole(name, o);
    const auto lens = std::get<BlurAtInfinity>(r.camera.model);
    double worst = 0;
    for (float z : r.pinhole.depth.data())
      worst = std::max(worst, std::abs(lens.blur_at_infinity_px * (lens.focus_distance_m / z - 1)));
    EXPECT_LE(2 * worst, 40) << name;
    EXPECT_GE(2 * worst, 8) << name;
  }
}

TEST(Scenes, BadNamesAndOptionsAreUsageErrors) {
  try {
    render_pinhole("nope", {});
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::usage);
    EXPECT_NE(std::string(e.what()).find("nope"), std::string::npos);
  }
  SceneOptions o;
  o.aperture.blades = 2;
  EXPECT_THROW(render_pinhole("fence", o), Error);
  o = {};
  o.width = 0;
  EXPECT_THROW(render_pinhole("fence", o), Error);
  o = {};
  o.focus_m = -1;
  EXPECT_THROW(render_pinhole("fence", o), Error);
}

// Two seeds are two independent unbiased estimates; their difference is the noise floor of
// the ground truth. At a reduced size (160x90) with the scenes' default sample counts.
// Measured: occluder 46.86 dB, fence 48.17 dB, highlights 54.49 dB (at 640x360 the figures are
// in docs/scenes.md). Floors are 0.3 dB below the measurement and never below 45 dB.
TEST(Scenes, TwoSeedsAgree) {
  struct Case {
    const char* name;
    double floor_db;
  };
  for (const Case c : {Case{"occluder", 46.5}, Case{"fence", 47.8}, Case{"highlights", 54.1}}) {
    SceneOptions o;
    o.width = 160;
    o.height = 90;
    o.seed = 1;
    const Image a = render_scene(c.name, o).ground_truth;
    o.seed = 2;
    const Image b = render_scene(c.name, o).ground_truth;
    const double p = metrics::psnr(a, b);
    std::printf("%s: two seeds at 160x90: %.2f dB\n", c.name, p);
    EXPECT_GE(p, std::max(45.0, c.floor_db)) << c.name;
  }
}
