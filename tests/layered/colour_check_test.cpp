// layered checks the input colour itself (MethodDef::checks_colour): render() hands it the
// unchecked frame with MethodContext::colour_dirty set, and the method must flag any sample
// that render/sanitize.hpp's rules would change — in every plane (tests/robustness only
// plants bad samples in planes 1 and 3), at every pixel including transparent ones that no
// later pass reads, in every configuration (the check rides on coc_extremes, the first pass
// of every path: the fused Gaussian stack, impl=plain, psf=disc, the per-layer path that
// serves debug views).
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "dofkit/coc.hpp"
#include "dofkit/render.hpp"
#include "methods/layered/fast.hpp"
#include "methods/method.hpp"
#include "render/sanitize.hpp"

namespace dofkit::detail {
const MethodDef& layered_method();
}

namespace {

using namespace dofkit;
constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// Near, in-focus, far and +inf depths; every 7th pixel transparent (alpha 0, colour 0) and
// every 5th half transparent, so the frame has pixels in no layer at all.
Frame frame(int w, int h) {
  Frame f;
  f.color = Image(w, h, 4, 1.0f);
  f.depth = Image(w, h, 1);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const int i = x + 3 * y;
      const float a = i % 7 == 0 ? 0.0f : (i % 5 == 0 ? 0.5f : 1.0f);
      for (int c = 0; c < 3; ++c)
        f.color.at(x, y, c) = a * (0.1f + 0.8f * std::fabs(std::sin(0.31f * x * (c + 1) + 0.17f * y)));
      f.color.at(x, y, 3) = a;
      const int k = (x * 5 + y * 3) % 4;
      f.depth.at(x, y) = k == 0 ? 0.4f : k == 1 ? 2.0f : k == 2 ? 30.0f : kInf;
    }
  return f;
}

RenderSettings settings(std::map<std::string, std::string> params, std::string view = "") {
  RenderSettings s;
  s.method = "layered";
  s.camera.model = BlurAtInfinity{2.0, 6.0};
  s.camera.max_coc_px = 12;
  s.params = std::move(params);
  s.threads = 2;
  s.debug_view = std::move(view);
  return s;
}

// One call of the method as render() makes it when it defers the check; returns the flag.
bool method_flags(const Frame& f, const RenderSettings& s) {
  const CocFunction coc_of(s.camera, f.width());
  Image coc(f.width(), f.height(), 1);
  for (int y = 0; y < f.height(); ++y)
    for (int x = 0; x < f.width(); ++x) coc.at(x, y) = coc_of(f.depth.at(x, y));
  const detail::Params params("layered", detail::find_method("layered")->params, s.params);
  detail::DebugSink sink(s.debug_view);
  detail::Workspace ws;
  std::atomic<bool> dirty{false};
  Image out(f.width(), f.height(), 4);
  detail::layered_method().render({f, coc, s.camera, coc_of, params, sink, s.threads, ws, &dirty}, out);
  return dirty.load();
}

// A bad value for plane ch, varied with the position: NaN, ±inf, out of range, subnormal.
float bad_value(int x, int y, int ch) {
  switch ((x + 2 * y + ch) % 4) {
    case 0:
      return kNaN;
    case 1:
      return ch == 3 ? 2.0f : -kInf;
    case 2:
      return ch == 3 ? -0.25f : 2e18f;
    default:
      return 1e-40f;  // subnormal
  }
}

const std::vector<std::map<std::string, std::string>>& configs() {
  static const std::vector<std::map<std::string, std::string>> c = {
      {},  // the fused Gaussian stack
      {{"impl", "plain"}},
      {{"psf", "disc"}},
      {{"fill", "under"}, {"half_res", "off"}},
  };
  return c;
}

TEST(LayeredColourCheck, CleanFrameIsNotFlagged) {
  for (const auto& p : configs()) {
    EXPECT_FALSE(method_flags(frame(37, 6), settings(p)));
    EXPECT_FALSE(method_flags(frame(37, 6), settings(p, "layer_1_matted")));
  }
}

// The default (fused) path's check, every pixel and every plane of frames whose widths are
// not multiples of the vector sizes (and one wider than the fused passes' 256-column blocks).
TEST(LayeredColourCheck, FusedPathFlagsEverySampleOfEveryPlane) {
  const RenderSettings s = settings({});
  for (auto [w, h] : {std::pair{13, 9}, {37, 6}, {301, 2}}) {
    const Frame good = frame(w, h);
    const std::uint64_t fused_before = detail::layered::fused_render_count();
    EXPECT_FALSE(method_flags(good, s));
    EXPECT_EQ(detail::layered::fused_render_count(), fused_before + 1);  // the path in question
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        for (int ch = 0; ch < 4; ++ch) {
          Frame bad = good;
          bad.color.at(x, y, ch) = bad_value(x, y, ch);
          ASSERT_TRUE(method_flags(bad, s)) << w << "x" << h << " (" << x << ", " << y << ") plane " << ch;
        }
  }
}

// Every configuration: corners, the last column, a transparent pixel, every plane.
TEST(LayeredColourCheck, OtherConfigurationsFlagEveryPlane) {
  const int w = 37, h = 6;
  const Frame good = frame(w, h);
  for (const auto& p : configs())
    for (const std::string view : {"", "layer_2_blurred", "front"})
      for (auto [x, y] : {std::pair{0, 0}, {w - 1, 0}, {w - 1, h - 1}, {0, h - 1}, {7, 0}, {18, 3}})
        for (int ch = 0; ch < 4; ++ch) {
          Frame bad = good;
          bad.color.at(x, y, ch) = bad_value(x, y, ch);
          ASSERT_TRUE(method_flags(bad, settings(p, view)))
              << p.size() << " params, view '" << view << "' (" << x << ", " << y << ") plane " << ch;
        }
}

// Through render(): a frame with one bad sample renders exactly like its sanitised copy, in
// all four planes (the Renderer reuses its workspace across the tries and the frames).
TEST(LayeredColourCheck, RenderOfHostileFrameEqualsSanitisedFrame) {
  for (const auto& p : configs()) {
    const RenderSettings s = settings(p);
    Renderer renderer(s);
    const Frame good = frame(19, 7);
    for (int y = 0; y < 7; y += 3)
      for (int x = 0; x < 19; x += 2)
        for (int ch = 0; ch < 4; ++ch) {
          Frame bad = good;
          bad.color.at(x, y, ch) = bad_value(x, y, ch);
          Frame clean = bad;
          detail::sanitize_color(bad.color, clean.color);
          const Image& got = renderer.render(bad).image;
          const Image want = render(clean, s).image;
          ASSERT_EQ(got.data().size(), want.data().size());
          ASSERT_EQ(std::memcmp(got.data().data(), want.data().data(), got.data().size() * sizeof(float)), 0)
              << p.size() << " params (" << x << ", " << y << ") plane " << ch;
        }
  }
}

}  // namespace
