// Hostile numbers through dofkit::render for every registered method (issue 9): non-finite
// and extreme colour, degenerate and extreme depth, extreme cameras, degenerate image sizes.
// Contract: finite output of the right size, or a clear usage / bad-input Error — never a
// crash, hang, out-of-bounds access (run under ASan+UBSan by scripts/sanitize) or NaN.
#include <gtest/gtest.h>

#include <cstring>

#include "methods/method.hpp"
#include "render/sanitize.hpp"
#include "robustness/robustness_util.hpp"

using namespace dofkit;
using namespace dofkit::robust;

namespace {

class Hostile : public ::testing::TestWithParam<std::string> {};

std::string param_name(const ::testing::TestParamInfo<std::string>& info) {
  std::string n = info.param;
  for (char& c : n)
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  return n;
}

struct ColourCase {
  const char* name;
  std::function<void(Image&, int x, int y)> poison;  // modifies pixel (x, y)
};

// Each case poisons a checkerboard of pixels (and the (0,0) pixel, so 1x1 is hit too).
std::vector<ColourCase> colour_cases() {
  auto set_rgb = [](float v) {
    return [v](Image& c, int x, int y) {
      for (int k = 0; k < 3; ++k) c.at(x, y, k) = v;
    };
  };
  auto set_a = [](float v) { return [v](Image& c, int x, int y) { c.at(x, y, 3) = v; }; };
  return {
      {"nan_rgb", set_rgb(kNaN)},
      {"pos_inf_rgb", set_rgb(kInf)},
      {"neg_inf_rgb", set_rgb(-kInf)},
      {"flt_max_rgb", set_rgb(kFltMax)},
      {"neg_flt_max_rgb", set_rgb(-kFltMax)},
      {"negative_rgb", set_rgb(-3.0f)},
      {"zero_rgb", set_rgb(0.0f)},
      {"denormal_rgb", set_rgb(kDenorm)},
      {"nan_alpha", set_a(kNaN)},
      {"inf_alpha", set_a(kInf)},
      {"negative_alpha", set_a(-0.5f)},
      {"alpha_above_one", set_a(7.0f)},
      {"zero_alpha_coloured", set_a(0.0f)},
      {"denormal_alpha", set_a(kDenorm)},
      {"everything",
       [](Image& c, int x, int y) {
         const float v[] = {kNaN, kInf, -kInf, kFltMax, kDenorm, -1.0f};
         for (int k = 0; k < 4; ++k) c.at(x, y, k) = v[(x + 2 * y + k) % 6];
       }},
  };
}

Frame poisoned(int w, int h, const ColourCase& cc) {
  Frame f = textured_frame(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if ((x + y) % 2 == 0) cc.poison(f.color, x, y);
  return f;
}

}  // namespace

INSTANTIATE_TEST_SUITE_P(AllMethods, Hostile, ::testing::ValuesIn(method_names()), param_name);

// render() sanitises colour before any method sees it, so hostile colour on an ordinary
// frame must render (no error) and give exactly what the sanitised colour gives.
TEST_P(Hostile, NonFiniteAndExtremeColourIsSanitised) {
  for (const auto& cc : colour_cases()) {
    const Frame f = poisoned(24, 16, cc);
    const RenderSettings s = default_settings(GetParam());
    expect_finite_or_clear_error(f, s, cc.name, /*must_render=*/true);
    Frame clean = f;
    detail::sanitize_color(f.color, clean.color);
    const Outcome a = try_render(f, s), b = try_render(clean, s);
    if (a.rendered && b.rendered) {
      ASSERT_EQ(a.result.image.data().size(), b.result.image.data().size());
      EXPECT_EQ(std::memcmp(a.result.image.data().data(), b.result.image.data().data(),
                            a.result.image.data().size() * sizeof(float)),
                0)
          << cc.name << ": render of hostile colour differs from render of its sanitised copy";
    }
  }
}

TEST_P(Hostile, HostileColourOnTinyImages) {
  for (const auto& cc : colour_cases())
    for (auto [w, h] : {std::pair{1, 1}, {1, 5}, {5, 1}, {3, 2}})
      expect_finite_or_clear_error(poisoned(w, h, cc), default_settings(GetParam()), cc.name);
}

// Depth that is valid but extreme: all +inf, all at the focus, subnormal, FLT_MAX, and a
// mix of the smallest and largest values next to each other.
TEST_P(Hostile, ExtremeValidDepth) {
  struct DepthCase {
    const char* name;
    std::function<float(int x, int y)> z;
  };
  const std::vector<DepthCase> cases = {
      {"all_inf", [](int, int) { return kInf; }},
      {"all_at_focus", [](int, int) { return 2.0f; }},
      {"all_subnormal", [](int, int) { return kDenorm; }},
      {"all_flt_max", [](int, int) { return kFltMax; }},
      {"tiny_and_inf_checker", [](int x, int y) { return (x + y) % 2 ? kDenorm : kInf; }},
      {"near_clamp_everywhere", [](int, int) { return 1e-3f; }},
  };
  for (const auto& dc : cases)
    for (auto [w, h] : {std::pair{1, 1}, {2, 3}, {3, 2}, {24, 16}}) {
      Frame f = textured_frame(w, h);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) f.depth.at(x, y) = dc.z(x, y);
      expect_finite_or_clear_error(f, default_settings(GetParam()), dc.name, /*must_render=*/w >= 24);
    }
}

