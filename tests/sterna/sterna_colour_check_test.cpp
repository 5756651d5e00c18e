// sterna checks the input colour itself (MethodDef::checks_colour): render() does not scan the
// colour first, and sterna must find a bad sample wherever it is. The fast path tests the
// samples inside its downsample (fast_prepare.cpp: 8-texel vector quads, then a scalar tail
// that repeats the edge column on odd widths; the last row pair repeats the edge row on odd
// heights; near_upsample=bicubic and per_pixel_scale take it too); every other path
// (impl=plain, strength 0, debug views) scans the frame first. Whatever the path, a frame with one bad sample must
// render exactly like its sanitised copy. tests/robustness checks colour plane 1 and alpha on three sizes with the
// default settings; this test covers every plane, every path, and sizes whose vector part
// meets an odd last column and an odd last row.
#include <gtest/gtest.h>

#include <atomic>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "dofkit/render.hpp"
#include "methods/method.hpp"
#include "render/sanitize.hpp"

using namespace dofkit;

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// A textured frame with near, in-focus and far pixels (focus 2 m) in every column pair, so
// every quad feeds the near and the far field.
Frame frame(int w, int h) {
  Frame f;
  f.color = Image(w, h, 4, 1.0f);
  f.depth = Image(w, h, 1);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float a = 0.5f + 0.5f * std::fabs(std::cos(0.3f * x + 0.7f * y));
      for (int c = 0; c < 3; ++c)
        f.color.at(x, y, c) = a * (0.1f + 0.8f * std::fabs(std::sin(0.37f * x * (c + 1) + 0.23f * y)));
      f.color.at(x, y, 3) = a;
      const int k = (x * 7 + y * 3) % 4;
      f.depth.at(x, y) = k == 0 ? 0.5f : k == 1 ? 2.0f : k == 2 ? 8.0f : kInf;
    }
  return f;
}

// A value the sanitiser changes, cycling through the kinds (NaN, ±inf, above
// kMaxColorValue; alpha above 1 or negative). Denormals are left out: a missed one could
// round away and leave the output unchanged, so it would prove nothing here.
float hostile(int n, int ch) {
  if (ch == 3) {
    const float a[] = {kNaN, 2.0f, -0.5f, kInf};
    return a[n % 4];
  }
  const float c[] = {kNaN, kInf, -kInf, 3e20f};
  return c[n % 4];
}

RenderSettings settings(std::map<std::string, std::string> p) {
  RenderSettings s;
  s.method = "sterna";
  s.camera.model = BlurAtInfinity{2.0, 6.0};
  s.camera.max_coc_px = 12;
  s.threads = 2;
  s.params = std::move(p);
  return s;
}

std::string label(const std::map<std::string, std::string>& p) {
  std::string l = p.empty() ? "defaults" : "";
  for (const auto& [k, v] : p) l += k + "=" + v + " ";
  return l;
}

// One bad sample at every pixel and plane of a w × h frame, rendered by one reused Renderer
// (the way render() defers the check), against the render of the sanitised frame.
void expect_every_bad_sample_found(const std::map<std::string, std::string>& p, int w, int h) {
  SCOPED_TRACE(label(p) + std::to_string(w) + "x" + std::to_string(h));
  const RenderSettings s = settings(p);
  Renderer renderer(s);
  Renderer clean_renderer(s);
  const Frame good = frame(w, h);
  int checked = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int ch = 0; ch < 4; ++ch) {
        Frame bad = good;
        bad.color.at(x, y, ch) = hostile(x + 3 * y + ch, ch);
        Frame clean = bad;
        detail::sanitize_color(bad.color, clean.color);
        const Image& got = renderer.render(bad).image;
        const Image& want = clean_renderer.render(clean).image;
        ASSERT_EQ(got.data().size(), want.data().size());
        ASSERT_EQ(std::memcmp(got.data().data(), want.data().data(), got.data().size() * sizeof(float)), 0)
            << "bad sample at (" << x << ", " << y << ") plane " << ch;
        ++checked;
      }
  EXPECT_EQ(checked, 4 * w * h);
  // And the same renderer still renders a clean frame as a fresh one does.
  const Image& again = renderer.render(good).image;
  const Image fresh = render(good, s).image;
  ASSERT_EQ(again.data().size(), fresh.data().size());
  EXPECT_EQ(std::memcmp(again.data().data(), fresh.data().data(), again.data().size() * sizeof(float)), 0);
}

