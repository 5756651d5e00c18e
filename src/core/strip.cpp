// The strip operations of core/strip.hpp, shared by both strip filters, core/filters.cpp
// (gaussian_blur_plane, the box blurs) and core/weighted_gaussian.cpp (the normalised Gaussian
// of starcraft's medium level): the transposes between rows and strips and the extended-box
// passes over a strip.
//
// Precision: the window sum S_i = Σ_{|k|<=r} v_{i+k} is updated as S_{i+1} = S_i + v_{i+r+1}
// − v_{i−r} in float. Each update adds a rounding error of at most ε·|S| (ε = 2⁻²⁴), so after
// m updates the drift is <= m·ε·max|S|; recomputing S from scratch every kResync outputs caps
// m, i.e. the error stays below ~kResync·ε ≈ 2e-6 of the local window magnitude (the plain
// form's double sums are exact to that level, its float output rounding is ε).
#include <algorithm>
#include <cstddef>

#include "core/clones.hpp"
#include "core/strip.hpp"

namespace dofkit::core::strip {

static_assert(kStripLanes == 16, "strip_passes keeps two 8-lane vectors per step");
constexpr int kLanes = kStripLanes;
#define SP_LOAD8(p) (*reinterpret_cast<const Vec8u*>(p))
#define SP_STORE8(p, v) (*reinterpret_cast<Vec8u*>(p) = (v))

namespace {

// Outputs i … end − 1 of one box pass over a strip (two vectors of 8 lanes): out = (sum +
// alpha·(lo + hi))·norm, then the window slides, sum += hi − (sample i − r); kFresh >= 1 also
// adds hi to the next resync point's pending sum (f), kFresh == 2 to the one after it (g).
// (Inlined into each clone of strip_passes: vector arguments are fine there.)
template <int kFresh>
__attribute__((always_inline)) inline void box_steps(int& i, int end, const float*& lo, const float*& hi, float*& d,
                                                     Vec8& s0, Vec8& s1, Vec8& f0, Vec8& f1, Vec8& g0, Vec8& g1,
                                                     Vec8 va, Vec8 vn) {
  for (; i < end; ++i, lo += kLanes, hi += kLanes, d += kLanes) {
    const Vec8 h0 = SP_LOAD8(hi), h1 = SP_LOAD8(hi + 8);
    SP_STORE8(d, (s0 + va * (SP_LOAD8(lo) + h0)) * vn);
    SP_STORE8(d + 8, (s1 + va * (SP_LOAD8(lo + 8) + h1)) * vn);
    s0 += h0 - SP_LOAD8(lo + kLanes);  // lo + kLanes: sample i − r, leaving the window
    s1 += h1 - SP_LOAD8(lo + kLanes + 8);
    if constexpr (kFresh >= 1) {
      f0 += h0;
      f1 += h1;
    }
    if constexpr (kFresh >= 2) {
      g0 += h0;
      g1 += h1;
    }
  }
}

}  // namespace

DOFKIT_CLONES
float* strip_passes(float* a, float* b, int n, int pad, int r, float alpha, int passes) {
  const float norm = static_cast<float>(1.0 / (2.0 * r + 1.0 + 2.0 * alpha));
  const Vec8 va = {alpha, alpha, alpha, alpha, alpha, alpha, alpha, alpha};
  const Vec8 vn = {norm, norm, norm, norm, norm, norm, norm, norm};
  const Vec8 zero = {};
  for (int p = 0; p < passes; ++p) {
    float* src = a + static_cast<std::size_t>(pad) * kLanes;
    float* dst = b + static_cast<std::size_t>(pad) * kLanes;
    for (int i = 1; i <= r + 1; ++i)
      for (int j = 0; j < kLanes; ++j) {
        src[-i * kLanes + j] = src[j];
        src[(n - 1 + i) * kLanes + j] = src[(n - 1) * kLanes + j];
      }
    // The window sums are recomputed from scratch at every kResync-th output R. The samples of
    // that fresh sum, R − r … R + r, all enter the window as `hi` during the 2r + 1 outputs
    // before R, so the fresh sum is built there (from 0, in the same order) instead of
    // re-reading them: the same value, bit for bit. Up to a window of kResync samples this
    // starts inside the block before R (one pending sum, f); up to 2·kResync it starts in the
    // block before that (a second pending sum, g, for the resync point after next) — the
    // medium level of starcraft at 4K (2r + 1 ≈ 43), where re-summing 43 samples per 32
    // outputs as one dependent chain of adds cost ~40 % of the pass. Wider windows re-sum.
    const int span = 2 * r + 1;
    const bool carry = span <= 2 * kResync;
    Vec8 s0 = zero, s1 = zero;  // window sums, lanes 0-7, 8-15
    Vec8 f0 = zero, f1 = zero;  // pending fresh sum of the next resync point
    Vec8 g0 = zero, g1 = zero;  // ... and of the one after it (span > kResync only)
    if (carry)  // the samples of the first pending sum that enter before output 0
      for (int k = kResync - r; k <= r; ++k) {
        const float* q = src + static_cast<std::ptrdiff_t>(k) * kLanes;
        f0 += SP_LOAD8(q);
        f1 += SP_LOAD8(q + 8);
      }
    for (int i0 = 0; i0 < n; i0 += kResync) {
      if (i0 == 0 || !carry) {
        s0 = zero;
        s1 = zero;
        for (int k = -r; k <= r; ++k) {
          const float* q = src + static_cast<std::ptrdiff_t>(i0 + k) * kLanes;
          s0 += SP_LOAD8(q);
          s1 += SP_LOAD8(q + 8);
        }
      } else {
        s0 = f0;
        s1 = f1;
        f0 = g0;
        f1 = g1;
        g0 = zero;
        g1 = zero;
      }
      // Outputs [i0, from_f) update the window only, [from_f, from_g) also f, [from_g, i1)
      // also g: hi = sample i + r + 1 belongs to the fresh sum of R when R − r <= i + r + 1.
      const int i1 = std::min(n, i0 + kResync);
      const int from_f = carry ? std::clamp(i0 + kResync - span, i0, i1) : i1;
      const int from_g = carry ? std::clamp(i0 + 2 * kResync - span, i0, i1) : i1;
      const float* lo = src + static_cast<std::ptrdiff_t>(i0 - r - 1) * kLanes;  // sample i − r − 1
      const float* hi = src + static_cast<std::ptrdiff_t>(i0 + r + 1) * kLanes;  // sample i + r + 1
      float* d = dst + static_cast<std::ptrdiff_t>(i0) * kLanes;
      int i = i0;
      box_steps<0>(i, from_f, lo, hi, d, s0, s1, f0, f1, g0, g1, va, vn);
      box_steps<1>(i, from_g, lo, hi, d, s0, s1, f0, f1, g0, g1, va, vn);
      box_steps<2>(i, i1, lo, hi, d, s0, s1, f0, f1, g0, g1, va, vn);
    }
    std::swap(a, b);
  }
  return a;
}

// 8×8 transposes. The strip of a horizontal sweep is written and read back once per plane,
// so the transposes are a good part of such a sweep (starcraft's medium level: 7.5 % of the
// whole render on 1 thread, measured by skipping them). An 8×8 block costs 8 loads, 24
// shuffles and 8 stores; the SSE 4×4 form it replaces spent twice the loads and stores per
// value. Written with generic vector shuffles, which GCC turns into unpack/shuffle/permute
// instructions for each clone (AVX2: in-lane unpacks and shuffles, then 128-bit permutes).

namespace {

// o[k][j] = r[j][k] for an 8×8 block held in eight vectors.
__attribute__((always_inline)) inline void transpose8(const Vec8 r[8], Vec8 o[8]) {
  Vec8 t[8], u[8];
  for (int i = 0; i < 8; i += 2) {
    t[i] = __builtin_shufflevector(r[i], r[i + 1], 0, 8, 1, 9, 4, 12, 5, 13);
    t[i + 1] = __builtin_shufflevector(r[i], r[i + 1], 2, 10, 3, 11, 6, 14, 7, 15);
  }
  for (int i = 0; i < 8; i += 4)
    for (int h = 0; h < 2; ++h) {
      u[i + 2 * h] = __builtin_shufflevector(t[i + h], t[i + 2 + h], 0, 1, 8, 9, 4, 5, 12, 13);
      u[i + 2 * h + 1] = __builtin_shufflevector(t[i + h], t[i + 2 + h], 2, 3, 10, 11, 6, 7, 14, 15);
    }
  for (int k = 0; k < 4; ++k) {
    o[k] = __builtin_shufflevector(u[k], u[k + 4], 0, 1, 2, 3, 8, 9, 10, 11);
    o[k + 4] = __builtin_shufflevector(u[k], u[k + 4], 4, 5, 6, 7, 12, 13, 14, 15);
  }
}

}  // namespace

DOFKIT_CLONES
void load_rows_transposed(const float* const* rows, int nx, const float* mul, float* dst) {
  int x = 0;
  for (; x + 8 <= nx; x += 8)
    for (int j = 0; j < kLanes; j += 8) {
      Vec8 r[8], o[8];
      for (int i = 0; i < 8; ++i) r[i] = SP_LOAD8(rows[j + i] + x);
      transpose8(r, o);
      for (int k = 0; k < 8; ++k) {
        float* d = dst + static_cast<std::size_t>(x + k) * kLanes + j;
        SP_STORE8(d, mul ? o[k] * SP_LOAD8(mul + static_cast<std::size_t>(x + k) * kLanes + j) : o[k]);
      }
    }
  for (; x < nx; ++x)
    for (int j = 0; j < kLanes; ++j) {
      const std::size_t i = static_cast<std::size_t>(x) * kLanes + j;
      dst[i] = mul ? rows[j][x] * mul[i] : rows[j][x];
    }
}

DOFKIT_CLONES
void store_rows_transposed(const float* src, int nx, float* const* rows, int nrows) {
  int x = 0;
  const int jv = nrows - nrows % 8;  // rows stored by the 8×8 blocks
  if (jv > 0)
    for (; x + 8 <= nx; x += 8)
      for (int j = 0; j < jv; j += 8) {
        Vec8 s[8], o[8];
        for (int k = 0; k < 8; ++k) s[k] = SP_LOAD8(src + static_cast<std::size_t>(x + k) * kLanes + j);
        transpose8(s, o);
        for (int i = 0; i < 8; ++i) SP_STORE8(rows[j + i] + x, o[i]);
      }
  for (int j = jv; j < nrows; ++j)  // the remaining rows of the block columns
    for (int xx = 0; xx < x; ++xx) rows[j][xx] = src[static_cast<std::size_t>(xx) * kLanes + j];
  for (; x < nx; ++x)
    for (int j = 0; j < nrows; ++j) rows[j][x] = src[static_cast<std::size_t>(x) * kLanes + j];
}

#undef SP_LOAD8
#undef SP_STORE8

}  // namespace dofkit::core::strip