// NaN, zero and negative depth are a clear bad-input error naming the pixel, for every
// method (the IO layer's --invalid-depth far is the way to accept them).
TEST_P(Hostile, InvalidDepthIsBadInput) {
  for (float bad : {kNaN, 0.0f, -0.0f, -1.0f, -kInf}) {
    Frame f = textured_frame(9, 7);
    f.depth.at(4, 3) = bad;
    const Outcome o = try_render(f, default_settings(GetParam()));
    ASSERT_TRUE(o.error) << "depth " << bad << " was accepted";
    EXPECT_EQ(o.kind, ErrorKind::bad_input) << o.message;
    EXPECT_NE(o.message.find("(4, 3)"), std::string::npos) << o.message;
  }
}

// Cameras at the edge of validity: extreme f-numbers, focus just beyond the focal length or
// astronomically far, equal planes, huge radii and clamps, tiny and huge reference widths.
TEST_P(Hostile, ExtremeValidCameras) {
  struct CamCase {
    const char* name;
    CameraModel cam;
  };
  auto cam = [](CocModelKind m, double max_coc = std::numeric_limits<double>::infinity(), double ref = 0) {
    CameraModel c;
    c.model = m;
    c.max_coc_px = max_coc;
    c.reference_width_px = ref;
    return c;
  };
  const double inf = std::numeric_limits<double>::infinity();
  const std::vector<CamCase> cases = {
      // The edges of every documented range (dofkit/ranges.hpp) are valid.
      {"f_number_0.1", cam(ThinLens{50, 0.1, 2.0, 36})},
      {"f_number_1e4", cam(ThinLens{50, 1e4, 2.0, 36})},
      {"focus_just_past_focal_length", cam(ThinLens{50, 2.8, 0.0500001, 36})},
      {"focus_1e30_m", cam(ThinLens{50, 2.8, 1e30, 36})},
      {"focal_length_0.1_mm", cam(ThinLens{0.1, 2.8, 2.0, 36})},
      {"focal_length_1e5_mm", cam(ThinLens{1e5, 0.1, 1e3, 0.1})},
      {"sensor_0.1_mm", cam(ThinLens{50, 2.8, 2.0, 0.1})},
      {"sensor_1e4_mm", cam(ThinLens{50, 2.8, 2.0, 1e4})},
      {"smallest_thin_lens_k", cam(ThinLens{0.1, 1e4, 1e30, 1e4})},
      {"largest_thin_lens_k", cam(ThinLens{1e5, 0.1, 100.0000001, 0.1}, inf, 1e9)},
      {"blur_at_inf_1e9", cam(BlurAtInfinity{2.0, 1e9})},
      {"blur_at_inf_0", cam(BlurAtInfinity{2.0, 0.0})},
      {"focus_1e-6", cam(BlurAtInfinity{1e-6, 8.0})},
      {"focus_1e30", cam(BlurAtInfinity{1e30, 8.0})},
      {"planes_sharp_equal", cam(FourPlane{0.5, 2.0, 2.0, 20.0, 16, 8, false})},
      {"planes_far_blurry_inf", cam(FourPlane{0.5, 2.0, 4.0, inf, 16, 8, false})},
      {"planes_far_blurry_inf_inverse", cam(FourPlane{0.5, 2.0, 4.0, inf, 16, 8, true})},
      {"planes_nearly_equal", cam(FourPlane{1.0, 1.0000001, 1.0000001, 1.0000002, 1e6, 1e6, true})},
      {"planes_radius_1e9", cam(FourPlane{0.5, 2.0, 4.0, 20.0, 1e9, 1e9, false})},
      {"planes_1e-6_to_1e30", cam(FourPlane{1e-6, 2e-6, 1e29, 1e30, 16, 8, true})},
      {"starcraft_amount_1e6", cam(StarCraft{2.0, 0.0, 1e-9, 1e6, 1e9})},
      {"starcraft_zero_amount", cam(StarCraft{2.0, 0.5, 5.0, 0.0, 16})},
      {"near_far_degenerate", cam(NearFarBlend{0.0, 2.0, 2.0, 2.0000001, 1e9})},
      {"max_coc_1e-3", cam(BlurAtInfinity{2.0, 8.0}, 1e-3)},
      {"max_coc_1e9", cam(BlurAtInfinity{2.0, 1e9}, 1e9)},
      {"reference_width_1", cam(BlurAtInfinity{2.0, 1e9}, inf, 1)},
      {"reference_width_1e9", cam(BlurAtInfinity{2.0, 8.0}, inf, 1e9)},
  };
  for (const auto& cc : cases)
    for (auto [w, h] : {std::pair{1, 1}, {5, 5}, {33, 9}}) {
      RenderSettings s = default_settings(GetParam());
      s.camera = cc.cam;
      expect_finite_or_clear_error(textured_frame(w, h), s, cc.name, /*must_render=*/w >= 33);
    }
}

