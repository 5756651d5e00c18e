// P2/P3 of the McGuire method (docs/methods/mcguire.md): the dual separable blur.
//
// Each 1-D pass reads taps B = A + δ·e, δ ∈ [−R_max, R_max] (full-resolution spacing, clamped
// to the buffer), around a point-decimated centre A, and accumulates two results at once:
//
// 1. The far/focus "blurry" image. Tap B is a gather that imitates a scatter: it counts only
//    if B's own disc reaches A (the kernel is stretched to B's radius, so a sharp tap reaches
//    only δ = 0), only if B is not in the near field, and — with the far occlusion test — only
//    if B is not meaningfully farther than A (|r_A| − |r_B| + 1.5 > 0, soft). When A itself is
//    in the near field every tap gets weight 1 instead: a plain box of everything around A,
//    which "inpaints" the background hidden behind the blurry near object.
// 2. The near field, premultiplied by a coverage α: in the horizontal pass each near tap gets
//    α_B from a curve of r_B / R_near (a near tap only "reaches" A if |δ| <= r_B), and the
//    premultiplied (α_B·colour, α_B) is box-averaged over |δ| < R_near; the vertical pass box-
//    averages those premultiplied values again. Dividing by the full box count (not by Σα)
//    is what makes the near field's silhouette soft: coverage fades over R_near.
//
// Colour is RGBA premultiplied; alpha is blurred like a colour channel.
#include <algorithm>
#include <cmath>
#include <vector>

#include "core/parallel.hpp"
#include "methods/mcguire/blur_weights.hpp"
#include "methods/mcguire/g3d.hpp"
#include "methods/mcguire/mcguire.hpp"

