// Every optimised path against its oracle on the frame `dofkit bench` times (issue 8: "output
// after optimisation equals the plain implementation within 1e-4"). The per-method suites
// compare impl=fast with impl=plain on frames built for each pass; this test adds the bench
// frame itself, whose mix of a far wall, a receding ground plane, a near bar and sparse HDR
// fireflies (radiance 40 on a texture in [0, 1]) is what the speed figures are quoted on. It
// found a starcraft fast path that was 4e-3 off at a few pixels next to fireflies while
// every per-method test passed.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "core/parallel.hpp"
#include "dofkit/render.hpp"
#include "methods/method.hpp"
#include "scene/bench_frame.hpp"

using namespace dofkit;

namespace {

struct Case {
  std::string method;
  std::vector<std::pair<std::string, std::string>> params;
};

std::string label(const Case& c) {
  std::string s = c.method;
  for (const auto& [k, v] : c.params) s += " " + k + "=" + v;
  return s;
}

// Worst |fast − plain| / max(1, |plain|) over every sample of the image and the CoC, with the
// number of samples over 1e-4 and where the worst one is.
void expect_fast_matches_plain(const Case& c, int w, int h) {
  SCOPED_TRACE(label(c) + " at " + std::to_string(w) + "x" + std::to_string(h));
  const Frame frame = scene::bench_frame(w, h);
  RenderSettings s;
  s.method = c.method;
  for (const auto& [k, v] : c.params) s.params[k] = v;
  s.camera = scene::bench_camera(w);
  s.threads = 2;
  RenderSettings p = s;
  p.params["impl"] = "plain";
  const RenderResult fast = render(frame, s), plain = render(frame, p);
  ASSERT_EQ(fast.image.data().size(), plain.image.data().size());
  const std::vector<float>& a = fast.image.data();
  const std::vector<float>& b = plain.image.data();
  double worst = 0;
  std::size_t at = 0, over = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const double e = std::fabs(static_cast<double>(a[i]) - b[i]) / std::max(1.0, std::fabs(static_cast<double>(b[i])));
    if (!(e <= 1e-4)) ++over;  // NaN counts as over
    if (!(e <= worst)) {
      worst = e;
      at = i;
    }
  }
  const std::size_t plane = static_cast<std::size_t>(w) * h;
  EXPECT_EQ(over, 0u) << "worst relative difference " << worst << " at pixel (" << (at % plane) % w << ", "
                      << (at % plane) / w << ") plane " << at / plane << ": fast " << a[at] << ", plain " << b[at];
  EXPECT_EQ(fast.coc.data(), plain.coc.data());
}

const std::vector<Case>& cases() {
  static const std::vector<Case> c = {
      {"mcguire", {}},
      {"mcguire", {{"variant", "book"}}},
      {"mcguire", {{"variant", "g3d"}}},
      {"sterna", {}},
      {"starcraft", {}},
      {"layered", {}},
  };
  return c;
}

}  // namespace

// 640×360 is a size at which the starcraft defect above showed (6 samples, 8.8e-3); 333×187
// has sides that are multiples of no block or vector size.
TEST(FastMatchesPlain, BenchFrameEveryMethod) {
  for (const Case& c : cases()) {
    expect_fast_matches_plain(c, 640, 360);
    expect_fast_matches_plain(c, 333, 187);
  }
}

// render() hands the methods the CoC map's range, taken while it writes the map
// (MethodContext::coc_range). The methods that size their kernels by it (mcguire, sterna)
// must render exactly what they render when they scan the map themselves (coc_range null),
// on frames whose largest near or far radius sits in the last row, the last column or a
// single pixel, where a range that missed a row block would show.
TEST(FastMatchesPlain, RenderersCocRangeEqualsAScanOfTheMap) {
  for (const char* name : {"mcguire", "sterna"}) {
    const detail::MethodDef* m = detail::find_method(name);
    ASSERT_NE(m, nullptr);
    for (int variant = 0; variant < 3; ++variant) {
      SCOPED_TRACE(std::string(name) + " frame " + std::to_string(variant));
      const int w = 97, h = 61;
      Frame frame = scene::bench_frame(w, h);
      if (variant == 1) {  // nothing nearer than 3 m but a run of 16 pixels in the last row
        for (float& z : frame.depth.data()) z = std::max(z, 3.0f);
        for (int x = 40; x < 56; ++x) frame.depth.at(x, h - 1) = 0.3f;
      }
      if (variant == 2)
        for (int x = 0; x < w; ++x) frame.depth.at(x, h - 1) = 1e6f;  // the farthest row last, no sky above
      if (variant == 2)
        for (int y = 0; y < h - 1; ++y)
          for (int x = 0; x < w; ++x) frame.depth.at(x, y) = std::min(frame.depth.at(x, y), 50.0f);
      RenderSettings s;
      s.method = name;
      s.camera = scene::bench_camera(w);
      s.camera.max_coc_px = 12;  // near radii that reach the outputs of the rows above
      s.threads = 2;
      const RenderResult got = render(frame, s);
      // The same method with no range given: it scans got.coc itself.
      const detail::Params params(name, m->params, s.params);
      detail::DebugSink sink("");
      detail::Workspace ws;
      const CocFunction coc_of(s.camera, w);
      Image out(w, h, 4);
      core::with_threads(2, [&] {
        m->render({frame, got.coc, s.camera, coc_of, params, sink, 2, ws, nullptr, nullptr}, out);
      });
      EXPECT_EQ(got.image.data(), out.data());
    }
  }
}