TEST_P(Hostile, InvalidCamerasAreUsageErrors) {
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  const std::vector<std::pair<const char*, CocModelKind>> cases = {
      {"f_number_0", ThinLens{50, 0.0, 2.0, 36}},
      {"f_number_negative", ThinLens{50, -2.8, 2.0, 36}},
      {"f_number_nan", ThinLens{50, nan, 2.0, 36}},
      {"f_number_inf", ThinLens{50, inf, 2.0, 36}},
      {"focus_at_focal_length", ThinLens{50, 2.8, 0.05, 36}},
      {"focus_inf", ThinLens{50, 2.8, inf, 36}},
      {"focus_nan", BlurAtInfinity{nan, 8}},
      {"focus_0", BlurAtInfinity{0.0, 8}},
      {"k_negative", BlurAtInfinity{2.0, -1}},
      {"k_inf", BlurAtInfinity{2.0, inf}},
      {"planes_near_equal", FourPlane{2.0, 2.0, 4.0, 20.0, 16, 8, false}},
      {"planes_reversed", FourPlane{20.0, 4.0, 2.0, 0.5, 16, 8, false}},
      {"planes_nan", FourPlane{nan, 2.0, 4.0, 20.0, 16, 8, false}},
      {"starcraft_none_eq_full", StarCraft{2.0, 1.0, 1.0, 1.0, 16}},
      {"near_far_nan_radius", NearFarBlend{1.0, 2.0, 2.0, 3.0, nan}},
      // Issue 37, finding 1: subnormal and overflowing camera numbers (the reference and the
      // scatter crashed, the other methods gave NaN radii).
      {"f_number_1e-320", ThinLens{50, 1e-320, 4.0, 36}},
      {"sensor_1e-320", ThinLens{50, 2.8, 4.0, 1e-320}},
      {"focal_length_1e6", ThinLens{1e6, 2.8, 4.0, 36}},
      {"focal_length_1e-320", ThinLens{1e-320, 2.8, 4.0, 36}},
      {"k_1e300", BlurAtInfinity{4.0, 1e300}},
      {"k_subnormal", BlurAtInfinity{4.0, 1e-320}},
      {"focus_1e-320", BlurAtInfinity{1e-320, 8}},
      {"focus_1e31", BlurAtInfinity{1e31, 8}},
      {"f_number_just_below", ThinLens{50, 0.0999, 2.0, 36}},
      {"f_number_just_above", ThinLens{50, 10001, 2.0, 36}},
      {"planes_radius_1e10", FourPlane{0.5, 2.0, 4.0, 20.0, 1e10, 8, false}},
      {"starcraft_amount_inf", StarCraft{2.0, 0.5, 5.0, inf, 16}},
      {"near_far_radius_1e30", NearFarBlend{0.0, 2.0, 2.0, 3.0, 1e30}},
  };
  for (const auto& [name, model] : cases) {
    RenderSettings s = default_settings(GetParam());
    s.camera.model = model;
    const Outcome o = try_render(textured_frame(5, 5), s);
    ASSERT_TRUE(o.error) << name << " was accepted";
    EXPECT_EQ(o.kind, ErrorKind::usage) << name << ": " << o.message;
  }
  for (double max_coc : {0.0, -1.0, nan, 1e-320, 1e-6, 1e30}) {
    RenderSettings s = default_settings(GetParam());
    s.camera.max_coc_px = max_coc;
    const Outcome o = try_render(textured_frame(5, 5), s);
    ASSERT_TRUE(o.error) << "max_coc " << max_coc << " was accepted";
    EXPECT_EQ(o.kind, ErrorKind::usage) << o.message;
  }
  // --reference-width 1e-300 with --blur-at-infinity 1e300 (K · W / ref overflowed, even
  // with --max-coc 10), and every reference width outside [1, 1e9].
  for (double ref : {1e-300, 1e-320, 0.5, 1e30, inf, -1.0, nan}) {
    RenderSettings s = default_settings(GetParam());
    s.camera.model = BlurAtInfinity{4.0, 8.0};
    s.camera.reference_width_px = ref;
    s.camera.max_coc_px = 10;
    const Outcome o = try_render(textured_frame(5, 5), s);
    ASSERT_TRUE(o.error) << "reference width " << ref << " was accepted";
    EXPECT_EQ(o.kind, ErrorKind::usage) << o.message;
    EXPECT_NE(o.message.find("--reference-width"), std::string::npos) << o.message;
  }
  // --threads beyond 1024 (12,000,000 crashed, 4,000,000 took 2.1 GB) and negative.
  for (int threads : {-1, 1025, 100000, 12000000}) {
    RenderSettings s = default_settings(GetParam());
    s.threads = threads;
    const Outcome o = try_render(textured_frame(5, 5), s);
    ASSERT_TRUE(o.error) << threads << " threads were accepted";
    EXPECT_EQ(o.kind, ErrorKind::usage) << o.message;
    EXPECT_NE(o.message.find("--threads"), std::string::npos) << o.message;
  }
}

