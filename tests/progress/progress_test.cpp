// RenderSettings::progress: reports per band (lens, reference), cancels, and never changes the
// output (bit for bit, any thread count).
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <mutex>
#include <vector>

#include "common/test_frames.hpp"
#include "dofkit/render.hpp"

namespace dofkit {
namespace {

// A textured frame with a depth ramp from 1 m to 12 m, so the CoC spans near and far.
Frame ramp_frame(int w, int h) {
  Frame f = test::hashed_texture_frame(w, h, 1.0f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) f.depth.at(x, y) = 1.0f + 11.0f * static_cast<float>(x + y) / (w + h);
  return f;
}

RenderSettings settings_for(const std::string& method, int threads) {
  RenderSettings s;
  s.method = method;
  s.camera.model = BlurAtInfinity{3.0, 10.0};
  s.threads = threads;
  return s;
}

bool same_bits(const Image& a, const Image& b) {
  if (!a.same_size(b) || a.channels() != b.channels()) return false;
  for (int c = 0; c < a.channels(); ++c)
    if (std::memcmp(a.plane(c), b.plane(c), a.plane_size() * sizeof(float)) != 0) return false;
  return true;
}

TEST(Progress, SameOutputWithAndWithoutACallbackForAnyThreadCount) {
  const Frame f = ramp_frame(160, 96);
  for (const MethodInfo& m : methods()) {
    const Image plain = render(f, settings_for(m.name, 1)).image;
    for (const int threads : {1, 2, 3}) {
      RenderSettings s = settings_for(m.name, threads);
      std::mutex mu;
      std::vector<double> seen;
      s.progress = [&](double p) {
        const std::lock_guard<std::mutex> lock(mu);
        seen.push_back(p);
        return true;
      };
      const RenderResult r = render(f, s);
      EXPECT_TRUE(same_bits(plain, r.image)) << m.name << " with " << threads << " threads";
      ASSERT_FALSE(seen.empty()) << m.name;
      EXPECT_EQ(seen.back(), 1.0) << m.name;
      for (std::size_t i = 1; i < seen.size(); ++i) EXPECT_GT(seen[i], seen[i - 1]) << m.name;
      if (m.name == "lens" || m.name == "reference")
        EXPECT_GE(seen.size(), 4u) << m.name << " reports per band, not only at the end";
    }
  }
}

TEST(Progress, CancelThrowsAndTheRendererStaysUsable) {
  const Frame f = ramp_frame(200, 120);
  for (const char* method : {"lens", "reference"}) {
    for (const int threads : {1, 2}) {
      RenderSettings s = settings_for(method, threads);
      const Image expected = render(f, s).image;
      int calls = 0;
      s.progress = [&](double) { return ++calls < 2; };  // cancel at the second report
      Renderer renderer(s);
      EXPECT_THROW(renderer.render(f), Cancelled) << method;
      // A cancel stops at the next band: far fewer reports than a whole frame gives.
      EXPECT_EQ(calls, 2) << method;
      renderer.set_progress([](double) { return true; });
      EXPECT_TRUE(same_bits(expected, renderer.render(f).image)) << method << ": after a cancelled frame";
      renderer.set_progress({});
      EXPECT_TRUE(same_bits(expected, renderer.render(f).image)) << method;
    }
  }
}

TEST(Progress, CancelledIsAnInternalErrorWithOneLine) {
  const Frame f = ramp_frame(64, 32);
  RenderSettings s = settings_for("reference", 1);
  s.progress = [](double) { return false; };
  try {
    render(f, s);
    FAIL() << "no exception";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::internal);
    EXPECT_STREQ(e.what(), "render cancelled");
  }
}

}  // namespace
}  // namespace dofkit
