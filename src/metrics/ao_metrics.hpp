// Scores of an ambient-occlusion image against a reference AO, by the external ground
// truth's protocol for AO: PSNR of the linear AO values (peak 1), SSIM of the values (data
// range 1, the protocol's 11×11 Gaussian window), the PSNR inside the edge band (within 12 px
// of a relative depth jump > 5 %), and the mean signed error (test − reference). Pixels
// whose depth is +inf (sky) are left out of the PSNRs and the mean error; SSIM is taken over
// the whole image (both images hold 1 on the sky).
#pragma once
#include <limits>

#include "dofkit/image.hpp"

namespace dofkit::metrics {

struct AoScores {
  double psnr_db = 0;
  double ssim = 0;
  double edge_psnr_db = std::numeric_limits<double>::quiet_NaN();  ///< NaN if no edge pixel
  double mean_error = 0;                                           ///< mean of test − reference
};

/// Throws Error(bad_input) on size mismatch (1 plane each; `depth` 1 plane of the same size).
AoScores compare_ao(const Image& reference, const Image& test, const Image& depth);

}  // namespace dofkit::metrics
