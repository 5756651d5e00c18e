// impl=fast (src/methods/layered/fast.cpp) against impl=plain, the oracle: the fast passes do
// the same arithmetic in the same order, so the outputs must be bit-identical, for any thread
// count, at odd and tiny sizes, for single and multi-layer input and both PSFs, and when a
// Renderer reuses its workspace buffers (stale contents) for a second, different frame.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <string>

#include "core/filters.hpp"
#include "dofkit/render.hpp"
#include "methods/layered/fast.hpp"
#include "scene/bench_frame.hpp"

namespace {

using namespace dofkit;
constexpr float kInf = std::numeric_limits<float>::infinity();

// Textured frame: a near bar, an in-focus disc, a depth ramp (ground), far wall and sky at
// +inf, a few HDR highlights; with `fragments` > 1, hidden fragments behind (some missing).
Frame test_frame(int w, int h, int fragments, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0, 1);
  Frame f;
  f.color = Image(w, h, 4, 1.0f);
  f.depth = Image(w, h, 1);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float s = (x + 0.5f) / w, t = (y + 0.5f) / h;
      float z;
      if (s > 0.1f && s < 0.25f)
        z = 1.2f;
      else if (std::hypot(s - 0.6f, t - 0.5f) < 0.2f)
        z = 4.0f;
      else if (t > 0.6f)
        z = 1.5f / std::max(0.05f, (t - 0.55f) * 2.5f);
      else
        z = t < 0.15f ? kInf : 8.0f + 50.0f * (0.6f - t);
      f.depth.at(x, y) = z;
      for (int c = 0; c < 3; ++c) f.color.at(x, y, c) = u(rng);
      if (u(rng) < 0.01f) f.color.at(x, y, 0) = 30.0f;
    }
  if (fragments > 1) {
    f.layer_color.push_back(f.color);
    f.layer_depth.push_back(f.depth);
    for (int i = 1; i < fragments; ++i) {
      Image c(w, h, 4, 0.0f), z(w, h, 1, kInf);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
          if (u(rng) < 0.3f) continue;  // no fragment here
          const float a = u(rng) < 0.5f ? 1.0f : u(rng);
          for (int ch = 0; ch < 3; ++ch) c.at(x, y, ch) = a * u(rng);
          c.at(x, y, 3) = a;
          const float zv = f.layer_depth[i - 1].at(x, y);
          z.at(x, y) = std::isinf(zv) ? kInf : zv * (1.2f + 3.0f * u(rng));
        }
      f.layer_color.push_back(c);
      f.layer_depth.push_back(z);
    }
  }
  return f;
}

RenderSettings settings(const std::string& impl, int threads, double k_px = 8.0) {
  RenderSettings rs;
  rs.method = "layered";
  // K = 8: near CoC ≈ 19 px, steps of σ >= 4 px (half res); K = 20: steps of σ >= 8 px too
  // (quarter res).
  rs.camera.model = BlurAtInfinity{4.0, k_px};
  rs.params["impl"] = impl;
  rs.threads = threads;
  return rs;
}

void expect_same(const Frame& f, RenderSettings rs, const std::string& what) {
  rs.params["impl"] = "plain";
  rs.threads = 1;
  const Image plain = render(f, rs).image;
  for (int threads : {1, 2}) {
    rs.params["impl"] = "fast";
    rs.threads = threads;
    const Image fast = render(f, rs).image;
    ASSERT_EQ(fast.width(), plain.width());
    ASSERT_EQ(fast.data().size(), plain.data().size());
    std::size_t diff = 0;
    for (std::size_t i = 0; i < fast.data().size(); ++i) diff += !(fast.data()[i] == plain.data()[i]);
    EXPECT_EQ(diff, 0u) << what << " threads " << threads;
  }
}

TEST(LayeredFast, BitIdenticalToPlainSingleInput) {
  // Sizes: tiny, odd, and one large enough for σ >= 4 px steps (half resolution).
  const std::uint64_t fused_before = detail::layered::fused_render_count();
  int gaussian_cases = 0;
  for (auto [w, h] : {std::pair{1, 1}, {1, 3}, {3, 1}, {2, 2}, {5, 7}, {37, 19}, {67, 21}, {160, 90}, {257, 33}})
    for (const char* psf : {"gaussian", "disc"})
      for (const char* half : {"on", "off"})
        for (const char* fill : {"auto", "under", "off"}) {
          RenderSettings rs = settings("fast", 1);
          rs.params["psf"] = psf;
          rs.params["half_res"] = half;
          rs.params["fill"] = fill;
          expect_same(test_frame(w, h, 1, 7), rs,
                      std::to_string(w) + "x" + std::to_string(h) + " " + psf + " half_res " + half + " fill " + fill);
          gaussian_cases += std::string(psf) == "gaussian";
        }
  // 520 px: two full 256-px row blocks, so whole blocks are hole (the ground under far
  // layers) or empty and take the block shortcuts of the fused path.
  for (auto [w, h] : {std::pair{5, 3}, {37, 19}, {161, 91}, {300, 40}, {520, 36}})
    for (const char* psf : {"gaussian", "disc"})
      for (const char* quarter : {"on", "off"}) {
        RenderSettings rs = settings("fast", 1, 20.0);
        rs.params["psf"] = psf;
        rs.params["quarter_res"] = quarter;
        expect_same(test_frame(w, h, 1, 9), rs,
                    std::to_string(w) + "x" + std::to_string(h) + " K 20 " + psf + " quarter_res " + quarter);
        gaussian_cases += std::string(psf) == "gaussian";
      }
  // Every Gaussian case (two fast renders each) went through the fused path, none fell back.
  EXPECT_EQ(detail::layered::fused_render_count() - fused_before, 2u * gaussian_cases);
}

