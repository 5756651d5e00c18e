// The fast separable filters against their plain oracles (double running sums, clamped taps).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "core/filters.hpp"
#include "core/parallel.hpp"

namespace dofkit::core {
namespace {

// HDR-like test signal: mostly [0, 1], some pixels up to 200 (highlights), some exact zeros.
std::vector<float> hdr_plane(int w, int h, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<float> v(static_cast<std::size_t>(w) * h);
  for (auto& x : v) {
    const float t = u(rng);
    x = t < 0.02f ? 200.0f * u(rng) : (t < 0.1f ? 0.0f : u(rng));
  }
  return v;
}

// The fast form's float running sums are re-synchronised every 32 outputs: their error is a
// few ε of the window's magnitude. Measured worst |fast − plain| / max(1, |plain|) on these
// HDR planes: see the printed value; the bound asserted is the 1e-4 of issue 8.
double rel_err(const std::vector<float>& a, const std::vector<float>& b) {
  double e = 0;
  for (std::size_t i = 0; i < a.size(); ++i)
    e = std::max(e, std::fabs(static_cast<double>(a[i]) - b[i]) / std::max(1.0, std::fabs(static_cast<double>(b[i]))));
  return e;
}

TEST(Filters, GaussianFastMatchesPlain) {
  double worst = 0;
  const int sizes[][2] = {{160, 90}, {7, 5}, {33, 17}, {1, 40}, {40, 1}, {257, 131}};
  const float sigmas[] = {0.3f, 1.0f, 2.7f, 8.6f, 25.0f};
  unsigned seed = 1;
  for (const auto& sz : sizes)
    for (float sigma : sigmas)
      for (int passes : {1, 2, 3}) {
        const int w = sz[0], h = sz[1];
        std::vector<float> a = hdr_plane(w, h, seed++), b = a;
        gaussian_blur_plane(a.data(), w, h, sigma, sigma * 0.7f, passes);
        gaussian_blur_plane_plain(b.data(), w, h, sigma, sigma * 0.7f, passes);
        const double e = rel_err(a, b);
        worst = std::max(worst, e);
        EXPECT_LE(e, 1e-4) << w << "x" << h << " sigma " << sigma << " passes " << passes;
      }
  std::printf("worst relative error fast vs plain Gaussian: %.3g\n", worst);
}

TEST(Filters, BoxAndSinglePassMatchPlain) {
  const int w = 203, h = 77;
  for (int r : {0, 1, 5, 40, 150}) {
    std::vector<float> src = hdr_plane(w, h, 100 + r), a(src.size()), b(src.size());
    box_blur_plane(src.data(), a.data(), w, h, r, r / 2 + 1);
    box_blur_plane_plain(src.data(), b.data(), w, h, r, r / 2 + 1);
    EXPECT_LE(rel_err(a, b), 1e-4) << "box r " << r;
    a = src;
    b = src;
    extended_box_x(a.data(), w, h, r, 0.37f);
    extended_box_y(a.data(), w, h, r + 2, 0.61f);
    extended_box_x_plain(b.data(), w, h, r, 0.37f);
    extended_box_y_plain(b.data(), w, h, r + 2, 0.61f);
    EXPECT_LE(rel_err(a, b), 1e-4) << "extended box r " << r;
  }
}

TEST(Filters, ConstantIsPreserved) {
  // A constant plane stays constant up to float rounding (normalised weights, edge clamping).
  const int w = 100, h = 60;
  std::vector<float> a(static_cast<std::size_t>(w) * h, 3.5f);
  gaussian_blur_plane(a.data(), w, h, 12.0f, 4.0f);
  for (float v : a) ASSERT_NEAR(v, 3.5f, 3.5e-6f);
}

TEST(Filters, SameResultForAnyThreadCount) {
  const int w = 321, h = 203;
  const std::vector<float> src = hdr_plane(w, h, 7);
  std::vector<float> one = src, two = src;
  with_threads(1, [&] { gaussian_blur_plane(one.data(), w, h, 6.3f, 9.1f); });
  with_threads(2, [&] { gaussian_blur_plane(two.data(), w, h, 6.3f, 9.1f); });
  EXPECT_EQ(one, two);
}

}  // namespace
}  // namespace dofkit::core
