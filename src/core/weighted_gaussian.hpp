// Weighted (normalised) Gaussian in two fused strip sweeps.
//
// A normalised convolution with weights c computes, per plane k,
//     out_k = G * (c · src_k) / G * c            (where G * c > tiny, else src_k),
// so a tap with c = 0 adds nothing. Written as separate passes it costs, per plane, a
// multiply sweep, the Gaussian's horizontal and vertical sweeps and a divide sweep, each a
// full read + write of the plane. Here the multiply happens while a strip of rows is loaded
// for the horizontal passes, and the division while a strip of columns is stored after the
// vertical passes: one read of src and c and one write per plane for each axis.
//
// The Gaussian is the extended-box cascade of core/filters (gaussian_blur_plane, `passes`
// boxes per axis, variance exact for any sigma) with the same strip arithmetic (float running
// sums re-synchronised every 32 outputs, edges replicated into a padded strip), so the result
// is bit for bit that of: multiply, gaussian_blur_plane on every plane and on c, divide.
// Output does not depend on the thread count.
#pragma once
#include <type_traits>

namespace dofkit::core {

/// Normalised Gaussian of `nplanes` planes weighted by c (all w × h floats, row-major).
/// src[k]: input planes; c: weights (>= 0); dst[k]: outputs (must not alias src or c);
/// weight: scratch of w × h floats (holds c blurred along x on return). sigma: Gaussian σ in
/// px (both axes; <= 0: no blur, out = src where c > tiny); passes: boxes per axis; tiny: the
/// smallest blurred weight that is divided by (below it the source is kept).
void weighted_gaussian(const float* const* src, int nplanes, const float* c, int w, int h, float sigma, int passes,
                       float tiny, float* const* dst, float* weight, bool normalise = true);

/// The same normalised Gaussian, streamed: computes the output rows y0 … y1 − 1 in order,
/// full width, without intermediate planes, and hands each to `row_out(y, rows)` (rows[k] =
/// plane k's normalised row, valid during the call). Serial; call it for disjoint bands from
/// parallel workers. Each band warms its passes up from rows above it (about
/// passes · (r + 1) + 32 rows per pass), so the result is bit for bit that of
/// weighted_gaussian whatever the banding. Working memory per call (kept per thread): about
/// (passes + 1) · (2r + 23) rows of (nplanes + 1) · w floats, r ≈ sigma · sqrt(3 / passes).
/// normalise = false: the rows are handed over before the division, rows[k] = plane k's
/// blurred c·src (k < nplanes) and rows[nplanes] = the blurred weight, so that the consumer
/// can divide only where it uses the result (`tiny` is then unused).
/// Row consumer of weighted_gaussian_rows: sink(ctx, y, rows).
using RowSink = void (*)(void* ctx, int y, const float* const* rows);
void weighted_gaussian_rows(const float* const* src, int nplanes, const float* c, int w, int h, float sigma, int passes,
                            float tiny, int y0, int y1, RowSink sink, void* ctx, bool normalise = true);
/// Same with any callable f(y, rows) (no std::function: nothing is allocated per call).
template <class F>
void weighted_gaussian_rows(const float* const* src, int nplanes, const float* c, int w, int h, float sigma, int passes,
                            float tiny, int y0, int y1, F&& row_out, bool normalise = true) {
  using Fn = std::remove_reference_t<F>;
  weighted_gaussian_rows(
      src, nplanes, c, w, h, sigma, passes, tiny, y0, y1,
      [](void* f, int y, const float* const* rows) { (*static_cast<Fn*>(f))(y, rows); },
      const_cast<void*>(static_cast<const void*>(&row_out)), normalise);
}

/// Rows per call of weighted_gaussian_rows' vertical passes: 0 (the default) lets it choose
/// by the rings' size and the L2 (see kWideGroup in weighted_gaussian.cpp); 4 or 32 forces
/// that group on the calling thread, for the tests that hold both to the same bits on any
/// machine. The output never depends on it.
void set_weighted_gaussian_group(int rows);

/// The normalised convolution's sums at one pixel, evaluated without running sums: out[k] =
/// the cascade applied to c·src[k] (c·src rounded to float, as the sweeps form it) for
/// k < nplanes, out[nplanes] = the cascade applied to c, in double. The cascade is linear, so
/// each axis is one weight vector per output position (its clamp-to-edge folded in, found by
/// running the passes' transposes back from the output sample); every weight is >= 0 and so is
/// every partial sum of the weight plane. Hence, with u = 2^-53 and n <= (2R + 1)² + 2R + 1
/// operations per sum (R = passes · (r + 1), the cascade's reach), |out[k] − exact| <=
/// n · u · Σ (weights · |c·src|) (relative to the sum of magnitudes under the kernel, whatever
/// lies outside it; for the weight plane relative to out[nplanes] itself), where the sweeps'
/// float running sums are off by residues of everything that passed through them since their
/// last re-synchronisation (see weighted_gaussian.cpp). O(R²) per pixel: for the few pixels
/// where that residue is not negligible (medium level of starcraft: a small blurred weight).
void weighted_gaussian_at(const float* const* src, int nplanes, const float* c, int w, int h, float sigma, int passes,
                          int x, int y, double* out);

}  // namespace dofkit::core
