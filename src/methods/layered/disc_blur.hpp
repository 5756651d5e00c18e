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
#pragma once
#include <vector>

#include "dofkit/image.hpp"

namespace dofkit::detail::layered {

struct DiscKernel {
  struct Tap {
    int dx;
    double w;
  };
  struct Row {
    int dy;
    int span;              ///< full-weight taps dx ∈ [−span, span]; −1: none
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

/// Blurs every plane of `img` by the disc of radius `radius` px, in place.
void disc_blur(Image& img, double radius);

}  // namespace dofkit::detail::layered