// The first command of finding 1 as the library sees it: focus 4 m, f/1e-320 on a 64x48 frame
// — a usage error naming --f-number, for every method (before: a crash in the disc scatter,
// NaN radii in the other methods).
TEST_P(Hostile, SubnormalFNumberIsRefusedByName) {
  RenderSettings s = default_settings(GetParam());
  s.camera.model = ThinLens{50, 1e-320, 4.0, 36};
  const Outcome o = try_render(textured_frame(64, 48), s);
  ASSERT_TRUE(o.error);
  EXPECT_EQ(o.kind, ErrorKind::usage);
  EXPECT_NE(o.message.find("--f-number 1e-320: must be 0.1 to 10000"), std::string::npos) << o.message;
}

// A camera made without validate() (CocFunction directly) still never gives a NaN radius: K
// beyond 1e300 px is capped, so inf · 0 at the focus depth cannot happen.
TEST(HostileCoc, NonFiniteThinLensGivesNoNaN) {
  CameraModel c;
  c.model = ThinLens{50, 1e-320, 4.0, 36};
  const CocFunction f(c, 64);
  for (float z : {0.5f, 4.0f, 100.0f, std::numeric_limits<float>::infinity()}) EXPECT_FALSE(std::isnan(f(z))) << z;
  c.model = BlurAtInfinity{4.0, std::numeric_limits<double>::quiet_NaN()};
  const CocFunction g(c, 64);
  EXPECT_FALSE(std::isnan(g(4.0f)));
}

