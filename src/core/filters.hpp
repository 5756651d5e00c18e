// Separable filters shared by the methods. All use clamp-to-edge borders and cost O(1) per
// pixel whatever the radius, so a large blur is as cheap as a small one.
#pragma once
#include "dofkit/image.hpp"

namespace dofkit::core {

// The functions below are the fast forms: clamp-free interiors (borders replicated into a
// padded strip buffer), float running sums re-synchronised every kResync outputs, several
// columns (vertical) or several transposed rows (horizontal) per SIMD lane group, all passes
// of one axis run while the strip is in cache. They match the `*_plain` oracles (double
// running sums, clamped taps, one pass per sweep) within ~1e-6 of the local signal magnitude
// (tests/core). Output is independent of the thread count (fixed strips, same code per lane).

/// Bits of 2^-96 as a float. A magnitude below it (|x| < 2^-96, x != 0) is "tiny": a few
/// multiplies by blur weights take it to a subnormal, and on Intel cores a vector multiply
/// with a subnormal operand or result takes a microcode assist (~20× its cost). The fast
/// forms multiply blocks holding tiny samples through double instead (exact products,
/// rounded once: the same bits): core/strip.cpp here, and the layered method's up-sampling.
constexpr unsigned kTinyMagnitudeBits = 0x0f800000u;

/// Whether the fast forms take those exact multiplies: only where this core's float multiply
/// is slow on subnormals. Measured once per process, on first use: a dependent chain of 1024
/// scalar multiplies with a subnormal operand against one with a normal operand, best of 3.
/// The exact path is taken where the subnormal chain is 4× slower or more (Intel cores: a
/// microcode assist of ~20× per multiply); where the chain is only ≈ 1.5× slower (AMD Zen) the
/// exact path is pure cost (layered without it: 0.86–0.92 of its 1-thread time, see
/// docs/methods/layered.md). The output bits do not depend on it.
bool exact_tiny_multiplies();
/// Tests: 1 forces the exact multiplies, 0 the float ones, -1 (the default) measures.
void set_exact_tiny_multiplies(int mode);

/// Box mean of (2·rx+1) × (2·ry+1) taps on one plane (src and dst may alias).
void box_blur_plane(const float* src, float* dst, int w, int h, int rx, int ry);

/// Gaussian blur of standard deviation `sigma` px (both axes) approximated by `passes`
/// extended-box passes per axis (Gwosdek et al. 2011): the variance is exact for any real
/// sigma, the shape converges to a Gaussian (3 passes: within ~1 % of peak). O(1) per pixel.
/// In place on every plane of `img`. sigma <= 0 leaves the image unchanged.
void gaussian_blur(Image& img, float sigma, int passes = 3);
/// Same on one plane of w × h floats.
void gaussian_blur_plane(float* data, int w, int h, float sigma_x, float sigma_y, int passes = 3);

/// One extended-box pass along x (rows) or y (columns): weights 1 for |i| <= r and alpha for
/// |i| = r+1, normalised. In place.
void extended_box_x(float* data, int w, int h, int r, float alpha);
void extended_box_y(float* data, int w, int h, int r, float alpha);
/// Radius and end weight of one of `passes` extended boxes giving total variance sigma².
void extended_box_params(float sigma, int passes, int& r, float& alpha);

/// Bilinear sample of one plane at continuous position (x, y) in pixel units, where pixel
/// (i, j) has its centre at (i + 0.5, j + 0.5); clamp-to-edge.
float sample_bilinear(const float* plane, int w, int h, float x, float y);

/// The footprint sample_bilinear uses along one axis of n samples for position x:
/// the clamped neighbours i0, i1 and the weight t of i1.
inline void bilinear_footprint(float x, int n, int& i0, int& i1, float& t) {
  const float f = x - 0.5f;
  const float f0 = __builtin_floorf(f);
  t = f - f0;
  const int k = static_cast<int>(f0);
  i0 = k < 0 ? 0 : (k > n - 1 ? n - 1 : k);
  i1 = k + 1 < 0 ? 0 : (k + 1 > n - 1 ? n - 1 : k + 1);
}
/// Several passes of the same extended box along one axis, in place (fast form).
void extended_box_passes_x(float* data, int w, int h, int r, float alpha, int passes);
void extended_box_passes_y(float* data, int w, int h, int r, float alpha, int passes);

/// Plain forms: the original straightforward implementations, kept as test oracles.
void extended_box_x_plain(float* data, int w, int h, int r, float alpha);
void extended_box_y_plain(float* data, int w, int h, int r, float alpha);
void gaussian_blur_plane_plain(float* data, int w, int h, float sigma_x, float sigma_y, int passes = 3);
void gaussian_blur_plain(Image& img, float sigma, int passes = 3);
void box_blur_plane_plain(const float* src, float* dst, int w, int h, int rx, int ry);

}  // namespace dofkit::core
