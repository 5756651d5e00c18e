// core::weighted_gaussian (the fused normalised Gaussian of the medium level) against the
// separate steps it fuses: multiply by c, gaussian_blur_plane on every plane and on c, divide
// (the previous fast medium level) — bit for bit — and against the plain double-sum Gaussian
// (the oracle) within 1e-4 relative (of the weighted sums, see below); identical for 1 and 2 threads.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "core/filters.hpp"
#include "core/parallel.hpp"
#include "core/weighted_gaussian.hpp"

using namespace dofkit;

namespace {

constexpr float kTiny = 1e-6f;
// The division amplifies the float sums' rounding (a few 1e-7 of the window magnitude, see
// core/filters) by 1/weight: next to an in-focus (c = 0) area a blurred weight of 1e-4 turns it
// into 1e-3 relative. Both forms are right to their precision there (and the final mix weights
// the medium level by about that small weight's level), so the comparison with the double-sum
// oracle is made on the normalised convolution's sums, |fast − plain| · weight (weights are in
// [0, 1]); everywhere the fused form equals the separate fast steps bit for bit.

float hash01(std::uint32_t v) {
  v ^= v >> 16;
  v *= 0x7feb352dU;
  v ^= v >> 15;
  v *= 0x846ca68bU;
  v ^= v >> 16;
  return (v & 0xffffff) / float(0x1000000);
}

struct Planes {
  int w, h;
  std::vector<float> src[3], c;
};

// Three planes with values up to 40 (highlights) and weights with zero runs (in-focus areas,
// where the source must come back) next to blurry areas.
Planes make_planes(int w, int h) {
  Planes p{w, h, {}, {}};
  const std::size_t n = static_cast<std::size_t>(w) * h;
  for (int k = 0; k < 3; ++k) {
    p.src[k].resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      const float v = hash01(static_cast<std::uint32_t>(i * 3 + k));
      p.src[k][i] = v > 0.97f ? 40.0f * v : v;
    }
  }
  p.c.resize(n);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      p.c[static_cast<std::size_t>(y) * w + x] =
          (x / 11 + y / 7) % 3 == 0 ? 0.0f : hash01(static_cast<std::uint32_t>(y * 7919 + x + 1000003));
  return p;
}

// The separate steps (previous fast form, or the plain oracle with plain = true).
std::vector<float> separate(const Planes& p, float sigma, bool plain) {
  const std::size_t n = static_cast<std::size_t>(p.w) * p.h;
  std::vector<float> out(3 * n), wt = p.c;
  auto blur = plain ? core::gaussian_blur_plane_plain : core::gaussian_blur_plane;
  blur(wt.data(), p.w, p.h, sigma, sigma, 3);
  for (int k = 0; k < 3; ++k) {
    float* d = out.data() + k * n;
    for (std::size_t i = 0; i < n; ++i) d[i] = p.c[i] * p.src[k][i];
    blur(d, p.w, p.h, sigma, sigma, 3);
    for (std::size_t i = 0; i < n; ++i) d[i] = wt[i] > kTiny ? d[i] / wt[i] : p.src[k][i];
  }
  return out;
}

std::vector<float> fused(const Planes& p, float sigma, int threads) {
  const std::size_t n = static_cast<std::size_t>(p.w) * p.h;
  std::vector<float> out(3 * n), wt(n);
  const float* src[3] = {p.src[0].data(), p.src[1].data(), p.src[2].data()};
  float* dst[3] = {out.data(), out.data() + n, out.data() + 2 * n};
  core::with_threads(threads,
                     [&] { core::weighted_gaussian(src, 3, p.c.data(), p.w, p.h, sigma, 3, kTiny, dst, wt.data()); });
  return out;
}

}  // namespace

TEST(WeightedGaussian, EqualsTheSeparateStepsAndThePlainOracle) {
  // Sizes below, at and above the 16-lane strip and the 4-wide transposes, odd sizes, and
  // σ from none to wider than the image (the padded strip replicates the edge).
  double worst_plain = 0;
  for (const auto& [w, h] : {std::pair{1, 1}, {1, 7}, {6, 1}, {5, 3}, {17, 33}, {50, 19}, {203, 117}}) {
    const Planes p = make_planes(w, h);
    for (float sigma : {0.0f, 0.7f, 3.3f, 9.0f, 40.0f}) {
      const std::vector<float> f1 = fused(p, sigma, 1), f2 = fused(p, sigma, 2);
      EXPECT_EQ(f1, f2) << w << "x" << h << " sigma " << sigma;
      EXPECT_EQ(f1, separate(p, sigma, false)) << w << "x" << h << " sigma " << sigma;
      const std::vector<float> ref = separate(p, sigma, true);
      std::vector<float> wt = p.c;
      core::gaussian_blur_plane_plain(wt.data(), w, h, sigma, sigma, 3);
      for (std::size_t i = 0; i < ref.size(); ++i) {
        const double e = std::fabs(double(f1[i]) - ref[i]) * wt[i % wt.size()];
        worst_plain = std::max(worst_plain, e / std::max(1.0, std::fabs(double(ref[i])) * wt[i % wt.size()]));
      }
    }
  }
  std::printf("weighted_gaussian vs plain: worst relative difference %.3g\n", worst_plain);
  EXPECT_LE(worst_plain, 1e-4);
}

