// Properties of the reference method (depth-ordered disc scatter) and of the depth-blind
// scatter baseline.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "dofkit/render.hpp"
#include "core/aperture.hpp"
#include "methods/reference/disc_scatter.hpp"

using namespace dofkit;

namespace {

Frame make_frame(int w, int h, float z, float r = 0.5f, float g = 0.5f, float b = 0.5f) {
  Frame f;
  f.color = Image(w, h, 4);
  f.depth = Image(w, h, 1, z);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      f.color.at(x, y, 0) = r;
      f.color.at(x, y, 1) = g;
      f.color.at(x, y, 2) = b;
      f.color.at(x, y, 3) = 1.0f;
    }
  return f;
}

// Deterministic texture so that identity tests are not trivially satisfied.
void texture(Frame& f) {
  for (int y = 0; y < f.height(); ++y)
    for (int x = 0; x < f.width(); ++x)
      for (int c = 0; c < 3; ++c)
        f.color.at(x, y, c) = 0.1f + 0.8f * std::fabs(std::sin(0.37f * x * (c + 1) + 0.23f * y));
}

RenderSettings settings(double focus, double k, const char* method = "reference") {
  RenderSettings s;
  s.method = method;
  s.camera.model = BlurAtInfinity{focus, k};
  return s;
}

}  // namespace

TEST(Reference, InFocusIsIdentity) {
  Frame f = make_frame(64, 48, 4.0f);
  texture(f);
  for (int y = 0; y < 48; ++y)
    for (int x = 0; x < 64; ++x) f.depth.at(x, y) = 4.0f + 0.01f * ((x + y) % 3);  // |r| < 0.5
  const RenderResult r = render(f, settings(4.0, 8.0));
  for (int c = 0; c < 4; ++c)
    for (std::size_t i = 0; i < f.color.plane_size(); ++i) ASSERT_EQ(r.image.plane(c)[i], f.color.plane(c)[i]);
}

TEST(Reference, ConstantImageStaysConstant) {
  Frame f = make_frame(80, 60, 1.0f, 0.3f, 0.6f, 0.9f);
  for (int y = 0; y < 60; ++y)
    for (int x = 0; x < 80; ++x) f.depth.at(x, y) = (x < 40) ? 1.0f : (y < 30 ? 10.0f : 3.0f);
  const RenderResult r = render(f, settings(3.0, 6.0));
  const float want[4] = {0.3f, 0.6f, 0.9f, 1.0f};
  for (int c = 0; c < 4; ++c)
    for (std::size_t i = 0; i < f.color.plane_size(); ++i) ASSERT_NEAR(r.image.plane(c)[i], want[c], 1e-5);
}

TEST(Reference, SharpForegroundNotCoveredByBlurredBackground) {
  // Left half: in focus at 2 m. Right half: far background (r = −K·(1 − 2/50) ≈ −11.5 px), bright.
  Frame f = make_frame(96, 32, 2.0f, 0.1f, 0.2f, 0.3f);
  for (int y = 0; y < 32; ++y)
    for (int x = 48; x < 96; ++x) {
      f.depth.at(x, y) = 50.0f;
      for (int c = 0; c < 3; ++c) f.color.at(x, y, c) = 5.0f;
    }
  const RenderResult r = render(f, settings(2.0, 12.0));
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 48; ++x)
      for (int c = 0; c < 4; ++c) ASSERT_EQ(r.image.at(x, y, c), f.color.at(x, y, c)) << x << "," << y;
  // … while the background itself is blurred towards the edge (it loses nothing to the left).
  EXPECT_GT(r.image.at(50, 16, 0), 4.0f);
}

TEST(Reference, BrightFarPixelBecomesDiscWithItsEnergy) {
  const int w = 81, h = 81;
  Frame f = make_frame(w, h, 100.0f, 0, 0, 0);
  f.color.at(40, 40, 0) = 1000.0f;
  // K = 10 px, focus 1 m: a point at 100 m has r = 10·(1/100 − 1) = −9.9 px.
  const RenderResult r = render(f, settings(1.0, 10.0));
  double energy = 0, inside_min = 1e30, outside_max = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double v = r.image.at(x, y, 0), d = std::hypot(x - 40.0, y - 40.0);
      energy += v;
      if (d < 9.9 - 0.6) inside_min = std::min(inside_min, v);
      if (d > 9.9 + 0.6) outside_max = std::max(outside_max, v);
    }
  EXPECT_NEAR(energy, 1000.0, 1000.0 * 1e-3);
  EXPECT_EQ(outside_max, 0.0);
  const double flat = 1000.0 / detail::disc_area(9.9);
  EXPECT_NEAR(inside_min, flat, flat * 1e-3);  // uniform disc inside the anti-aliased rim
}

