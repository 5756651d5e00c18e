// Disc (uniform circular aperture) blur of a layer, for the layered method's `psf=disc` mode.
//
// The kernel is a pixel-grid disc of radius R px with an anti-aliased rim: the tap at offset
// (dx, dy) has coverage cov = saturate(R − sqrt(dx² + dy²) + 0.5) — 1 inside, 0 outside, a
// linear ramp across the one-pixel band around the circle, the same coverage the reference
// method's scatter uses — and weight cov / Σcov so the kernel sums to 1 exactly (not π R²).
// For R <= 0.5 only the centre tap is non-zero: the blur is the identity.
//
// Evaluation: every kernel row dy is a *span* of full-weight taps |dx| <= n_dy plus a few rim
// taps on either side. A span is one difference of a row prefix sum, so a pixel costs
// (2R + 1) span look-ups plus the rim taps (about 2π R in all): O(R) per pixel, exact (no
// approximation of the shape). Prefix sums are in double so long rows lose nothing.
// Borders clamp to the edge (as core::gaussian_blur). Output does not depend on the thread
// count: every output pixel is summed in the same fixed order.
//
// Other apertures (core/aperture.hpp): the kernel is the model's footprint for the layer's
// anchor radius and field side, read as a gather (the tap at offset t weighs the footprint at
// −t: a source spreads over p = q + o, so receiver p gathers q = p − o). Each row is a run of
// full-weight taps (the footprint's interior, asymmetric in general) plus partial taps, where
// consecutive taps of equal weight (an aperture image's flat parts, a polygon's horizontal
// edge) form one run: one span look-up each. An RGB aperture image gives each colour plane its
// own kernel and the alpha plane the mean of the three.
#pragma once
#include <vector>

#include "core/aperture.hpp"
#include "dofkit/image.hpp"

namespace dofkit::detail::layered {

struct DiscKernel {
  struct Tap {
    int dx;
    double w;
    int len = 1;  ///< taps dx … dx + len − 1, each of weight w
  };
  struct Row {
    int dy;
    int lo = 0, hi = -1;   ///< full-weight taps dx ∈ [lo, hi] (none when lo > hi)
    std::vector<Tap> rim;  ///< partial-coverage taps of this row
  };
  double radius = 0;
  int extent = 0;          ///< largest |dx| or |dy| with a non-zero tap
  double full_weight = 1;  ///< weight of one full-coverage tap (1 / Σcov)
  std::vector<Row> rows;
};

/// Coverage of the tap at (dx, dy) of a disc of radius r: saturate(r − |(dx, dy)| + 0.5).
double disc_coverage(double r, int dx, int dy);

/// The normalised kernel of a disc of radius `radius` px (>= 0).
DiscKernel make_disc_kernel(double radius);

/// The normalised gather kernel of `model`'s footprint for a layer of signed CoC `coc` px
/// (radius |coc|, field side from its sign), coverage channel `channel` (−1: the mean of the
/// model's channels). The circle gives make_disc_kernel(|coc|).
DiscKernel make_aperture_kernel(const core::ApertureModel& model, double coc, int channel);

/// Blurs every plane of `img` by the disc of radius `radius` px, in place.
void disc_blur(Image& img, double radius);

/// Blurs every plane of `img` by the footprint of `model` for signed CoC `coc` px, in place
/// (model null or the circle: disc_blur(img, |coc|)).
void disc_blur(Image& img, double coc, const core::ApertureModel* model);

}  // namespace dofkit::detail::layered