namespace dofkit::detail::mcguire {

namespace {

// The g3d kernels' constants (g3d.hpp); `tab` holds near_box(δ) then δ² for δ = −R … R.
G3dParams g3d_params(const Constants& k, std::vector<float>& tab) {
  G3dParams p;
  p.R = k.r_max;
  p.f = k.f;
  p.rmax = static_cast<float>(k.r_max);
  p.occlusion = k.far_occlusion;
  p.inv_near = k.inv_near;
  p.near_inv = near_box_inverse_norm(k);
  p.fov_rad = k.g3d_fov_rad;
  const std::size_t n = 2 * static_cast<std::size_t>(k.r_max) + 1;
  tab.resize(2 * n);
  bool any = false;
  for (int d = -k.r_max; d <= k.r_max; ++d) {
    any |= (tab[d + k.r_max] = near_box(k, static_cast<float>(d))) != 0.0f;
    tab[n + d + k.r_max] = static_cast<float>(d) * static_cast<float>(d);
  }
  p.near_tab = any ? tab.data() : nullptr;  // R_near = 0: the near sums are all 0
  p.d2_tab = tab.data() + n;
  return p;
}

// Per-thread scratch of the g3d kernels: grows to the largest row / row group seen and is
// reused by every later frame (no allocation in steady state).
std::vector<float>& g3d_scratch() {
  thread_local std::vector<float> s;
  return s;
}

void g3d_horizontal(const Image& packed, const Constants& k, int ox, int wo, Image& t_blur, Image& t_near) {
  std::vector<float> tab;
  const G3dParams p = g3d_params(k, tab);
  core::parallel_for(
      packed.height(),
      [&](int y0, int y1) {
        std::vector<float>& scratch = g3d_scratch();
        for (int y = y0; y < y1; ++y) {
          G3dRowJob job;
          for (int c = 0; c < 5; ++c) {
            job.src[c] = packed.row(c, y);
            job.t_blur[c] = t_blur.row(c, y);
            job.t_near[c] = t_near.row(c, y);
          }
          job.W = packed.width();
          job.ox = ox;
          job.wo = wo;
          g3d_horizontal_row(p, job, scratch);
        }
      },
      4);
}

}  // namespace

void blur_horizontal_plain(const Image& packed, const Constants& k, int ox, int wo, Image& t_blur, Image& t_near) {
  const int W = packed.width(), H = packed.height(), R = k.r_max;
  const float rmax = static_cast<float>(R);
  t_blur.resize(wo, H, 5);
  t_near.resize(wo, H, 5);
  core::parallel_for(
      H,
      [&](int y0, int y1) {
        for (int y = y0; y < y1; ++y) {
          const float* col[4] = {packed.row(0, y), packed.row(1, y), packed.row(2, y), packed.row(3, y)};
          const float* s = packed.row(4, y);
          for (int i = 0; i < wo; ++i) {
            const int a = ox + k.f * i;
            const float r_a = s[a] * rmax;
            const float nearness = saturate(4.0f * r_a);
            float blur[4] = {0, 0, 0, 0}, blur_w = 0;
            float near[5] = {0, 0, 0, 0, 0}, near_w = 0;
            for (int d = -R; d <= R; ++d) {
              const int b = std::clamp(a + d, 0, W - 1);
              const float r_b = s[b] * rmax;
              const float wn = far_weight(k, static_cast<float>(d), r_a, r_b);
              const float w = wn + (1.0f - wn) * nearness;  // lerp(wn, 1, nearness_A)
              for (int c = 0; c < 4; ++c) blur[c] += w * col[c][b];
              blur_w += w;
              const float alpha = near_alpha_horizontal(k, static_cast<float>(d), r_b);
              const float v = near_box(k, static_cast<float>(d));
              for (int c = 0; c < 4; ++c) near[c] += v * alpha * col[c][b];
              near[4] += v * alpha;
              near_w += v;
            }
            for (int c = 0; c < 4; ++c) t_blur.row(c, y)[i] = blur[c] / blur_w;
            t_blur.row(4, y)[i] = s[a];
            const float inv = 1.0f / std::max(near_w, 1e-5f);
            for (int c = 0; c < 5; ++c) t_near.row(c, y)[i] = near[c] * inv;
          }
        }
      },
      4);
}

void blur_vertical_plain(const Image& t_blur, const Image& t_near, const Constants& k, int oy, int ho, Image& blur,
                         Image& near) {
  const int W = t_blur.width(), H = t_blur.height(), R = k.r_max;
  const float rmax = static_cast<float>(R);
  blur.resize(W, ho, 4);
  near.resize(W, ho, 5);
  core::parallel_for(
      ho,
      [&](int j0, int j1) {
        for (int j = j0; j < j1; ++j) {
          const int a = oy + k.f * j;
          for (int i = 0; i < W; ++i) {
            const float r_a = t_blur.at(i, a, 4) * rmax;
            const float nearness = saturate(4.0f * r_a);
            float acc[4] = {0, 0, 0, 0}, acc_w = 0;
            float nacc[5] = {0, 0, 0, 0, 0}, nacc_w = 0;
            for (int d = -R; d <= R; ++d) {
              const int b = std::clamp(a + d, 0, H - 1);
              const float r_b = t_blur.at(i, b, 4) * rmax;
              const float wn = far_weight(k, static_cast<float>(d), r_a, r_b);
              const float w = wn + (1.0f - wn) * nearness;
              for (int c = 0; c < 4; ++c) acc[c] += w * t_blur.at(i, b, c);
              acc_w += w;
              const float v = near_box(k, static_cast<float>(d));
              for (int c = 0; c < 5; ++c) nacc[c] += v * t_near.at(i, b, c);
              nacc_w += v;
            }
            for (int c = 0; c < 4; ++c) blur.at(i, j, c) = acc[c] / acc_w;
            const float inv = 1.0f / std::max(nacc_w, 1e-5f);
            float n[5];
            for (int c = 0; c < 5; ++c) n[c] = nacc[c] * inv;
            if (k.variant == Variant::g3d) g3d_coverage_curve(k, n);
            for (int c = 0; c < 5; ++c) near.at(i, j, c) = n[c];
          }
        }
      },
      2);
}

// Fast P2. g3d: the SIMD kernel of g3d_simd.cpp (g3d.hpp explains it; equal to the plain pass
// within float rounding). book/demo (used by tests only: the renderer takes fast.cpp's passes
// for them): the same sums as blur_horizontal_plain, in the same order, but each output pixel
// only visits the taps that can contribute. For book/demo the far weight is exactly 0 once
// 5|δ| / (0.001 + c|r_B|) >= 6, i.e. |δ| >= 1.2 (0.001 + c|r_B|), and a near tap only
// contributes for |δ| <= r_B; so unless the centre itself is near-field (then every tap has
// weight 1), the loop can stop at the largest such reach over a tile's tap window. Skipped
// terms are exact zeros, so the result is bit-identical to the plain pass. The near
// normaliser (the box count) does not depend on the data and is computed once. Rows are
// padded with R_max replicated edge pixels so clamped taps need no clamp in the loop.
void blur_horizontal(const Image& packed, const Constants& k, int ox, int wo, Image& t_blur, Image& t_near) {
  t_blur.resize(wo, packed.height(), 5);
  t_near.resize(wo, packed.height(), 5);
  if (k.variant == Variant::g3d) return g3d_horizontal(packed, k, ox, wo, t_blur, t_near);
  const int W = packed.width(), H = packed.height(), R = k.r_max, f = k.f;
  const float rmax = static_cast<float>(R);
  const float reach_c = k.variant == Variant::book ? 0.5f : 0.8f;
  const float near_inv = near_box_inverse_norm(k);
  constexpr int kTile = 8;
  core::parallel_for(
      H,
      [&](int y0, int y1) {
        const int P = W + 2 * R;
        std::vector<float> col[4], rb(P);
        for (auto& c : col) c.resize(P);
        for (int y = y0; y < y1; ++y) {
          for (int x = 0; x < P; ++x) {
            const int src = std::clamp(x - R, 0, W - 1);
            for (int c = 0; c < 4; ++c) col[c][x] = packed.row(c, y)[src];
            rb[x] = packed.row(4, y)[src] * rmax;
          }
          for (int i0 = 0; i0 < wo; i0 += kTile) {
            const int i1 = std::min(wo, i0 + kTile);
            // Tap window of the tile in padded coordinates: [ox + f·i0, ox + f·(i1−1) + 2R].
            float far_max = 0, near_max = 0;
            for (int x = ox + f * i0; x <= ox + f * (i1 - 1) + 2 * R; ++x) {
              if (in_near(rb[x]))
                near_max = std::max(near_max, rb[x]);
              else
                far_max = std::max(far_max, std::fabs(rb[x]));
            }
            const int far_reach = static_cast<int>(1.2f * (0.001f + reach_c * far_max)) + 1;
            const int near_reach = std::min(static_cast<int>(near_max), static_cast<int>(std::ceil(k.r_near)));
            const int tile_bound = std::min(R, std::max(far_reach, near_reach));
            for (int i = i0; i < i1; ++i) {
              const int a = ox + f * i + R;
              const float r_a = rb[a];
              const float nearness = saturate(4.0f * r_a);
              const int L = nearness > 0 ? R : tile_bound;
              float blur[4] = {0, 0, 0, 0}, blur_w = 0;
              float near[5] = {0, 0, 0, 0, 0};
              for (int d = -L; d <= L; ++d) {
                const int b = a + d;
                const float r_b = rb[b];
                const float wn = far_weight(k, static_cast<float>(d), r_a, r_b);
                const float w = wn + (1.0f - wn) * nearness;
                for (int c = 0; c < 4; ++c) blur[c] += w * col[c][b];
                blur_w += w;
                const float v = near_box(k, static_cast<float>(d));
                if (v != 0.0f) {
                  const float va = v * near_alpha_horizontal(k, static_cast<float>(d), r_b);
                  for (int c = 0; c < 4; ++c) near[c] += va * col[c][b];
                  near[4] += va;
                }
              }
              for (int c = 0; c < 4; ++c) t_blur.row(c, y)[i] = blur[c] / blur_w;
              t_blur.row(4, y)[i] = packed.row(4, y)[a - R];
              for (int c = 0; c < 5; ++c) t_near.row(c, y)[i] = near[c] * near_inv;
            }
          }
        }
      },
      4);
}

// Fast P3. g3d: the SIMD kernel of g3d_simd.cpp. book/demo (tests only, as above): the same
// per-pixel sums in the same δ order as blur_vertical_plain, but with the
// tap loop outside the loop over a row of outputs, so every tap reads one contiguous row
// (the plain version walks down columns), and with rows of zero near-box weight skipped.
void blur_vertical(const Image& t_blur, const Image& t_near, const Constants& k, int oy, int ho, Image& blur,
                   Image& near) {
  const int W = t_blur.width(), H = t_blur.height(), R = k.r_max;
  const float rmax = static_cast<float>(R);
  blur.resize(W, ho, 4);
  near.resize(W, ho, 5);
  if (k.variant == Variant::g3d) {
    std::vector<float> tab;
    const G3dParams p = g3d_params(k, tab);
    // Fixed work items of 64 output rows × 256 columns (not the partitioner's chunks: each
    // item copies a 2R-row halo, and 2 threads need enough items to share evenly).
    constexpr int kRows = 64, kCols = 256;
    const int nj = (ho + kRows - 1) / kRows, nx = (W + kCols - 1) / kCols;
    core::parallel_for(nj * nx, [&](int t0, int t1) {
      for (int t = t0; t < t1; ++t) {
        const int j0 = (t / nx) * kRows, x0 = (t % nx) * kCols;
        g3d_vertical_block(p, t_blur, t_near, oy, j0, std::min(ho, j0 + kRows), x0, std::min(W, x0 + kCols), blur, near,
                           g3d_scratch());
      }
    });
    return;
  }
  const float near_inv = near_box_inverse_norm(k);
  core::parallel_for(
      ho,
      [&](int j0, int j1) {
        std::vector<float> r_a(W), nearness(W), acc(5 * W), nacc(5 * W);
        for (int j = j0; j < j1; ++j) {
          const int a = oy + k.f * j;
          const float* sa = t_blur.row(4, a);
          for (int i = 0; i < W; ++i) {
            r_a[i] = sa[i] * rmax;
            nearness[i] = saturate(4.0f * r_a[i]);
          }
          std::fill(acc.begin(), acc.end(), 0.0f);
          std::fill(nacc.begin(), nacc.end(), 0.0f);
          for (int d = -R; d <= R; ++d) {
            const int b = std::clamp(a + d, 0, H - 1);
            const float* sb = t_blur.row(4, b);
            const float* cb[4] = {t_blur.row(0, b), t_blur.row(1, b), t_blur.row(2, b), t_blur.row(3, b)};
            const float fd = static_cast<float>(d);
            for (int i = 0; i < W; ++i) {
              const float wn = far_weight(k, fd, r_a[i], sb[i] * rmax);
              const float w = wn + (1.0f - wn) * nearness[i];
              for (int c = 0; c < 4; ++c) acc[c * W + i] += w * cb[c][i];
              acc[4 * W + i] += w;
            }
            const float v = near_box(k, fd);
            if (v != 0.0f)
              for (int c = 0; c < 5; ++c) {
                const float* nb = t_near.row(c, b);
                float* na = nacc.data() + c * W;
                for (int i = 0; i < W; ++i) na[i] += v * nb[i];
              }
          }
          for (int i = 0; i < W; ++i) {
            for (int c = 0; c < 4; ++c) blur.at(i, j, c) = acc[c * W + i] / acc[4 * W + i];
            float n[5];
            for (int c = 0; c < 5; ++c) n[c] = nacc[c * W + i] * near_inv;
            if (k.variant == Variant::g3d) g3d_coverage_curve(k, n);
            for (int c = 0; c < 5; ++c) near.at(i, j, c) = n[c];
          }
        }
      },
      2);
}

}  // namespace dofkit::detail::mcguire