// Stripes of three depths (near, in focus, far) whose widths vary with the row, so a layer
// occupies several disjoint runs inside one 256-px row block, runs touch all four image
// borders, and a few pixels are transparent (no layer at all). The fused path evaluates the
// matte and the pull only inside each layer's span per row block; outside it must give the
// same bits as the full evaluation.
Frame stripe_frame(int w, int h) {
  Frame f;
  f.color = Image(w, h, 4, 1.0f);
  f.depth = Image(w, h, 1);
  std::mt19937 rng(21);
  std::uniform_real_distribution<float> u(0, 1);
  const float depths[4] = {1.2f, 4.0f, 30.0f, kInf};
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const int period = 5 + (y % 7) * 4;  // 5 … 29 px stripes
      f.depth.at(x, y) = depths[((x + 3 * y) / period) % 4];
      for (int c = 0; c < 3; ++c) f.color.at(x, y, c) = u(rng);
      if ((x * 7 + y * 3) % 97 == 0)
        for (int c = 0; c < 4; ++c) f.color.at(x, y, c) = 0.0f;  // transparent
    }
  return f;
}

TEST(LayeredFast, BitIdenticalWithDisjointRunsPerBlock) {
  const std::uint64_t fused_before = detail::layered::fused_render_count();
  int cases = 0;
  for (auto [w, h] : {std::pair{263, 37}, {517, 23}, {31, 9}})
    for (const char* fill : {"auto", "under", "off"})
      for (const char* half : {"on", "off"}) {
        RenderSettings rs = settings("fast", 1, 20.0);
        rs.params["psf"] = "gaussian";
        rs.params["fill"] = fill;
        rs.params["half_res"] = half;
        expect_same(stripe_frame(w, h), rs,
                    std::to_string(w) + "x" + std::to_string(h) + " stripes fill " + fill + " half_res " + half);
        ++cases;
      }
  EXPECT_EQ(detail::layered::fused_render_count() - fused_before, 2u * cases);
}

// Six depths in stripes of varying width, so that within one 256-px row block the pixels in
// front of a layer (its holes) form several disjoint runs for many layers at once, touching
// the block and image borders. The fused path fills (and flags) holes only inside each
// layer's hole span per row block (the chunks holding a hole); outside it must give the same
// bits as the full evaluation. (A span shrunk by one pixel at either end fails this test.)
Frame hole_stripe_frame(int w, int h) {
  Frame f;
  f.color = Image(w, h, 4, 1.0f);
  f.depth = Image(w, h, 1);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(0, 1);
  const float depths[6] = {1.1f, 1.6f, 2.5f, 4.0f, 9.0f, kInf};
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const int period = 3 + (y % 5) * 7;  // 3 … 31 px stripes
      const int i = ((x + 5 * y) / period) % 11;
      f.depth.at(x, y) = depths[i < 6 ? i : 10 - i];  // 0 … 5 … 1: every step up and down
      for (int c = 0; c < 3; ++c) f.color.at(x, y, c) = u(rng);
    }
  return f;
}

TEST(LayeredFast, BitIdenticalWithHoleRunsPerBlock) {
  const std::uint64_t fused_before = detail::layered::fused_render_count();
  int cases = 0;
  for (auto [w, h] : {std::pair{300, 21}, {17, 11}})
    for (const char* fill : {"auto", "under"})
      for (double k_px : {8.0, 20.0}) {
        RenderSettings rs = settings("fast", 1, k_px);
        rs.params["psf"] = "gaussian";
        rs.params["fill"] = fill;
        expect_same(
            hole_stripe_frame(w, h), rs,
            std::to_string(w) + "x" + std::to_string(h) + " hole stripes fill " + fill + " K " + std::to_string(k_px));
        ++cases;
      }
  EXPECT_EQ(detail::layered::fused_render_count() - fused_before, 2u * cases);
}