TEST(WeightedGaussian, StreamedRowsEqualThePlaneFormForAnyBanding) {
  // weighted_gaussian_rows streams bands of rows; each band warms its passes up from rows
  // above it, so any banding must give the plane form's output bit for bit. Bands start at,
  // just after and between the 32-row re-synchronisation points and at the image edges.
  // Each case runs with the group the function chooses (1000 × 150 at σ 40: rings over 4 MB,
  // so 32 rows per call on a core with a 2 MB L2, 4 on others) and with each group forced
  // (set_weighted_gaussian_group), so both are checked on any machine.
  struct GroupReset {
    ~GroupReset() { core::set_weighted_gaussian_group(0); }
  } reset;
  for (int group : {0, 4, 32})
    for (const auto& size : {std::pair{1, 1}, {6, 1}, {5, 3}, {17, 33}, {50, 119}, {203, 117}, {1000, 150}}) {
      const int w = size.first, h = size.second;  // not a structured binding: the lambda below captures w
      const Planes p = make_planes(w, h);
      const std::size_t n = static_cast<std::size_t>(w) * h;
      for (float sigma : {0.0f, 0.7f, 3.3f, 9.0f, 40.0f}) {
        core::set_weighted_gaussian_group(0);
        const std::vector<float> ref = fused(p, sigma, 1);
        core::set_weighted_gaussian_group(group);
        for (const std::vector<int>& cuts : {std::vector<int>{0, h}, std::vector<int>{0, 1, 33, 64, h},
                                             std::vector<int>{0, h / 3, h / 2 + 1, h - 1, h}}) {
          std::vector<float> out(3 * n, -1.0f);
          const float* src[3] = {p.src[0].data(), p.src[1].data(), p.src[2].data()};
          for (std::size_t b = 0; b + 1 < cuts.size(); ++b)
            core::weighted_gaussian_rows(src, 3, p.c.data(), w, h, sigma, 3, kTiny, cuts[b], cuts[b + 1],
                                         [&](int y, const float* const* rows) {
                                           for (int k = 0; k < 3; ++k)
                                             std::copy(rows[k], rows[k] + w, out.data() + k * n + std::size_t(y) * w);
                                         });
          EXPECT_EQ(out, ref) << w << "x" << h << " sigma " << sigma << " bands " << cuts.size() - 1 << " group "
                              << group;
        }
      }
    }
}

TEST(WeightedGaussian, StreamedRowsBeforeTheDivisionEqualThePlaneSums) {
  // normalise = false (the starcraft final pass divides itself): rows[k] are the blurred c·src
  // planes and rows[3] the blurred weight, bit for bit those of the plane form with
  // normalise = false, for 2 and 3 box passes (the medium level's medium_boxes) and any banding.
  for (const auto& size : {std::pair{5, 3}, {50, 119}, {203, 117}}) {
    const int w = size.first, h = size.second;  // not a structured binding: the lambda below captures w
    const Planes p = make_planes(w, h);
    const std::size_t n = static_cast<std::size_t>(w) * h;
    const float* src[3] = {p.src[0].data(), p.src[1].data(), p.src[2].data()};
    for (int passes : {2, 3})
      for (float sigma : {0.7f, 9.0f}) {
        std::vector<float> ref(4 * n);
        float* dst[3] = {ref.data(), ref.data() + n, ref.data() + 2 * n};
        core::weighted_gaussian(src, 3, p.c.data(), w, h, sigma, passes, kTiny, dst, ref.data() + 3 * n, false);
        for (const std::vector<int>& cuts : {std::vector<int>{0, h}, std::vector<int>{0, h / 3, h / 2 + 1, h}}) {
          std::vector<float> out(4 * n, -1.0f);
          for (std::size_t b = 0; b + 1 < cuts.size(); ++b)
            core::weighted_gaussian_rows(
                src, 3, p.c.data(), w, h, sigma, passes, kTiny, cuts[b], cuts[b + 1],
                [&](int y, const float* const* rows) {
                  for (int k = 0; k < 4; ++k) std::copy(rows[k], rows[k] + w, out.data() + k * n + std::size_t(y) * w);
                },
                false);
          EXPECT_EQ(out, ref) << w << "x" << h << " passes " << passes << " sigma " << sigma;
        }
      }
  }
}