// Degenerate shapes: single pixels, single rows/columns, sizes below any tile or reduction
// factor, odd sizes, with the largest radius the clamp allows (the absolute cap is
// max(W/4, 8) px, so a 1x1 image still gets an 8 px disc).
TEST_P(Hostile, DegenerateSizes) {
  const std::vector<std::pair<int, int>> sizes = {{1, 1}, {1, 2},  {2, 1},  {1, 7},  {7, 1},  {2, 3},
                                                  {3, 2}, {5, 5},  {1, 64}, {64, 1}, {17, 3}, {3, 17},
                                                  {7, 7}, {15, 9}, {31, 2}, {2, 31}};
  for (auto [w, h] : sizes) {
    RenderSettings s = default_settings(GetParam());
    s.camera.model = BlurAtInfinity{2.0, 1e6};  // every radius at the clamp
    s.camera.max_coc_px = std::numeric_limits<double>::infinity();
    expect_finite_or_clear_error(textured_frame(w, h), s, "max_radius");
    expect_finite_or_clear_error(textured_frame(w, h), default_settings(GetParam()), "default_camera");
    for (int threads : {1, 3}) {
      RenderSettings t = default_settings(GetParam());
      t.threads = threads;
      expect_finite_or_clear_error(textured_frame(w, h), t, "threads_" + std::to_string(threads));
    }
  }
}

// One Renderer over frames of changing size: its kept buffers must be re-shaped, never read
// stale or out of bounds, and every frame must equal a fresh one-shot render.
TEST_P(Hostile, RendererReusedAcrossSizes) {
  const RenderSettings s = default_settings(GetParam());
  Renderer renderer(s);
  for (auto [w, h] : {std::pair{33, 9}, {1, 1}, {5, 5}, {33, 9}, {2, 3}, {64, 1}, {24, 16}}) {
    SCOPED_TRACE(size_text(w, h));
    const Frame f = textured_frame(w, h);
    const Outcome fresh = try_render(f, s);
    try {
      const RenderResult& r = renderer.render(f);
      ASSERT_TRUE(fresh.rendered) << "one-shot render refused what the Renderer accepted: " << fresh.message;
      ASSERT_EQ(r.image.data().size(), fresh.result.image.data().size());
      EXPECT_EQ(
          std::memcmp(r.image.data().data(), fresh.result.image.data().data(), r.image.data().size() * sizeof(float)),
          0)
          << "reused Renderer output differs from a fresh render";
    } catch (const Error& e) {
      EXPECT_TRUE(fresh.error) << "Renderer threw but one-shot render did not: " << e.what();
    }
  }
}

// Renderer::set_camera between frames (a focus pull): each frame equals a fresh one-shot
// render with that camera, the buffers are kept, and an inconsistent camera is refused
// without replacing the one in use.
TEST_P(Hostile, RendererSetCameraBetweenFrames) {
  RenderSettings s = default_settings(GetParam());
  Renderer renderer(s);
  const Frame f = textured_frame(33, 17);
  for (double focus : {1.0, 3.0, 0.7}) {
    RenderSettings t = s;
    t.camera.model = BlurAtInfinity{focus, 6.0};
    renderer.set_camera(t.camera);
    const Outcome fresh = try_render(f, t);
    ASSERT_TRUE(fresh.rendered) << fresh.message;
    const RenderResult& r = renderer.render(f);
    ASSERT_EQ(r.image.data().size(), fresh.result.image.data().size());
    EXPECT_EQ(
        std::memcmp(r.image.data().data(), fresh.result.image.data().data(), r.image.data().size() * sizeof(float)), 0)
        << "focus " << focus;
  }
  CameraModel bad;
  bad.model = ThinLens{50.0, -2.0, 4.0, 36.0};  // f-number <= 0
  EXPECT_THROW(renderer.set_camera(bad), Error);
  EXPECT_NO_THROW(renderer.render(f));
  EXPECT_EQ(std::get<BlurAtInfinity>(renderer.settings().camera.model).focus_distance_m, 0.7);
}