TEST(Reference, DiscAreaIsCloseToPiR2) {
  for (double r : {3.0, 7.5, 20.0}) EXPECT_NEAR(detail::disc_area(r), M_PI * r * r, 0.02 * M_PI * r * r);
  EXPECT_DOUBLE_EQ(detail::disc_area(0.5), 1.0);
}

TEST(Reference, IdenticalAcrossThreadCounts) {
  Frame f = make_frame(120, 70, 1.0f);
  texture(f);
  for (int y = 0; y < 70; ++y)
    for (int x = 0; x < 120; ++x) f.depth.at(x, y) = 0.8f + 0.05f * x + (y > 35 ? 3.0f : 0.0f);
  RenderSettings s = settings(3.0, 9.0);
  s.threads = 1;
  const RenderResult a = render(f, s);
  s.threads = 2;
  const RenderResult b = render(f, s);
  ASSERT_EQ(a.image.data(), b.image.data());
}

TEST(Reference, NearBlurSpreadsOverSharpBackground) {
  // A near bright bar in front of an in-focus dark background: the bar's blur must spread
  // outward over the background (near-field spreading), unlike far blur.
  Frame f = make_frame(96, 32, 4.0f, 0, 0, 0);
  for (int y = 0; y < 32; ++y)
    for (int x = 40; x < 56; ++x) {
      f.depth.at(x, y) = 1.0f;  // r = 4·(4/1 − 1) = 12 px
      for (int c = 0; c < 3; ++c) f.color.at(x, y, c) = 1.0f;
    }
  const RenderResult r = render(f, settings(4.0, 4.0));
  EXPECT_GT(r.image.at(36, 16, 0), 0.2f);  // 4 px outside the bar: roughly the disc fraction
  EXPECT_LT(r.image.at(36, 16, 0), 0.6f);
  EXPECT_EQ(r.image.at(10, 16, 0), 0.0f);  // far from the bar: untouched
}

TEST(Scatter, IgnoresDepthOrder) {
  // The depth-blind baseline does bleed blurred background over a sharp foreground.
  Frame f = make_frame(96, 32, 2.0f, 0.1f, 0.2f, 0.3f);
  for (int y = 0; y < 32; ++y)
    for (int x = 48; x < 96; ++x) {
      f.depth.at(x, y) = 50.0f;
      for (int c = 0; c < 3; ++c) f.color.at(x, y, c) = 5.0f;
    }
  const RenderResult r = render(f, settings(2.0, 12.0, "scatter"));
  EXPECT_GT(r.image.at(46, 16, 0), 0.5f);
}

TEST(Reference, ThinBlurredBarIsSeeThrough) {
  // A 2 px bright bar 1 m away (r = 4·(4/1 − 1) = 12 px) over a sharp grey wall at 4 m.
  // A real lens sees the wall past the bar: about 2·24/(π·12²) ≈ 11 % of the aperture is
  // blocked, so the bar's pixels must show mostly wall, not the bar at full strength.
  Frame f = make_frame(96, 32, 4.0f, 0.2f, 0.2f, 0.2f);
  for (int y = 0; y < 32; ++y)
    for (int x = 47; x < 49; ++x) {
      f.depth.at(x, y) = 1.0f;
      for (int c = 0; c < 3; ++c) f.color.at(x, y, c) = 1.0f;
    }
  const RenderResult r = render(f, settings(4.0, 4.0));
  const float v = r.image.at(47, 16, 0);
  EXPECT_GT(v, 0.22f);
  EXPECT_LT(v, 0.4f);
  // Energy of the bar spreads ±12 px: 10 px away the wall is still brightened.
  EXPECT_GT(r.image.at(37, 16, 0), 0.21f);
}

