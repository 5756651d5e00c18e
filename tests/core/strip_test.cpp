// strip::strip_passes against its definition: every pass recomputes its window sum from scratch
// at each kResync-th output and slides it in between, in float, in this order. The kernel
// builds the fresh sums while the samples slide in (one pending sum for windows up to kResync
// samples, two up to 2·kResync) instead of re-reading them, and runs up to three passes as one
// cascade, each a few blocks behind the one before (more passes: cascades one after the
// other); that must not change a bit.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <random>
#include <vector>

#include "core/filters.hpp"
#include "core/strip.hpp"

namespace dofkit::core::strip {
namespace {

constexpr int kL = kStripLanes;

// The definition, one lane at a time (scalar float, the kernel's operations in its order).
std::vector<float> reference(std::vector<float> a, int n, int pad, int r, float alpha, int passes) {
  const float norm = static_cast<float>(1.0 / (2.0 * r + 1.0 + 2.0 * alpha));
  std::vector<float> b(a.size(), 0.0f);
  for (int p = 0; p < passes; ++p) {
    for (int j = 0; j < kL; ++j) {
      auto v = [&](int i) -> float& { return a[static_cast<std::size_t>(pad + i) * kL + j]; };
      for (int i = 1; i <= r + 1; ++i) {
        v(-i) = v(0);
        v(n - 1 + i) = v(n - 1);
      }
      float s = 0.0f;
      for (int i = 0; i < n; ++i) {
        if (i % kResync == 0) {
          s = 0.0f;
          for (int k = -r; k <= r; ++k) s += v(i + k);
        }
        const float lo = v(i - r - 1), hi = v(i + r + 1);
        b[static_cast<std::size_t>(pad + i) * kL + j] = (s + alpha * (lo + hi)) * norm;
        s += hi - v(i - r);
      }
    }
    std::swap(a, b);
  }
  return a;
}

// strip_passes over the strip a equals reference() bit for bit at outputs [0, n).
bool passes_match_definition(const std::vector<float>& a, int n, int pad, int r, float alpha, int passes) {
  const std::vector<float> want = reference(a, n, pad, r, alpha, passes);
  std::vector<float> in = a, b(a.size(), 0.0f);
  const float* got = strip_passes(in.data(), b.data(), n, pad, r, alpha, passes);
  for (int i = 0; i < n; ++i)
    if (std::memcmp(got + static_cast<std::size_t>(pad + i) * kL, want.data() + static_cast<std::size_t>(pad + i) * kL,
                    kL * sizeof(float)) != 0)
      return false;
  return true;
}

TEST(Strip, PassesEqualTheirResummingDefinitionBitForBit) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  // Windows 2r + 1 up to one resync block (one pending sum), up to two (two pending sums,
  // e.g. starcraft's medium level at 4K: r ≈ 21), and wider (re-summed).
  for (int r : {0, 1, 5, 15, 16, 20, 31, 32, 40})
    for (int n : {1, 7, 31, 32, 33, 64, 95, 200, 517})
      for (int passes : {1, 2, 3, 4, 5, 7}) {  // > 3: cascades one after the other
        const int pad = r + 1 + (n % 3);       // pad may exceed r + 1
        std::vector<float> a(static_cast<std::size_t>(n + 2 * pad) * kL);
        for (auto& x : a) {  // HDR-like: highlights and exact zeros make rounding visible
          const float t = u(rng);
          x = t < 0.05f ? 300.0f * u(rng) : (t < 0.15f ? 0.0f : u(rng));
        }
        const float alpha = 0.25f + 0.5f * u(rng);
        EXPECT_TRUE(passes_match_definition(a, n, pad, r, alpha, passes))
            << "r " << r << " n " << n << " passes " << passes;
      }
}

TEST(Strip, TinySamplesGiveTheSameBitsWithAndWithoutTheExactMultiplies) {
  // Blur tails near subnormals (|x| < 2^-96, down to the smallest subnormals): the blocks that
  // hold them multiply through double where core::exact_tiny_multiplies() says so, and through
  // the float multiply otherwise; both must be the definition's bits, on any machine.
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  struct Reset {
    ~Reset() { set_exact_tiny_multiplies(-1); }
  } reset;
  for (int mode : {1, 0})
    for (int r : {1, 5, 20})
      for (int n : {33, 200, 517})
        for (int passes : {1, 3, 4}) {
          set_exact_tiny_multiplies(mode);
          const int pad = r + 1;
          std::vector<float> a(static_cast<std::size_t>(n + 2 * pad) * kL);
          for (std::size_t i = 0; i < a.size(); ++i) {
            const float t = u(rng);
            const bool tail = (i / kL) % 96 < 40;  // runs of tiny samples among ordinary ones
            a[i] = tail ? (t < 0.3f ? 1e-40f * u(rng) : (t < 0.6f ? 3e-30f * u(rng) : 0.0f)) : u(rng);
          }
          const float alpha = 0.25f + 0.5f * u(rng);
          EXPECT_TRUE(passes_match_definition(a, n, pad, r, alpha, passes))
              << "exact " << mode << " r " << r << " n " << n << " passes " << passes;
        }
}

// The row transposes against their definition: 16×16 blocks on AVX-512 (from the first column
// where all rows are 64-byte aligned), 8×8 blocks and single columns around them (and
// everywhere else), rows of any length, aligned alike or not, with and without the weights'
// product, and the ragged last strip of a plane (fewer than 16 rows to store).
TEST(Strip, TransposesMoveEverySampleExactly) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(-2.0f, 2.0f);
  for (int nx : {1, 7, 8, 15, 16, 17, 31, 40, 64, 1001})
    for (int shift : {0, 4, 9, -1})  // rows from a 64-byte boundary + shift floats; -1: stride nx + 1
      for (bool with_mul : {false, true}) {
        const int stride = shift < 0 ? nx + 1 : (nx + 31) / 16 * 16;
        std::vector<float> store(static_cast<std::size_t>(kL) * stride + 32), mul(static_cast<std::size_t>(kL) * nx);
        float* base =
            store.data() + (16 - reinterpret_cast<std::uintptr_t>(store.data()) % 64 / 4) % 16 + std::max(shift, 0);
        for (auto& v : store) v = u(rng);
        for (auto& v : mul) v = u(rng);
        const float* rows[kL];
        for (int j = 0; j < kL; ++j) rows[j] = base + static_cast<std::size_t>(j) * stride;
        std::vector<float> s(static_cast<std::size_t>(nx) * kL, 0.0f);
        load_rows_transposed(rows, nx, with_mul ? mul.data() : nullptr, s.data());
        for (int x = 0; x < nx; ++x)
          for (int j = 0; j < kL; ++j) {
            const std::size_t i = static_cast<std::size_t>(x) * kL + j;
            ASSERT_EQ(s[i], with_mul ? rows[j][x] * mul[i] : rows[j][x])
                << "nx " << nx << " shift " << shift << " x " << x << " j " << j;
          }
        for (int nrows : {16, 15, 9, 8, 3, 1}) {
          std::vector<float> out(store.size(), 9.0f);
          float* obase = out.data() + (base - store.data());
          float* orows[kL];
          for (int j = 0; j < kL; ++j) orows[j] = obase + static_cast<std::size_t>(j) * stride;
          store_rows_transposed(s.data(), nx, orows, nrows);
          for (int j = 0; j < kL; ++j)
            for (int x = 0; x < nx; ++x)
              ASSERT_EQ(orows[j][x], j < nrows ? s[static_cast<std::size_t>(x) * kL + j] : 9.0f)
                  << "nx " << nx << " shift " << shift << " nrows " << nrows << " x " << x << " j " << j;
        }
      }
}

