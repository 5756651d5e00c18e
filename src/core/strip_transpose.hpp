// Shared by the strip filters (core/filters.cpp, core/weighted_gaussian.cpp): a strip holds
// kStripLanes independent 1-D signals interleaved, strip[x · kStripLanes + j] = sample x of
// signal j. The horizontal sweeps transpose rows into and out of it with SSE 4×4 transposes
// (baseline x86-64, so no per-target copies are needed); both filters run their box passes
// with strip_passes (core/strip_passes.cpp), so their sums are the same bit for bit.
#pragma once
#include <immintrin.h>

namespace dofkit::core::strip {

constexpr int kStripLanes = 16;

/// The running window sums of the box passes are recomputed from scratch every kResync
/// outputs (see strip_passes). Every sweep that must match the strips bit for bit (the
/// vertical sweeps of core/weighted_gaussian.cpp) re-synchronises at the same outputs.
constexpr int kResync = 32;

/// Eight lanes as one value (GCC/clang vector extension): the strip loops keep the window sums
/// of a strip in registers (two of these for 16 lanes) instead of re-loading and re-storing
/// an array every step, and need no run-time alias checks between the strip buffers. Element
/// by element the operations are the scalar ones, in the same order, so the sums are the same.
typedef float Vec8 __attribute__((vector_size(32)));
/// The same type at float alignment, for unaligned loads and stores through a pointer (no
/// helper function: a vector argument or result would change the baseline clone's ABI).
typedef float Vec8u __attribute__((vector_size(32), aligned(4), may_alias));

/// `passes` extended-box passes (radius r, end weight alpha: the box of core/filters.hpp)
/// over a strip of n samples in a; b is a second strip buffer; both have `pad` >= r + 1
/// border samples, which each pass fills with the replicated edge samples (clamp to edge).
/// Returns the buffer holding the result (a after an even number of passes, b after an odd
/// one): the caller reads it from there, no copy back.
float* strip_passes(float* a, float* b, int n, int pad, int r, float alpha, int passes);

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
