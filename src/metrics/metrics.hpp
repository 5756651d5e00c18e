// Image-quality metrics by the common bokeh-rendering protocol: linear RGB clipped to
// [0, 1], sRGB-encoded; PSNR with peak 1; SSIM with an 11×11 Gaussian window (σ = 1.5),
// K1 = 0.01, K2 = 0.03, mean over R, G, B.
//
// Exactly what is computed (docs/quality.md has the rationale):
// - Only planes 0..2 (R, G, B) are compared. Colour is premultiplied, so a pixel with
//   alpha < 1 is compared as composited over black.
// - "Display values" d = srgb_encode(clamp(linear, 0, 1)), the standard piecewise sRGB curve.
// - PSNR = 10 log10(1 / MSE), MSE pooled over R, G, B and all (or all masked) pixels;
//   +inf for identical display values.
// - SSIM matches scikit-image 0.19 `structural_similarity(a, b, channel_axis=-1,
//   gaussian_weights=True, sigma=1.5, use_sample_covariance=False, data_range=1)`:
//   local moments by an 11-tap Gaussian (σ = 1.5, radius int(3.5σ + 0.5) = 5) with
//   scipy's 'reflect' border (… c b a | a b c …), SSIM map cropped by 5 px on every side
//   before averaging, then the mean over R, G, B. Images must be at least 11 × 11.
// - Edge band: pixels within `band_px` (Euclidean, between pixel centres) of a pixel that
//   has a depth jump to a 4-neighbour: |z1 − z2| / min(z1, z2) > `jump`, +inf next to a
//   finite depth counts as a jump, +inf next to +inf does not; NaN never jumps.
// - RMSE of the linear, unclipped R, G, B values, pooled over the three planes.
// All functions throw Error(bad_input) on a size mismatch or fewer than 3 planes, and are
// deterministic (sums are formed per row, then over rows in order, whatever the threads).
#pragma once
#include <limits>

#include "dofkit/image.hpp"

namespace dofkit::metrics {

struct Scores {
  double psnr_db = 0;  ///< whole image (inf for identical images)
  double ssim = 0;     ///< whole image, mean over RGB
  double edge_psnr_db =
      std::numeric_limits<double>::quiet_NaN();  ///< within 12 px of a depth edge (NaN if no depth given / no edge)
  double rmse_linear = 0;                        ///< RMSE of linear RGB (unclipped)
  /// Fraction (0..1) of the pixels inside the edge band (NaN if no depth / mask given).
  double edge_fraction = std::numeric_limits<double>::quiet_NaN();
};

/// Default edge-band half width, pixels, and relative depth jump of the protocol.
inline constexpr int kEdgeBandPx = 12;
inline constexpr double kEdgeJump = 0.05;

double psnr(const Image& ref, const Image& test);
/// PSNR of the linear values of every plane, no clipping: 10·log10(peak² / MSE) (inf for
/// identical images). For HDR buffers such as a lit image (peak 1 = diffuse white).
double psnr_linear(const Image& ref, const Image& test, double peak = 1.0);
double ssim(const Image& ref, const Image& test);
double rmse_linear(const Image& ref, const Image& test);
/// Mask (1 plane, 0/1) of pixels within `band_px` of a depth discontinuity (relative jump > `jump`).
Image edge_band(const Image& depth, int band_px = 12, double jump = 0.05);
/// PSNR over the pixels where mask > 0.5 (NaN if the mask selects no pixel).
double psnr_masked(const Image& ref, const Image& test, const Image& mask);
/// All scores; `depth` (pinhole depth of the reference) may be null → no edge PSNR.
Scores compare(const Image& ref, const Image& test, const Image* depth);
/// All scores with a ready-made edge-band mask (1 plane; null → no edge PSNR). Used when
/// the band must come from a larger image than the one compared (a crop).
Scores compare_with_mask(const Image& ref, const Image& test, const Image* band_mask);

/// Mean SSIM of two single planes of W × H values taken as they are (data range 1; no sRGB
/// encoding), by the protocol's window and border (for AO images). Needs W, H >= 11.
double ssim_values(const float* a, const float* b, int w, int h);

/// The per-pixel display value of the protocol: sRGB encoding of clamp(v, 0, 1).
float display_value(float linear);
/// Copy of the region [x0, x1) × [y0, y1) of every plane. Throws Error(usage) naming the
/// crop if it is empty or leaves the image.
Image crop(const Image& img, int x0, int y0, int x1, int y1);
/// Per-pixel error map (1 plane): mean over R, G, B of |display(ref) − display(test)|.
Image abs_error_map(const Image& ref, const Image& test);

}  // namespace dofkit::metrics
