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

/// sum[i] += 1 / z[4i + k] for k = 0 … 3 in that order, in double, for i in [0, n): one row's
/// share of the 4×4 block sums of 1/z. IEEE division is correctly rounded whatever the vector
/// width, so every copy (4 or 8 doubles per division instead of the baseline's 2) gives the
/// plain pass's quotients. Four blocks at a time: their 16 quotients are transposed so that
/// lane j of vector k holds block i + j's k-th term, and the four adds per lane run in the
/// plain order (the scalar loop over a separate quotient row ran one dependent add chain per
/// block, 0.5 ms of a 1080p frame on one thread).
static_assert(kDown == 4, "inverse_block_sums sums blocks of four columns");
typedef double Vec4d __attribute__((vector_size(32)));
typedef double Vec4du __attribute__((vector_size(32), aligned(8), may_alias));
typedef float Vec4fu __attribute__((vector_size(16), aligned(4), may_alias));
DOFKIT_CLONES
void inverse_block_sums(const float* __restrict z, double* __restrict sum, int n) {
  const Vec4d one = {1.0, 1.0, 1.0, 1.0};
  int i = 0;
  for (; i + 4 <= n; i += 4) {
    Vec4d q[4];  // q[b] = 1 / z of block i + b (its four columns)
    for (int b = 0; b < 4; ++b)
      q[b] = one / __builtin_convertvector(*reinterpret_cast<const Vec4fu*>(z + 4 * (i + b)), Vec4d);
    // Transpose: t[k] lane b = q[b][k].
    const Vec4d u0 = __builtin_shufflevector(q[0], q[1], 0, 4, 2, 6), u1 = __builtin_shufflevector(q[0], q[1], 1, 5, 3, 7);
    const Vec4d u2 = __builtin_shufflevector(q[2], q[3], 0, 4, 2, 6), u3 = __builtin_shufflevector(q[2], q[3], 1, 5, 3, 7);
    const Vec4d t0 = __builtin_shufflevector(u0, u2, 0, 1, 4, 5), t2 = __builtin_shufflevector(u0, u2, 2, 3, 6, 7);
    const Vec4d t1 = __builtin_shufflevector(u1, u3, 0, 1, 4, 5), t3 = __builtin_shufflevector(u1, u3, 2, 3, 6, 7);
    Vec4d acc = *reinterpret_cast<const Vec4du*>(sum + i);
    acc = acc + t0;
    acc = acc + t1;
    acc = acc + t2;
    acc = acc + t3;
    *reinterpret_cast<Vec4du*>(sum + i) = acc;
  }
  for (; i < n; ++i)
    for (int k = 0; k < kDown; ++k) sum[i] += 1.0 / z[4 * i + k];
}

}  // namespace

void depth_blur(const Image& depth, float sigma_total, Image& inv_depth, bool plain) {
  const int w = depth.width(), h = depth.height();
  const int lw = down_size(w), lh = down_size(h);
  inv_depth.resize(lw, lh, 1);
  const int full = plain ? 0 : w / kDown;  // fast form: blocks with all 4 columns inside
  core::parallel_for(lh, [&](int j0, int j1) {
    thread_local std::vector<double> sum;
    sum.resize(full);
    for (int j = j0; j < j1; ++j) {
      float* o = inv_depth.row(0, j);
      const int ya = j * kDown, yb = std::min(h, (j + 1) * kDown);
      // Fast form: the block sums in the plain form's order (row by row, left to right, see
      // inverse_block_sums), so the sums are identical.
      if (full > 0) {
        std::fill(sum.begin(), sum.end(), 0.0);
        for (int y = ya; y < yb; ++y) inverse_block_sums(depth.row(0, y), sum.data(), full);
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
