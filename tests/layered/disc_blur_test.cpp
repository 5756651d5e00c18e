// The disc blur of the layered method's psf=disc mode (src/methods/layered/disc_blur.hpp):
// the span + rim evaluation against a brute-force sum over the same anti-aliased disc.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "core/parallel.hpp"
#include "core/aperture.hpp"
#include "methods/layered/disc_blur.hpp"

namespace {

using namespace dofkit;
using dofkit::detail::layered::disc_blur;
using dofkit::detail::layered::disc_coverage;
using dofkit::detail::layered::make_disc_kernel;

// Brute force: every tap of the (2n+1)² square, coverage saturate(R − d + 0.5), normalised by
// the coverage sum, clamp-to-edge, summed in double.
Image brute_disc(const Image& src, double radius) {
  const int n = static_cast<int>(std::ceil(radius + 0.5)) + 1;
  double sum = 0;
  for (int dy = -n; dy <= n; ++dy)
    for (int dx = -n; dx <= n; ++dx) sum += disc_coverage(radius, dx, dy);
  Image out(src.width(), src.height(), src.channels(), 0.0f);
  for (int c = 0; c < src.channels(); ++c)
    for (int y = 0; y < src.height(); ++y)
      for (int x = 0; x < src.width(); ++x) {
        double acc = 0;
        for (int dy = -n; dy <= n; ++dy)
          for (int dx = -n; dx <= n; ++dx) {
            const double w = disc_coverage(radius, dx, dy);
            if (w <= 0) continue;
            const int sx = std::clamp(x + dx, 0, src.width() - 1), sy = std::clamp(y + dy, 0, src.height() - 1);
            acc += w * src.at(sx, sy, c);
          }
        out.at(x, y, c) = static_cast<float>(acc / sum);
      }
  return out;
}

Image random_layer(int w, int h, unsigned seed) {
  // Premultiplied RGBA with transparent rows and columns (the blur skips all-zero rows).
  Image img(w, h, 4, 0.0f);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0, 1);
  for (int y = 0; y < h; ++y) {
    if (y % 7 == 3 || (y >= 9 && y < 13)) continue;
    for (int x = 0; x < w; ++x) {
      if (x % 5 == 1) continue;
      const float a = u(rng);
      for (int c = 0; c < 3; ++c) img.at(x, y, c) = a * u(rng);
      img.at(x, y, 3) = a;
    }
  }
  return img;
}

TEST(LayeredDisc, KernelSumsToOne) {
  for (double r : {0.0, 0.3, 0.5, 0.7, 1.0, 1.5, 2.25, 3.0, 5.5, 12.3, 40.0}) {
    const auto k = make_disc_kernel(r);
    double sum = 0;
    int taps = 0;
    for (const auto& row : k.rows) {
      EXPECT_EQ(row.lo, -row.hi);  // a disc's full run is symmetric
      if (row.lo <= row.hi) sum += (row.hi - row.lo + 1) * k.full_weight, taps += row.hi - row.lo + 1;
      for (const auto& t : row.rim) {
        EXPECT_GT(t.w, 0.0);
        EXPECT_LT(t.w, k.full_weight);  // rim taps are partial
        EXPECT_EQ(t.len, 1);
        sum += t.w, ++taps;
      }
    }
    EXPECT_NEAR(sum, 1.0, 1e-12) << "r = " << r;
    // Roughly the disc's area (the coverage ramp is centred on the circle).
    if (r >= 3) EXPECT_NEAR(1.0 / k.full_weight, M_PI * r * r, 0.02 * M_PI * r * r) << "r = " << r;
    if (r <= 0.5) EXPECT_EQ(k.extent, 0) << "r = " << r;
  }
}

TEST(LayeredDisc, EqualsBruteForceAreaWeightedDisc) {
  const Image src = random_layer(37, 23, 11);
  // 9.2 and 14 reach past the image on every side (clamp-to-edge on both axes).
  for (double r : {0.8, 1.0, 1.5, 2.6, 3.7, 9.2, 14.0}) {
    Image fast = src;
    disc_blur(fast, r);
    const Image slow = brute_disc(src, r);
    double worst = 0;
    for (std::size_t i = 0; i < fast.data().size(); ++i)
      worst = std::max(worst, static_cast<double>(std::fabs(fast.data()[i] - slow.data()[i])));
    EXPECT_LT(worst, 1e-5) << "r = " << r;  // measured: 0 to 3e-8 (both sum in double)
  }
}

TEST(LayeredDisc, ConstantStaysConstantAndSmallRadiusIsIdentity) {
  Image img(41, 29, 4, 0.0f);
  for (int c = 0; c < 4; ++c)
    for (std::size_t i = 0; i < img.plane_size(); ++i) img.plane(c)[i] = 0.2f + 0.2f * c;
  for (double r : {0.9, 4.4, 17.0}) {
    Image b = img;
    disc_blur(b, r);
    for (int c = 0; c < 4; ++c)
      for (std::size_t i = 0; i < b.plane_size(); ++i) ASSERT_NEAR(b.plane(c)[i], 0.2f + 0.2f * c, 1e-6) << r;
  }
  const Image src = random_layer(20, 16, 5);
  for (double r : {0.0, 0.25, 0.5}) {
    Image b = src;
    disc_blur(b, r);
    EXPECT_EQ(b.data(), src.data()) << "r = " << r;
  }
}

TEST(LayeredDisc, SameResultForAnyThreadCount) {
  const Image src = random_layer(160, 90, 2);
  Image one = src, two = src;
  core::with_threads(1, [&] { disc_blur(one, 6.3); });
  core::with_threads(2, [&] { disc_blur(two, 6.3); });
  EXPECT_EQ(one.data(), two.data());
}

// Other apertures: the blur equals the brute-force scatter of every pixel over the model's
// footprint (p = q + o with weight cov(o) / Σcov; clamp-to-edge sources), for a rotated
// pentagon in both fields (the near field point-reflected) and a squeezed, curved hexagon.
TEST(LayeredDisc, ApertureKernelScattersTheFootprint) {
  const Image src = random_layer(29, 21, 7);
  struct Case {
    dofkit::ApertureShape shape;
    double coc;
  };
  dofkit::ApertureShape pent;
  pent.blades = 5;
  pent.rotation_deg = 17;
  dofkit::ApertureShape hex;
  hex.blades = 6;
  hex.curvature = 0.3;
  hex.anamorphic = 1.6;
  for (const Case& c : {Case{pent, -4.6}, Case{pent, 5.2}, Case{hex, -7.1}}) {
    const dofkit::core::ApertureModel m(c.shape, src.width(), src.height());
    Image fast = src;
    disc_blur(fast, c.coc, &m);
    const float rho = static_cast<float>(std::fabs(c.coc));
    const auto f = c.coc > 0 ? dofkit::core::Field::near : dofkit::core::Field::far;
    const auto k = m.kernel(rho, f);
    double worst = 0;
    for (int ch = 0; ch < 4; ++ch)
      for (int y = 0; y < src.height(); ++y)
        for (int x = 0; x < src.width(); ++x) {
          double acc = 0;
          for (int dy = -k.reach; dy <= k.reach; ++dy)
            for (int dx = -k.reach; dx <= k.reach; ++dx) {
              const int sx = std::clamp(x - dx, 0, src.width() - 1), sy = std::clamp(y - dy, 0, src.height() - 1);
              acc += k.at(dx, dy) / k.sum * src.at(sx, sy, ch);
            }
          worst = std::max(worst, std::fabs(acc - fast.at(x, y, ch)));
        }
    EXPECT_LT(worst, 1e-5) << c.coc;
  }
}

}  // namespace