// The column copies of the vertical sweep: whole strips and the ragged last one (lanes past
// the last column repeat it on the way in; only nx columns go back).
TEST(Strip, ColumnCopiesMoveExactlyTheirColumns) {
  const int w = 53, h = 37;
  std::vector<float> plane(static_cast<std::size_t>(w) * h);
  for (std::size_t i = 0; i < plane.size(); ++i) plane[i] = static_cast<float>(i) * 0.25f - 7.0f;
  for (int x0 = 0; x0 < w; x0 += kL) {
    const int nx = std::min(kL, w - x0);
    std::vector<float> s(static_cast<std::size_t>(h) * kL, -1.0f);
    load_columns(plane.data() + x0, w, h, nx, s.data());
    for (int y = 0; y < h; ++y)
      for (int j = 0; j < kL; ++j)
        ASSERT_EQ(s[static_cast<std::size_t>(y) * kL + j],
                  plane[static_cast<std::size_t>(y) * w + x0 + std::min(j, nx - 1)])
            << "x0 " << x0 << " y " << y << " j " << j;
    std::vector<float> out(plane.size(), 5.0f);
    for (auto& v : s) v = -v;
    store_columns(s.data(), h, nx, out.data() + x0, w);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const float want = x >= x0 && x < x0 + nx ? -plane[static_cast<std::size_t>(y) * w + x] : 5.0f;
        ASSERT_EQ(out[static_cast<std::size_t>(y) * w + x], want) << "x0 " << x0 << " y " << y << " x " << x;
      }
  }
}

}  // namespace
}  // namespace dofkit::core::strip