TEST(LayeredFast, BitIdenticalWhereTheNearAccumulatorIsZero) {
  // 1100 px wide: the near bar and the ground leave whole 256-px blocks of the upper rows
  // where the near accumulator F is +0 (beyond its blur's support), so the fused composite
  // writes them as +0 and the final pass takes rows of +0 instead of up-sampling F there.
  const std::uint64_t before = detail::layered::zero_block_count();
  for (const char* quarter : {"on", "off"}) {
    RenderSettings rs = settings("fast", 1, 20.0);
    rs.params["psf"] = "gaussian";
    rs.params["quarter_res"] = quarter;
    expect_same(test_frame(1100, 120, 1, 13), rs, std::string("1100x120 K 20 quarter_res ") + quarter);
  }
  EXPECT_GT(detail::layered::zero_block_count(), before);
}

TEST(LayeredFast, BitIdenticalOnTheBenchFrame) {
  // The frame `dofkit bench` times (K = 9 layers, quarter- and half-resolution steps, a near
  // accumulator that is +0 over much of the frame), at half its 1080p size.
  const Frame f = scene::bench_frame(960, 540);
  RenderSettings rs;
  rs.method = "layered";
  rs.camera = scene::bench_camera(960);
  const std::uint64_t zero_before = detail::layered::zero_block_count();
  const std::uint64_t tiny_before = detail::layered::tiny_block_count();
  // The near accumulator's blur tails hold subnormals here: where the exact multiplies are
  // taken (core::exact_tiny_multiplies, forced on here), the fused kernels that read them
  // multiply through double (MulX), the plain form with float multiplies; where they are not
  // (forced off), the fast form takes the float kernels too. Both give the plain form's bits.
  struct Reset {
    ~Reset() { core::set_exact_tiny_multiplies(-1); }
  } reset;
  core::set_exact_tiny_multiplies(1);
  expect_same(f, rs, "bench frame 960x540, exact multiplies");
  EXPECT_GT(detail::layered::zero_block_count(), zero_before);
  EXPECT_GT(detail::layered::tiny_block_count(), tiny_before);
  core::set_exact_tiny_multiplies(0);
  const std::uint64_t tiny_mid = detail::layered::tiny_block_count();
  expect_same(f, rs, "bench frame 960x540, float multiplies");
  EXPECT_EQ(detail::layered::tiny_block_count(), tiny_mid);
}

TEST(LayeredFast, BitIdenticalToPlainMultiLayerInput) {
  for (auto [w, h] : {std::pair{1, 1}, {3, 2}, {37, 19}, {160, 90}})
    for (const char* psf : {"gaussian", "disc"})
      for (const char* fill : {"auto", "on", "under", "off"}) {
        RenderSettings rs = settings("fast", 1, w == 160 ? 20.0 : 8.0);
        rs.params["psf"] = psf;
        rs.params["fill"] = fill;
        expect_same(test_frame(w, h, 3, 11), rs,
                    std::to_string(w) + "x" + std::to_string(h) + " " + psf + " fill " + fill);
      }
}

TEST(LayeredFast, BitIdenticalWithOtherPlansAndBands) {
  const Frame f = test_frame(96, 54, 1, 5);
  for (const char* band : {"0", "0.25", "1"})
    for (const char* layers : {"3", "9", "16"}) {
      RenderSettings rs = settings("fast", 1);
      rs.params["psf"] = "gaussian";
      rs.params["matte_band"] = band;
      rs.params["layers"] = layers;
      rs.params["step_px"] = "0.5";
      expect_same(f, rs, std::string("band ") + band + " layers " + layers);
    }
}

TEST(LayeredFast, RendererReusesItsBuffers) {
  // Workspace buffers keep the previous frame's contents: a second, different frame must
  // still come out exactly as a fresh plain render.
  for (int fragments : {1, 3}) {
    Renderer r(settings("fast", 2));
    const Frame a = test_frame(120, 70, fragments, 1), b = test_frame(120, 70, fragments, 2);
    r.render(a);
    const Image second = r.render(b).image;
    const Image plain = render(b, settings("plain", 1)).image;
    EXPECT_EQ(second.data(), plain.data()) << fragments;
  }
}

TEST(LayeredFast, DebugViewsMatchPlain) {
  const Frame f = test_frame(64, 36, 1, 3);
  for (const char* view : {"front", "back", "layer_2_matted", "layer_5_blurred"}) {
    RenderSettings rs = settings("plain", 1);
    rs.params["psf"] = "gaussian";
    rs.debug_view = view;
    const Image plain = render(f, rs).debug;
    rs.params["impl"] = "fast";
    const Image fast = render(f, rs).debug;
    EXPECT_EQ(fast.data(), plain.data()) << view;
  }
}

}  // namespace
