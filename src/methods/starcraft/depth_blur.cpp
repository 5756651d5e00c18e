// C4 — the blurred depth of the depth-ordering test (rule 3), at W/4 × H/4.
// The chapter downsamples and blurs linear depth. We reduce and blur inverse depth 1/z
// instead: the sky (z = +inf) becomes 0 rather than poisoning every average with +inf, and
// the thin-lens CoC is linear in 1/z, so "the neighbourhood is, on average, behind me" is
// measured on the same scale as the blur. The test itself is unchanged in meaning:
// blurred 1/z < own 1/z ⇔ the neighbourhood lies behind the pixel.
#include <algorithm>
#include <cmath>
#include <vector>

#include "core/clones.hpp"
#include "core/filters.hpp"
#include "core/parallel.hpp"
#include "methods/starcraft/starcraft.hpp"

namespace dofkit::detail::starcraft {

namespace {

/// inv[x] = 1 / z[x] in double for x in [0, n). IEEE division is correctly rounded whatever the
/// vector width, so the clones (4 or 8 doubles per division instead of the baseline's 2) give
/// the same values; the divisions bound this pass.
DOFKIT_CLONES
void inverse_row(const float* __restrict z, double* __restrict inv, int n) {
  for (int x = 0; x < n; ++x) inv[x] = 1.0 / z[x];
}

}  // namespace

void depth_blur(const Image& depth, float sigma_total, Image& inv_depth, bool plain) {
  const int w = depth.width(), h = depth.height();
  const int lw = down_size(w), lh = down_size(h);
  inv_depth.resize(lw, lh, 1);
  const int full = plain ? 0 : w / kDown;  // fast form: blocks with all 4 columns inside
  core::parallel_for(lh, [&](int j0, int j1) {
    thread_local std::vector<double> inv, sum;
    inv.resize(static_cast<std::size_t>(full) * kDown);
    sum.resize(full);
    for (int j = j0; j < j1; ++j) {
      float* o = inv_depth.row(0, j);
      const int ya = j * kDown, yb = std::min(h, (j + 1) * kDown);
      // Fast form: 1/z of each row first (a loop that vectorises), then the block sums in
      // the plain form's order (row by row, left to right), so the sums are identical.
      if (full > 0) {
        std::fill(sum.begin(), sum.end(), 0.0);
        for (int y = ya; y < yb; ++y) {
          const float* z = depth.row(0, y);
          inverse_row(z, inv.data(), full * kDown);
          for (int i = 0; i < full; ++i)
            for (int k = 0; k < kDown; ++k) sum[i] += inv[i * kDown + k];
        }
        for (int i = 0; i < full; ++i) o[i] = static_cast<float>(sum[i] / ((yb - ya) * kDown));
      }
      for (int i = full; i < lw; ++i) {
        double s = 0;
        int n = 0;
        for (int y = ya; y < yb; ++y) {
          const float* z = depth.row(0, y);
          for (int x = i * kDown; x < std::min(w, (i + 1) * kDown); ++x, ++n) s += 1.0 / z[x];
        }
        o[i] = static_cast<float>(s / n);
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