TEST(WeightedGaussian, PointFormEqualsThePlainCascade) {
  // weighted_gaussian_at (one pixel, no running sums, double) against the plain double-sum
  // cascade on every pixel, the image borders (clamp-to-edge folded into the weights)
  // included: within a few float roundings of the magnitudes under the kernel (the plain form
  // rounds each pass's output to float), for 1-3 passes and σ up to wider than the image.
  double worst = 0;
  for (const auto& [w, h] : {std::pair{1, 1}, {6, 1}, {5, 3}, {17, 33}, {50, 19}}) {
    const Planes p = make_planes(w, h);
    const std::size_t n = static_cast<std::size_t>(w) * h;
    const float* src[3] = {p.src[0].data(), p.src[1].data(), p.src[2].data()};
    for (int passes : {1, 2, 3})
      for (float sigma : {0.0f, 0.7f, 3.3f, 9.0f, 40.0f}) {
        std::vector<float> sums[4], mags[4];
        for (int k = 0; k < 4; ++k) {
          sums[k].resize(n);
          mags[k].resize(n);
          for (std::size_t i = 0; i < n; ++i) {
            sums[k][i] = k < 3 ? p.c[i] * p.src[k][i] : p.c[i];
            mags[k][i] = std::fabs(sums[k][i]);
          }
          core::gaussian_blur_plane_plain(sums[k].data(), w, h, sigma, sigma, passes);
          core::gaussian_blur_plane_plain(mags[k].data(), w, h, sigma, sigma, passes);
        }
        for (int y = 0; y < h; ++y)
          for (int x = 0; x < w; ++x) {
            double at[4];
            core::weighted_gaussian_at(src, 3, p.c.data(), w, h, sigma, passes, x, y, at);
            const std::size_t i = static_cast<std::size_t>(y) * w + x;
            for (int k = 0; k < 4; ++k) {
              const double e = std::fabs(at[k] - sums[k][i]) / std::max(1e-30, double(mags[k][i]));
              worst = std::max(worst, e);
              ASSERT_LE(e, 1e-6) << w << "x" << h << " passes " << passes << " sigma " << sigma << " at " << x << ","
                                 << y << " plane " << k << ": " << at[k] << " vs " << sums[k][i];
            }
          }
      }
  }
  std::printf("weighted_gaussian_at vs plain: worst %.3g of the magnitude under the kernel\n", worst);
}

TEST(WeightedGaussian, OneBoxPassEqualsTheSeparateSteps) {
  // medium_boxes = 1: the plane form's only vertical pass reads the planes in place and used to
  // write each output row while the next r + 1 rows still read it (0.22 for 0.208 at a
  // 50 x 119 image's second row). Both forms against the separate fast steps, bit for bit,
  // normalised (medium_blur's "medium" debug view) and not (the sums).
  for (const auto& size : {std::pair{5, 3}, {50, 119}, {203, 117}}) {
    const int w = size.first, h = size.second;
    const Planes p = make_planes(w, h);
    const std::size_t n = static_cast<std::size_t>(w) * h;
    const float* src[3] = {p.src[0].data(), p.src[1].data(), p.src[2].data()};
    for (float sigma : {0.7f, 9.0f}) {
      std::vector<float> sep(4 * n);
      for (int k = 0; k < 4; ++k) {
        for (std::size_t i = 0; i < n; ++i) sep[k * n + i] = k < 3 ? p.c[i] * p.src[k][i] : p.c[i];
        core::gaussian_blur_plane(sep.data() + k * n, w, h, sigma, sigma, 1);
      }
      std::vector<float> plane(4 * n), rows(4 * n, -1.0f);
      float* dst[3] = {plane.data(), plane.data() + n, plane.data() + 2 * n};
      core::weighted_gaussian(src, 3, p.c.data(), w, h, sigma, 1, kTiny, dst, plane.data() + 3 * n, false);
      core::weighted_gaussian_rows(
          src, 3, p.c.data(), w, h, sigma, 1, kTiny, 0, h,
          [&](int y, const float* const* r) {
            for (int k = 0; k < 4; ++k) std::copy(r[k], r[k] + w, rows.data() + k * n + std::size_t(y) * w);
          },
          false);
      EXPECT_EQ(plane, sep) << w << "x" << h << " sigma " << sigma;
      EXPECT_EQ(rows, sep) << w << "x" << h << " sigma " << sigma;
      std::vector<float> norm(3 * n), wt(n);
      float* ndst[3] = {norm.data(), norm.data() + n, norm.data() + 2 * n};
      core::weighted_gaussian(src, 3, p.c.data(), w, h, sigma, 1, kTiny, ndst, wt.data());
      for (int k = 0; k < 3; ++k)
        for (std::size_t i = 0; i < n; ++i) {
          const float* s = sep.data() + 3 * n;
          const float want = s[i] > kTiny ? sep[k * n + i] / s[i] : p.src[k][i];
          ASSERT_EQ(norm[k * n + i], want) << w << "x" << h << " sigma " << sigma << " plane " << k << " at " << i;
        }
    }
  }
}
