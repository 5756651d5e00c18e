// C4 — the blurred depth of the depth-ordering test (rule 3), at W/4 × H/4.
// The chapter downsamples and blurs linear depth. We reduce and blur inverse depth 1/z
// instead: the sky (z = +inf) becomes 0 rather than poisoning every average with +inf, and
// the thin-lens CoC is linear in 1/z, so "the neighbourhood is, on average, behind me" is
// measured on the same scale as the blur. The test itself is unchanged in meaning:
// blurred 1/z < own 1/z ⇔ the neighbourhood lies behind the pixel.
#include <algorithm>
#include <cmath>
#include <cstddef>
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
    const Vec4d u0 = __builtin_shufflevector(q[0], q[1], 0, 4, 2, 6),
                u1 = __builtin_shufflevector(q[0], q[1], 1, 5, 3, 7);
    const Vec4d u2 = __builtin_shufflevector(q[2], q[3], 0, 4, 2, 6),
                u3 = __builtin_shufflevector(q[2], q[3], 1, 5, 3, 7);
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

// The blur of the fast form. The depth test of the final pass (rule 3) compares the blurred
// 1/z with the pixel's own 1/z against a hard threshold, so a rounding difference in the
// blurred 1/z can switch a pixel between its own level and the blurred one — a jump in the
// output, not a rounding difference. It happens wherever the blurred 1/z lies within a few
// float ulps of the threshold, and that is common: on a plane (1/z affine in the image, the
// bench frame's ground) the blur reproduces the pixel's own 1/z, so the comparison sits on the
// tie tolerance wherever the tail of a neighbouring depth step fades out; in the sky (1/z = 0)
// it sits on it exactly, and a float running sum leaves ~1e-7 behind a step that has left the
// window where the plain double sums give 0. core::gaussian_blur_plane (float sums) therefore
// cannot stand in for the plain pass's blur here (1080p bench frame: 3488 pixels decided the
// other way, most in the sky, where the two levels nearly agree, but on the ground the output
// was up to 0.004 off), so the fast form makes the oracle's arithmetic —
// gaussian_blur_plane_plain: each pass out = float((Σ + α·(lo + hi))·norm), Σ += hi − out_lo,
// in double, input samples clamped to the edges — operation for operation, only vectorised:
// the x passes run 8 rows at a time (lane j = row j, transposed into a padded double strip),
// the y passes 32 columns at a time (lane = column). Same values, bit for bit (tested).
constexpr int kExactRows = 8;
constexpr int kExactCols = 32;
typedef double Vec8d __attribute__((vector_size(64)));
typedef double Vec8du __attribute__((vector_size(64), aligned(8), may_alias));  // unaligned access
typedef float Vec8f __attribute__((vector_size(32)));
typedef float Vec8fu __attribute__((vector_size(32), aligned(4), may_alias));

/// One x pass over a strip of 8 rows: in[(i + pad)·8 + j] = sample i of row j for i in
/// [−pad, w + pad) (edges replicated, pad = r + 1); out gets the pass's float-rounded outputs
/// as doubles, its edges replicated for the next pass.
DOFKIT_CLONES
void exact_box_x(const double* __restrict in, double* __restrict out, int w, int pad, int r, double alpha,
                 double norm) {
  auto at = [&](int i) -> Vec8d {
    return *reinterpret_cast<const Vec8du*>(in + static_cast<std::ptrdiff_t>(i + pad) * kExactRows);
  };
  Vec8d sum = {};
  for (int i = -r; i <= r; ++i) sum += at(i);
  Vec8du* o = reinterpret_cast<Vec8du*>(out + static_cast<std::size_t>(pad) * kExactRows);
  for (int x = 0; x < w; ++x) {
    const Vec8d v = (sum + alpha * (at(x - r - 1) + at(x + r + 1))) * norm;
    o[x] = __builtin_convertvector(__builtin_convertvector(v, Vec8f), Vec8d);
    sum += at(x + r + 1) - at(x - r);
  }
  for (int i = 1; i <= pad; ++i) o[-i] = o[0], o[w - 1 + i] = o[w - 1];
}

/// One y pass over a block of 32 columns stored h rows × 32: out row y from in rows
/// y − r − 1 … y + r + 1 (clamped), the plain pass's expression per column; the 32 running sums
/// stay in registers down the rows.
DOFKIT_CLONES
void exact_box_y(const float* __restrict in, float* __restrict out, int h, int r, double alpha, double norm) {
  constexpr int kV = kExactCols / 8;
  auto rowp = [&](int y) { return in + static_cast<std::size_t>(y < 0 ? 0 : (y >= h ? h - 1 : y)) * kExactCols; };
  auto load = [](const float* p) { return __builtin_convertvector(*reinterpret_cast<const Vec8fu*>(p), Vec8d); };
  Vec8d sum[kV] = {};
  for (int i = -r; i <= r; ++i) {
    const float* q = rowp(i);
    for (int v = 0; v < kV; ++v) sum[v] += load(q + 8 * v);
  }
  for (int y = 0; y < h; ++y) {
    const float* lo = rowp(y - r - 1);
    const float* hi = rowp(y + r + 1);
    const float* out_lo = rowp(y - r);
    float* dst = out + static_cast<std::size_t>(y) * kExactCols;
    for (int v = 0; v < kV; ++v) {
      const Vec8d hv = load(hi + 8 * v);
      *reinterpret_cast<Vec8fu*>(dst + 8 * v) =
          __builtin_convertvector((sum[v] + alpha * (load(lo + 8 * v) + hv)) * norm, Vec8f);
      sum[v] += hv - load(out_lo + 8 * v);
    }
  }
}

