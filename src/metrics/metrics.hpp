// Image-quality metrics by the common bokeh-rendering protocol: linear RGB clipped to
// [0, 1], sRGB-encoded; PSNR with peak 1; SSIM with an 11×11 Gaussian window (σ = 1.5),
// K1 = 0.01, K2 = 0.03, mean over R, G, B.
#pragma once
#include <limits>

#include "dofkit/image.hpp"

namespace dofkit::metrics {

struct Scores {
  double psnr_db = 0;       ///< whole image (inf for identical images)
  double ssim = 0;          ///< whole image, mean over RGB
  double edge_psnr_db = std::numeric_limits<double>::quiet_NaN();  ///< within 12 px of a depth edge (NaN if no depth given / no edge)
  double rmse_linear = 0;   ///< RMSE of linear RGB (unclipped)
};

double psnr(const Image& ref, const Image& test);
double ssim(const Image& ref, const Image& test);
double rmse_linear(const Image& ref, const Image& test);
/// Mask (1 plane, 0/1) of pixels within `band_px` of a depth discontinuity (relative jump > `jump`).
Image edge_band(const Image& depth, int band_px = 12, double jump = 0.05);
/// PSNR over the pixels where mask > 0.5.
double psnr_masked(const Image& ref, const Image& test, const Image& mask);
/// All scores; `depth` (pinhole depth of the reference) may be null → no edge PSNR.
Scores compare(const Image& ref, const Image& test, const Image* depth);

}  // namespace dofkit::metrics
