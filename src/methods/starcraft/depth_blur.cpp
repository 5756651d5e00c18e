// C4 — the blurred depth of the depth-ordering test (rule 3), at W/4 × H/4.
// The chapter downsamples and blurs linear depth. We reduce and blur inverse depth 1/z
// instead: the sky (z = +inf) becomes 0 rather than poisoning every average with +inf, and
// the thin-lens CoC is linear in 1/z, so "the neighbourhood is, on average, behind me" is
// measured on the same scale as the blur. The test itself is unchanged in meaning:
// blurred 1/z < own 1/z ⇔ the neighbourhood lies behind the pixel.
#include <algorithm>
#include <cmath>

#include "core/filters.hpp"
#include "core/parallel.hpp"
#include "methods/starcraft/starcraft.hpp"

namespace dofkit::detail::starcraft {

void depth_blur(const Image& depth, float sigma_total, Image& inv_depth, bool plain) {
  const int w = depth.width(), h = depth.height();
  const int lw = down_size(w), lh = down_size(h);
  inv_depth.resize(lw, lh, 1);
  core::parallel_for(lh, [&](int j0, int j1) {
    for (int j = j0; j < j1; ++j) {
      float* o = inv_depth.row(0, j);
      for (int i = 0; i < lw; ++i) {
        double sum = 0;
        int n = 0;
        for (int y = j * kDown; y < std::min(h, (j + 1) * kDown); ++y) {
          const float* z = depth.row(0, y);
          for (int x = i * kDown; x < std::min(w, (i + 1) * kDown); ++x, ++n) sum += 1.0 / z[x];
        }
        o[i] = static_cast<float>(sum / n);
      }
    }
  }, 4);
  const float s = quarter_res_sigma(sigma_total);
  (plain ? core::gaussian_blur_plane_plain : core::gaussian_blur_plane)(inv_depth.plane(0), lw, lh, s, s, 3);
}

float quarter_res_sigma(float sigma_total) {
  // Variances add under convolution. The 4×4 box mean adds (4² − 1)/12 = 1.25 px² per axis
  // and bilinear up-sampling from a grid of spacing 4 adds a tent of half-width 4, 4²/6 px².
  const float rest = sigma_total * sigma_total - 1.25f - 16.0f / 6.0f;
  return rest > 0 ? std::sqrt(rest) / kDown : 0.0f;
}

}  // namespace dofkit::detail::starcraft