// Runs sterna's render the way render() does when it leaves the colour check to the method
// and returns whether the method flagged the frame.
bool method_flags(const Frame& f, const RenderSettings& s) {
  const detail::MethodDef* def = nullptr;
  for (const detail::MethodDef* m : detail::all_methods())
    if (m->name == "sterna") def = m;
  EXPECT_NE(def, nullptr);
  EXPECT_TRUE(def->checks_colour);
  const CocFunction coc_of(s.camera, f.width());
  Image coc(f.width(), f.height(), 1);
  for (int y = 0; y < f.height(); ++y) coc_of.evaluate(f.depth.row(0, y), coc.row(0, y), f.width());
  const detail::Params params("sterna", def->params, s.params);
  detail::DebugSink sink("");
  detail::Workspace workspace;
  std::atomic<bool> dirty{false};
  Image out;
  def->render({f, coc, s.camera, coc_of, params, sink, 2, workspace, &dirty}, out);
  return dirty.load();
}

}  // namespace

// The fast path's vector test (integer maxima/minima of the bit patterns) and its scalar tail
// must flag exactly the samples sample_is_sanitary rejects: the boundary values on both sides
// of every rule (denormals, FLT_MIN, kMaxColorValue and the next float, alpha 1 and the next,
// signed zeros, negative alpha, infinities, NaNs of both signs), in each of the four quad slots
// of a vector block and in the scalar tail. A false alarm would not change any output (render()
// would only sanitise and render again), so this is the test that sees one.
TEST(SternaColourCheck, FastPathFlagsExactlyTheSamplesTheSanitiserRejects) {
  const float kMin = std::numeric_limits<float>::min(), kDen = std::numeric_limits<float>::denorm_min();
  const float kMax = detail::kMaxColorValue;
  const float neg_nan = std::bit_cast<float>(std::uint32_t{0xffc00000u});
  const std::vector<float> colour = {0.0f,
                                     -0.0f,
                                     kMin,
                                     -kMin,
                                     kMax,
                                     -kMax,
                                     0.5f,
                                     kDen,
                                     -kDen,
                                     kMin / 2,
                                     std::nextafter(kMin, 0.0f),
                                     std::nextafter(kMax, kInf),
                                     -std::nextafter(kMax, kInf),
                                     kInf,
                                     -kInf,
                                     kNaN,
                                     neg_nan};
  const std::vector<float> alpha = {0.0f,
                                    -0.0f,
                                    kMin,
                                    1.0f,
                                    0.5f,
                                    kDen,
                                    -kDen,
                                    -kMin,
                                    -0.5f,
                                    std::nextafter(kMin, 0.0f),
                                    std::nextafter(1.0f, 2.0f),
                                    kInf,
                                    -kInf,
                                    kNaN,
                                    neg_nan};
  const Frame good = frame(37, 7);
  for (const auto& p : std::vector<std::map<std::string, std::string>>{{}, {{"firefly", "karis"}}}) {
    const RenderSettings s = settings(p);
    EXPECT_FALSE(method_flags(good, s)) << label(p);
    // Vector block: the quad slots TL, TR, BL, BR; the scalar tail: an even and the odd last
    // column, a middle and the last (odd) row.
    for (auto [x, y] : {std::pair{0, 0}, {1, 0}, {0, 1}, {1, 1}, {31, 5}, {33, 3}, {36, 6}, {34, 6}})
      for (int ch = 0; ch < 4; ++ch)
        for (float v : ch == 3 ? alpha : colour) {
          Frame f = good;
          f.color.at(x, y, ch) = v;
          EXPECT_EQ(method_flags(f, s), !detail::sample_is_sanitary(v, ch == 3))
              << label(p) << " value " << v << " (bits " << std::hex << std::bit_cast<std::uint32_t>(v) << std::dec
              << ") at (" << x << ", " << y << ") plane " << ch;
        }
  }
}

TEST(SternaColourCheck, FastDownsampleFindsEveryBadSample) {
  // 37×7: two 8-texel vector blocks (columns 0-31), then the scalar tail (32-36, the last
  // quad repeating column 36), and the last row pair repeating row 6. 34×4: the tail is one
  // whole quad. 16×3: vector only, odd height. 5×5: scalar only.
  for (auto [w, h] : {std::pair{37, 7}, {34, 4}, {16, 3}, {5, 5}}) expect_every_bad_sample_found({}, w, h);
  // Karis weights: the other instantiation of the row function.
  expect_every_bad_sample_found({{"firefly", "karis"}}, 37, 7);
  // Bicubic near upsampling and the per-pixel kernel scale run the fast path as well.
  expect_every_bad_sample_found({{"near_upsample", "bicubic"}}, 37, 7);
  expect_every_bad_sample_found({{"per_pixel_scale", "on"}}, 37, 7);
}

TEST(SternaColourCheck, EveryOtherPathFindsEveryBadSample) {
  for (const auto& p : std::vector<std::map<std::string, std::string>>{{{"impl", "plain"}}, {{"strength", "0"}}})
    expect_every_bad_sample_found(p, 19, 5);
}