// Every declared debug view on tiny and degenerate frames: produced, right size, no crash.
TEST_P(Hostile, DebugViewsOnTinyFrames) {
  for (const auto& m : methods()) {
    if (m.name != GetParam()) continue;
    for (const auto& view : m.debug_views)
      for (auto [w, h] : {std::pair{1, 1}, {2, 3}, {9, 7}}) {
        SCOPED_TRACE(view.name + " " + size_text(w, h));
        RenderSettings s = default_settings(m.name);
        s.debug_view = view.name;
        const Outcome o = try_render(textured_frame(w, h), s);
        if (o.error) {
          EXPECT_NE(o.kind, ErrorKind::internal) << o.message;
          continue;
        }
        EXPECT_FALSE(o.result.debug.empty()) << "debug view not produced";
        EXPECT_GT(o.result.debug.channels(), 0);
      }
  }
}

// Rules of the colour sanitiser itself.
TEST(Sanitize, Rules) {
  Image in(8, 1, 4, 0.5f);
  const float rgb[8] = {kNaN, kInf, -kInf, kFltMax, -kFltMax, kDenorm, -kDenorm, 2.5f};
  const float a[8] = {kNaN, kInf, -kInf, 7.0f, -0.5f, kDenorm, 0.25f, 1.0f};
  for (int x = 0; x < 8; ++x) {
    for (int c = 0; c < 3; ++c) in.at(x, 0, c) = rgb[x];
    in.at(x, 0, 3) = a[x];
  }
  EXPECT_FALSE(detail::color_is_sanitary(in));
  Image out;
  EXPECT_EQ(detail::sanitize_color(in, out), 7u * 3 + 6);  // all but the last colour; alpha 0.25 and 1 stay
  const float M = detail::kMaxColorValue;
  const float want_rgb[8] = {0, M, -M, M, -M, 0, 0, 2.5f};
  const float want_a[8] = {0, 1, 0, 1, 0, 0, 0.25f, 1};
  for (int x = 0; x < 8; ++x) {
    for (int c = 0; c < 3; ++c) EXPECT_EQ(out.at(x, 0, c), want_rgb[x]) << x;
    EXPECT_EQ(out.at(x, 0, 3), want_a[x]) << x;
  }
  EXPECT_TRUE(detail::color_is_sanitary(out));
  // Ordinary HDR colour, negatives within range and -0 are left alone: no copy is made.
  Image ok(3, 2, 4, 1.0f);
  ok.at(0, 0, 0) = 1e9f;
  ok.at(1, 0, 1) = -2.0f;
  ok.at(2, 1, 2) = -0.0f;
  EXPECT_TRUE(detail::color_is_sanitary(ok));
  Frame f;
  f.color = ok;
  f.depth = Image(3, 2, 1, 1.0f);
  Frame scratch;
  EXPECT_EQ(&detail::sanitized_frame(f, scratch), &f);
}

TEST(Sanitize, LayerDepthMustBeValid) {
  Frame f = textured_frame(4, 3);
  f.layer_color = {f.color};
  f.layer_depth = {Image(4, 3, 1, kInf)};
  EXPECT_NO_THROW(validate_frame(f));
  f.layer_depth[0].at(2, 1) = kNaN;
  try {
    validate_frame(f);
    FAIL() << "NaN layer depth accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::bad_input);
    EXPECT_NE(std::string(e.what()).find("layer 0"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("(2, 1)"), std::string::npos) << e.what();
  }
}

// A Renderer refuses a frame with invalid depth anywhere (the count covers every row of
// every worker's share, the first bad pixel is named, with validate_frame's message, colour that would need sanitising
// does not mask it), and a renderer whose frame was refused renders the next valid frame exactly like a fresh one.
TEST(Sanitize, RendererDepthScanCountsEveryRowAndRecovers) {
  const Frame good = textured_frame(64, 100);
  Frame bad = good;
  bad.depth.at(5, 0) = kNaN;
  bad.depth.at(6, 40) = -1.0f;
  bad.depth.at(7, 99) = 0.0f;
  for (const std::string& method : method_names()) {  // every method of this build
    SCOPED_TRACE(method);
    RenderSettings s = default_settings(method);
    s.threads = 2;
    Renderer renderer(s);
    renderer.render(good);
    try {
      renderer.render(bad);
      FAIL() << "invalid depth accepted";
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::bad_input);
      const std::string m = e.what();
      EXPECT_NE(m.find("depth has 3 NaN, zero or negative"), std::string::npos) << m;
      EXPECT_NE(m.find("(5, 0)"), std::string::npos) << m;
      // render() checks the depth in its parallel CoC pass; the message is validate_frame's.
      try {
        validate_frame(bad);
        ADD_FAILURE() << "validate_frame accepted invalid depth";
      } catch (const Error& v) {
        EXPECT_EQ(m, std::string(v.what()));
      }
    }
    // Hostile colour as well: the depth error is still raised.
    Frame both = bad;
    both.color.at(1, 1, 0) = kNaN;
    EXPECT_THROW(renderer.render(both), Error);
    const Image again = renderer.render(good).image;
    const RenderResult fresh = render(good, s);
    ASSERT_EQ(again.data().size(), fresh.image.data().size());
    EXPECT_EQ(std::memcmp(again.data().data(), fresh.image.data().data(), again.data().size() * sizeof(float)), 0);
    EXPECT_EQ(std::memcmp(renderer.render(good).coc.data().data(), fresh.coc.data().data(),
                          fresh.coc.data().size() * sizeof(float)),
              0);
  }
}