TEST(Reference, SimdLoopMatchesPlainLoop) {
  Frame f = make_frame(150, 90, 1.0f);
  texture(f);
  for (int y = 0; y < 90; ++y)
    for (int x = 0; x < 150; ++x)
      f.depth.at(x, y) = (x > 20 && x < 30) ? 0.7f : (y < 40 ? 30.0f : 1.0f + 0.04f * y) + ((x * 7 + y) % 5 == 0);
  f.depth.at(75, 10) = std::numeric_limits<float>::infinity();
  const Image coc = compute_coc(f.depth, CameraModel{BlurAtInfinity{2.5, 7.0}});
  for (bool depth_order : {true, false}) {
    detail::DiscScatterOptions a, b;
    a.depth_order = b.depth_order = depth_order;
    a.simd = true;
    b.simd = false;
    Image oa, ob;
    detail::disc_scatter(f.color, f.depth, coc, a, oa);
    detail::disc_scatter(f.color, f.depth, coc, b, ob);
    for (std::size_t i = 0; i < oa.data().size(); ++i) ASSERT_NEAR(oa.data()[i], ob.data()[i], 1e-4) << i;
  }
}

TEST(Reference, SimdLoopMatchesPlainLoopWhenDiscsExceedTheImage) {
  // Discs (up to ~27 px) larger than the image and a width that is no multiple of the source
  // block or the vector width: every span is clipped and blocks are partial.
  for (int w : {37, 5}) {
    const int h = 23;
    Frame f = make_frame(w, h, 1.0f);
    texture(f);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        f.depth.at(x, y) = ((x / 3 + y / 4) % 3 == 0) ? 0.35f : (x + y) % 7 == 0 ? 40.0f : 2.0f;
    f.depth.at(w / 2, h / 2) = std::numeric_limits<float>::infinity();
    const Image coc = compute_coc(f.depth, CameraModel{BlurAtInfinity{2.0, 6.0}});
    detail::DiscScatterOptions a, b;
    b.simd = false;
    Image oa, ob;
    detail::disc_scatter(f.color, f.depth, coc, a, oa);
    detail::disc_scatter(f.color, f.depth, coc, b, ob);
    for (std::size_t i = 0; i < oa.data().size(); ++i) ASSERT_NEAR(oa.data()[i], ob.data()[i], 1e-4) << w << ": " << i;
  }
}

// --- apertures other than the circle (core/aperture.hpp) ------------------------------------

namespace {

std::vector<std::pair<std::string, ApertureShape>> test_apertures() {
  std::vector<std::pair<std::string, ApertureShape>> v;
  ApertureShape a;
  a.blades = 5;
  a.rotation_deg = 10;
  v.push_back({"pentagon", a});
  a = {};
  a.blades = 6;
  a.curvature = 0.3;
  a.anamorphic = 1.5;
  v.push_back({"curved hexagon, anamorphic 1.5", a});
  a = {};
  a.anamorphic = 0.6;
  v.push_back({"wide oval", a});
  a = {};
  a.blades = 7;
  a.rotation_deg = -20;
  a.cat_eye = 0.8;
  v.push_back({"heptagon, cat's eye", a});
  // A grey image (a soft-edged triangle-ish blob) and an RGB one (red smaller than blue).
  auto grey = std::make_shared<Image>(21, 17, 1, 0.0f);
  for (int y = 0; y < 17; ++y)
    for (int x = 0; x < 21; ++x) grey->at(x, y) = (y >= 2 && std::abs(x - 10) <= (y - 2) * 0.7) ? 1.0f : 0.0f;
  a = {};
  a.image = grey;
  a.rotation_deg = 20;
  v.push_back({"grey image, rotated", a});
  auto rgb = std::make_shared<Image>(16, 16, 3, 0.0f);
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 16; ++x) {
      const double d = std::hypot(x - 7.5, y - 7.5);
      rgb->at(x, y, 0) = d < 5 ? 1.0f : 0.0f;
      rgb->at(x, y, 1) = d < 6.5 ? 1.0f : 0.0f;
      rgb->at(x, y, 2) = d < 8 ? 0.5f : 0.0f;
    }
  a = {};
  a.image = rgb;
  v.push_back({"RGB image", a});
  return v;
}

Frame aperture_frame(int w, int h) {
  Frame f = make_frame(w, h, 1.0f);
  texture(f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      f.depth.at(x, y) = (x > 15 && x < 24) ? 0.6f : (y < h / 2 ? 25.0f : 1.0f + 0.05f * y) + ((x * 7 + y) % 5 == 0);
  f.depth.at(w / 2, 5) = std::numeric_limits<float>::infinity();
  f.color.at(w / 3, h / 4, 0) = 40.0f;  // a highlight far behind the focus
  return f;
}

}  // namespace

