// Shared by the strip filters (core/filters.cpp, core/weighted_gaussian.cpp): a strip holds
// kStripLanes independent 1-D signals interleaved, strip[x · kStripLanes + j] = sample x of
// signal j. The horizontal sweeps transpose rows into and out of it with SSE 4×4 transposes
// (baseline x86-64, so no per-target copies are needed).
#pragma once
#include <immintrin.h>

namespace dofkit::core::strip {

constexpr int kStripLanes = 16;

/// rows[j][x] = src[x · kStripLanes + j] for x in [0, nx) and the first nrows signals.
inline void store_rows_transposed(const float* src, int nx, float* const* rows, int nrows) {
  constexpr int L = kStripLanes;
  int x = 0;
  if (nrows == L) {
    for (; x + 4 <= nx; x += 4)
      for (int j = 0; j < L; j += 4) {
        __m128 r0 = _mm_loadu_ps(src + (x + 0) * L + j), r1 = _mm_loadu_ps(src + (x + 1) * L + j);
        __m128 r2 = _mm_loadu_ps(src + (x + 2) * L + j), r3 = _mm_loadu_ps(src + (x + 3) * L + j);
        _MM_TRANSPOSE4_PS(r0, r1, r2, r3);
        _mm_storeu_ps(rows[j] + x, r0);
        _mm_storeu_ps(rows[j + 1] + x, r1);
        _mm_storeu_ps(rows[j + 2] + x, r2);
        _mm_storeu_ps(rows[j + 3] + x, r3);
      }
  }
  for (; x < nx; ++x)
    for (int j = 0; j < nrows; ++j) rows[j][x] = src[x * L + j];
}

}  // namespace dofkit::core::strip
