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

namespace dofkit::core {

/// Normalised Gaussian of `nplanes` planes weighted by c (all w × h floats, row-major).
/// src[k]: input planes; c: weights (>= 0); dst[k]: outputs (must not alias src or c);
/// weight: scratch of w × h floats (holds c blurred along x on return). sigma: Gaussian σ in
/// px (both axes; <= 0: no blur, out = src where c > tiny); passes: boxes per axis; tiny: the
/// smallest blurred weight that is divided by (below it the source is kept).
void weighted_gaussian(const float* const* src, int nplanes, const float* c, int w, int h, float sigma,
                       int passes, float tiny, float* const* dst, float* weight, bool normalise = true);

}  // namespace dofkit::core