// A method with MethodDef::checks_colour tests the colour itself, inside one of its passes,
// instead of render()'s separate scan. Its test must see every sample: one bad sample
// anywhere (every pixel of frames whose sides are and are not multiples of the passes' block
// and vector sizes, every plane, a NaN and an out-of-range value; the default settings and
// impl=plain) must give
// exactly the render of the sanitised frame, and the hostile frame's debug view must be the
// sanitised frame's as well (the first try's views are discarded).
TEST(Sanitize, MethodsThatCheckColourThemselvesSeeEverySample) {
  for (const detail::MethodDef* m : detail::all_methods()) {
    if (!m->checks_colour) continue;
    SCOPED_TRACE(m->name);
    // The default settings on four sizes; the plain passes (whose check is a separate path)
    // on the first size.
    std::vector<std::pair<RenderSettings, std::vector<std::pair<int, int>>>> configs;
    configs.push_back({default_settings(m->name), {{13, 9}, {16, 8}, {37, 7}}});
    if (std::any_of(m->params.begin(), m->params.end(), [](const ParamInfo& p) { return p.name == "impl"; })) {
      RenderSettings plain = default_settings(m->name);
      plain.params["impl"] = "plain";
      configs.push_back({plain, {{13, 9}}});
    }
    for (auto& [s, sizes] : configs)
      for (auto [w, h] : sizes) {
        s.threads = 2;
        Renderer renderer(s), reference(s);
        const Frame good = textured_frame(w, h);
        int checked = 0;
        for (int y = 0; y < h; ++y)
          for (int x = 0; x < w; ++x)
            for (int ch = 0; ch < 4; ++ch) {
              Frame bad = good;
              bad.color.at(x, y, ch) = (x + y) % 2 ? kNaN : (ch == 3 ? 2.0f : kInf);
              Frame clean = bad;
              detail::sanitize_color(bad.color, clean.color);
              const Image& got = renderer.render(bad).image;
              const Image& want = reference.render(clean).image;
              ASSERT_EQ(got.data().size(), want.data().size());
              ASSERT_EQ(std::memcmp(got.data().data(), want.data().data(), got.data().size() * sizeof(float)), 0)
                  << w << "x" << h << " bad sample at (" << x << ", " << y << ") plane " << ch
                  << (s.params.count("impl") ? " impl=plain" : "");
              ++checked;
            }
        EXPECT_EQ(checked, 4 * w * h);
      }
    for (const DebugViewInfo& view : m->debug_views) {
      RenderSettings d = default_settings(m->name);
      d.debug_view = view.name;
      Frame bad = textured_frame(20, 12);
      bad.color.at(19, 11, 0) = kNaN;
      Frame clean = bad;
      detail::sanitize_color(bad.color, clean.color);
      const RenderResult a = render(bad, d), b = render(clean, d);
      ASSERT_EQ(a.debug.data().size(), b.debug.data().size()) << view.name;
      EXPECT_EQ(std::memcmp(a.debug.data().data(), b.debug.data().data(), a.debug.data().size() * sizeof(float)), 0)
          << view.name;
    }
  }
}