TEST(Reference, SimdLoopMatchesPlainLoopForEveryAperture) {
  const Frame f = aperture_frame(61, 43);
  const Image coc = compute_coc(f.depth, CameraModel{BlurAtInfinity{2.5, 7.0}});
  for (const auto& [name, shape] : test_apertures()) {
    const core::ApertureModel model(shape, f.width(), f.height());
    for (bool depth_order : {true, false}) {
      detail::DiscScatterOptions a, b;
      a.depth_order = b.depth_order = depth_order;
      a.aperture = b.aperture = &model;
      b.simd = false;
      Image oa, ob;
      detail::disc_scatter(f.color, f.depth, coc, a, oa);
      detail::disc_scatter(f.color, f.depth, coc, b, ob);
      for (std::size_t i = 0; i < oa.data().size(); ++i)
        ASSERT_NEAR(oa.data()[i], ob.data()[i], 1e-4 * std::max(1.0f, std::fabs(ob.data()[i]))) << name << ": " << i;
    }
  }
}

TEST(Reference, EveryApertureIsIdenticalAcrossThreadCounts) {
  const Frame f = aperture_frame(70, 44);
  for (const auto& [name, shape] : test_apertures()) {
    RenderSettings s = settings(2.5, 7.0);
    s.aperture = shape;
    s.threads = 1;
    const RenderResult a = render(f, s);
    s.threads = 2;
    const RenderResult b = render(f, s);
    ASSERT_EQ(a.image.data(), b.image.data()) << name;
  }
}

TEST(Reference, EveryApertureKeepsFocusAndConstants) {
  // In focus: the identity; a constant image stays constant (energy-normalised footprints).
  for (const auto& [name, shape] : test_apertures()) {
    Frame f = make_frame(40, 30, 4.0f);
    texture(f);
    RenderSettings s = settings(4.0, 8.0);
    s.aperture = shape;
    const RenderResult r = render(f, s);
    ASSERT_EQ(r.image.data(), f.color.data()) << name;
    Frame c = make_frame(40, 30, 1.0f, 0.3f, 0.6f, 0.9f);
    for (int y = 0; y < 30; ++y)
      for (int x = 0; x < 40; ++x) c.depth.at(x, y) = x < 20 ? 1.0f : 9.0f;
    const RenderResult rc = render(c, settings(3.0, 6.0));
    RenderSettings sc = settings(3.0, 6.0);
    sc.aperture = shape;
    const RenderResult rs = render(c, sc);
    for (std::size_t i = 0; i < rs.image.data().size(); ++i)
      ASSERT_NEAR(rs.image.data()[i], rc.image.data()[i], 1e-5) << name;
  }
}

// A bright far pixel spreads over the model's far footprint with its energy; a near one over
// the footprint turned by 180°.
TEST(Reference, BrightPixelBecomesTheApertureFootprint) {
  ApertureShape shape;
  shape.blades = 5;
  shape.rotation_deg = 10;
  const core::ApertureModel model(shape, 81, 81);
  for (float z : {100.0f, 0.35f}) {  // focus 1 m, K = 10: r = −9.9 px and +18.6 px
    Frame f = make_frame(81, 81, z, 0, 0, 0);
    f.color.at(40, 40, 0) = 1000.0f;
    RenderSettings s = settings(1.0, 10.0);
    s.aperture = shape;
    const RenderResult r = render(f, s);
    const float rc = 10.0f * (1.0f / z - 1.0f);
    const core::Field field = core::field_of(rc);
    const float rho = std::fabs(rc);
    const double sum = model.weight_sum(rho, field);
    double energy = 0, worst = 0;
    for (int y = 0; y < 81; ++y)
      for (int x = 0; x < 81; ++x) {
        const double v = r.image.at(x, y, 0);
        energy += v;
        const double want = 1000.0 * model.coverage(x - 40, y - 40, rho, field) / sum;
        worst = std::max(worst, std::abs(v - want));
      }
    EXPECT_NEAR(energy, 1000.0, 1.0) << z;
    EXPECT_LT(worst, 1e-3 * 1000.0 / sum) << z;
  }
}