/// gaussian_blur_plane_plain(data, w, h, sigma, sigma, passes), bit for bit (see above).
void exact_gaussian(float* data, int w, int h, float sigma, int passes) {
  if (w <= 0 || h <= 0 || !(sigma > 0)) return;
  int r = 0;
  float a = 0.0f;
  core::extended_box_params(sigma, passes, r, a);
  // The plain pass's constants: alpha promoted to double, norm = 1 / (2r + 1 + 2·alpha).
  const double alpha = a, norm = 1.0 / (2.0 * r + 1.0 + 2.0 * a);
  const int pad = r + 1;
  const std::size_t strip = static_cast<std::size_t>(w + 2 * pad) * kExactRows;
  core::parallel_for((h + kExactRows - 1) / kExactRows, [&](int s0, int s1) {
    thread_local std::vector<double> buf;
    buf.resize(2 * strip);
    double* sa = buf.data();
    double* sb = sa + strip;
    for (int s = s0; s < s1; ++s) {
      const int y0 = s * kExactRows, ny = std::min(kExactRows, h - y0);
      // Lanes past the last row repeat it (computed and dropped).
      for (int i = -pad; i < w + pad; ++i) {
        const int x = i < 0 ? 0 : (i >= w ? w - 1 : i);
        for (int j = 0; j < kExactRows; ++j)
          sa[static_cast<std::size_t>(i + pad) * kExactRows + j] =
              data[static_cast<std::size_t>(y0 + std::min(j, ny - 1)) * w + x];
      }
      for (int k = 0; k < passes; ++k) {
        exact_box_x(sa, sb, w, pad, r, alpha, norm);
        std::swap(sa, sb);
      }
      for (int j = 0; j < ny; ++j)
        for (int x = 0; x < w; ++x)
          data[static_cast<std::size_t>(y0 + j) * w + x] =
              static_cast<float>(sa[static_cast<std::size_t>(x + pad) * kExactRows + j]);
    }
  });
  core::parallel_for((w + kExactCols - 1) / kExactCols, [&](int b0, int b1) {
    thread_local std::vector<float> buf;
    buf.resize(2 * static_cast<std::size_t>(h) * kExactCols);
    float* ca = buf.data();
    float* cb = ca + static_cast<std::size_t>(h) * kExactCols;
    for (int b = b0; b < b1; ++b) {
      const int x0 = b * kExactCols, nx = std::min(kExactCols, w - x0);
      for (int y = 0; y < h; ++y) {
        const float* row = data + static_cast<std::size_t>(y) * w + x0;
        float* c = ca + static_cast<std::size_t>(y) * kExactCols;
        std::copy(row, row + nx, c);
        std::fill(c + nx, c + kExactCols, 0.0f);
      }
      for (int k = 0; k < passes; ++k) {
        exact_box_y(ca, cb, h, r, alpha, norm);
        std::swap(ca, cb);
      }
      for (int y = 0; y < h; ++y) {
        const float* c = ca + static_cast<std::size_t>(y) * kExactCols;
        std::copy(c, c + nx, data + static_cast<std::size_t>(y) * w + x0);
      }
    }
  });
}

}  // namespace

void depth_blur(const Image& depth, float sigma_total, Image& inv_depth, bool plain) {
  const int w = depth.width(), h = depth.height();
  const int lw = down_size(w), lh = down_size(h);
  inv_depth.resize(lw, lh, 1);
  const int full = plain ? 0 : w / kDown;  // fast form: blocks with all 4 columns inside
  core::parallel_for(
      lh,
      [&](int j0, int j1) {
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
      },
      4);
  const float s = quarter_res_sigma(sigma_total);
  if (plain)
    core::gaussian_blur_plane_plain(inv_depth.plane(0), lw, lh, s, s, 3);
  else
    exact_gaussian(inv_depth.plane(0), lw, lh, s, 3);
}

float quarter_res_sigma(float sigma_total) {
  // Variances add under convolution. The 4×4 box mean adds (4² − 1)/12 = 1.25 px² per axis
  // and bilinear up-sampling from a grid of spacing 4 adds a tent of half-width 4, 4²/6 px².
  const float rest = sigma_total * sigma_total - 1.25f - 16.0f / 6.0f;
  return rest > 0 ? std::sqrt(rest) / kDown : 0.0f;
}

}  // namespace dofkit::detail::starcraft
