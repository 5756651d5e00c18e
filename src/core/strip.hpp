// Shared by the strip filters (core/filters.cpp, core/weighted_gaussian.cpp): a strip holds
// kStripLanes independent 1-D signals interleaved, strip[x · kStripLanes + j] = sample x of
// signal j. The horizontal sweeps transpose rows into and out of it (load_rows_transposed,
// store_rows_transposed) and both filters run their box passes with strip_passes, all three
// in core/strip.cpp, so the two filters' sums are the same bit for bit.
#pragma once
#include <cstddef>

namespace dofkit::core::strip {

constexpr int kStripLanes = 16;

/// The running window sums of the box passes are recomputed from scratch every kResync
/// outputs (see strip_passes). Every sweep that must match the strips bit for bit (the
/// vertical sweeps of core/weighted_gaussian.cpp) re-synchronises at the same outputs.
constexpr int kResync = 32;

/// Eight lanes as one value (GCC/clang vector extension): the row loops of the vertical
/// sweeps (core/weighted_gaussian.cpp) and the transposes keep their sums and blocks in
/// registers instead of re-loading and re-storing an array every step, and need no run-time
/// alias checks between buffers. Element by element the operations are the scalar ones, in the
/// same order, so the sums are the same. (strip_passes uses a 16-lane form of its own.)
typedef float Vec8 __attribute__((vector_size(32)));
/// The same type at float alignment, for unaligned loads and stores through a pointer (no
/// helper function: a vector argument or result would change the baseline clone's ABI).
typedef float Vec8u __attribute__((vector_size(32), aligned(4), may_alias));

/// `passes` extended-box passes (radius r, end weight alpha: the box of core/filters.hpp)
/// over a strip of n samples in a; b is a second strip buffer; both have `pad` >= r + 1
/// border samples, which each pass fills with the replicated edge samples (clamp to edge).
/// Returns the buffer holding the result (a after an even number of passes, b after an odd
/// one): the caller reads it from there, no copy back. Only the result's samples [0, n) are
/// defined on return (the pads of either buffer hold whatever the passes left there).
float* strip_passes(float* a, float* b, int n, int pad, int r, float alpha, int passes);

/// dst[x · kStripLanes + j] = rows[j][x] · (mul ? mul[x · kStripLanes + j] : 1) for x in
/// [0, nx) and j in [0, kStripLanes): kStripLanes rows into a strip (each product rounded once,
/// as a separate multiply would).
void load_rows_transposed(const float* const* rows, int nx, const float* mul, float* dst);

/// rows[j][x] = src[x · kStripLanes + j] for x in [0, nx) and the first nrows signals.
void store_rows_transposed(const float* src, int nx, float* const* rows, int nrows);

/// dst[y · kStripLanes + j] = src[y · stride + min(j, nx − 1)] for y in [0, n), j in
/// [0, kStripLanes): nx <= kStripLanes adjacent columns into a strip, the lanes past the last
/// column repeating it (the vertical sweep of core/filters.cpp).
void load_columns(const float* src, std::size_t stride, int n, int nx, float* dst);

/// dst[y · stride + j] = src[y · kStripLanes + j] for y in [0, n), j in [0, nx).
void store_columns(const float* src, int n, int nx, float* dst, std::size_t stride);

}  // namespace dofkit::core::strip
