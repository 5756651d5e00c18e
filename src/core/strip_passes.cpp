// strip_passes (declared in core/strip_transpose.hpp): the extended-box passes of both strip
// filters, core/filters.cpp (gaussian_blur_plane, the box blurs) and core/weighted_gaussian.cpp
// (the normalised Gaussian of starcraft's medium level).
//
// Precision: the window sum S_i = Σ_{|k|<=r} v_{i+k} is updated as S_{i+1} = S_i + v_{i+r+1}
// − v_{i−r} in float. Each update adds a rounding error of at most ε·|S| (ε = 2⁻²⁴), so after
// m updates the drift is <= m·ε·max|S|; recomputing S from scratch every kResync outputs caps
// m, i.e. the error stays below ~kResync·ε ≈ 2e-6 of the local window magnitude (the plain
// form's double sums are exact to that level, its float output rounding is ε).
#include <algorithm>
#include <cstddef>

#include "core/clones.hpp"
#include "core/strip_transpose.hpp"

namespace dofkit::core::strip {

static_assert(kStripLanes == 16, "strip_passes keeps two 8-lane vectors per step");
constexpr int kLanes = kStripLanes;
#define SP_LOAD8(p) (*reinterpret_cast<const Vec8u*>(p))
#define SP_STORE8(p, v) (*reinterpret_cast<Vec8u*>(p) = (v))

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
    // The window sums are recomputed from scratch at every kResync-th output. When the
    // window is no longer than kResync, the samples of the next fresh sum all enter the window
    // as `hi` during the last 2r + 1 outputs of the current block, so the fresh sum is built
    // there (from 0, in the same order) instead of re-reading them: same value, bit for bit.
    const bool carry = 2 * r + 1 <= kResync;
    Vec8 s0 = zero, s1 = zero, f0 = zero, f1 = zero;  // window sums / next fresh sums, lanes 0-7, 8-15
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
      }
      const int i1 = std::min(n, i0 + kResync);
      const int acc_from = carry ? std::min(i1, i0 + kResync - 2 * r - 1) : i1;
      const float* lo = src + static_cast<std::ptrdiff_t>(i0 - r - 1) * kLanes;  // sample i − r − 1
      const float* hi = src + static_cast<std::ptrdiff_t>(i0 + r + 1) * kLanes;  // sample i + r + 1
      float* d = dst + static_cast<std::ptrdiff_t>(i0) * kLanes;
      for (int i = i0; i < acc_from; ++i, lo += kLanes, hi += kLanes, d += kLanes) {
        const Vec8 h0 = SP_LOAD8(hi), h1 = SP_LOAD8(hi + 8);
        SP_STORE8(d, (s0 + va * (SP_LOAD8(lo) + h0)) * vn);
        SP_STORE8(d + 8, (s1 + va * (SP_LOAD8(lo + 8) + h1)) * vn);
        s0 += h0 - SP_LOAD8(lo + kLanes);  // lo + kLanes: sample i − r, leaving the window
        s1 += h1 - SP_LOAD8(lo + kLanes + 8);
      }
      f0 = zero;
      f1 = zero;
      for (int i = acc_from; i < i1; ++i, lo += kLanes, hi += kLanes, d += kLanes) {
        const Vec8 h0 = SP_LOAD8(hi), h1 = SP_LOAD8(hi + 8);
        SP_STORE8(d, (s0 + va * (SP_LOAD8(lo) + h0)) * vn);
        SP_STORE8(d + 8, (s1 + va * (SP_LOAD8(lo + 8) + h1)) * vn);
        s0 += h0 - SP_LOAD8(lo + kLanes);
        s1 += h1 - SP_LOAD8(lo + kLanes + 8);
        f0 += h0;
        f1 += h1;
      }
    }
    std::swap(a, b);
  }
  return a;
}

#undef SP_LOAD8
#undef SP_STORE8

}  // namespace dofkit::core::strip
