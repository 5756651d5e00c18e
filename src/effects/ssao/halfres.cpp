// resolution=half — the AO computed on every other pixel and brought back to full resolution.
// AO is low frequency (the chapter's own argument for its quarter-res depth), so the passes
// 1–4 run on the grid of full-res pixels (2i, 2j) — a quarter of the pixels — with that grid's
// own camera, normals, noise tile and blur (all in grid pixels); the samples still read the
// same quarter-res depth. Then each full-res pixel takes a depth-aware bilinear mix of its
// nearest grid pixels (upsample_ao).
// Inputs/outputs: see ssao.hpp. Oracle: none needed — one scalar implementation for both
// impl values (row-parallel, every output pixel from its inputs alone: the same result for
// every thread count).
#include <algorithm>
#include <cmath>
#include <limits>

#include "core/parallel.hpp"
#include "effects/ssao/ssao.hpp"

namespace dofkit::detail::ao {

void subsample2(const Image& in, Image& out) {
  const int w2 = (in.width() + 1) / 2, h2 = (in.height() + 1) / 2, c = in.channels();
  out.resize(w2, h2, c);
  core::parallel_for(
      h2,
      [&](int j0, int j1) {
        for (int k = 0; k < c; ++k)
          for (int j = j0; j < j1; ++j) {
            const float* s = in.row(k, 2 * j);
            float* o = out.row(k, j);
            for (int i = 0; i < w2; ++i) o[i] = s[2 * i];
          }
      },
      16);
}

Camera half_camera(const Camera& full) {
  Camera c;
  c.w = (full.w + 1) / 2;
  c.h = (full.h + 1) / 2;
  c.f = 0.5f * full.f;
  c.inv_f = 1.0f / c.f;
  c.cx = 0.5f * full.cx + 0.25f;
  c.cy = 0.5f * full.cy + 0.25f;
  fill_rays(c);
  return c;
}

namespace {

// One full-res pixel of depth z from up to four grid taps (t[k] = depth, v[k] = AO, wt[k] =
// bilinear weight), as upsample_ao describes.
template <int N>
inline float mix(float z, float depth_t, const float (&t)[N], const float (&v)[N], const float (&wt)[N]) {
  const float limit = depth_t * z;
  float sum = 0.0f, wsum = 0.0f, best_d = std::numeric_limits<float>::infinity(), best = 1.0f;
  for (int k = 0; k < N; ++k) {
    const float d = std::abs(t[k] - z);  // +inf for a sky tap
    if (d <= limit) {
      sum += wt[k] * v[k];
      wsum += wt[k];
    }
    if (d < best_d) {
      best_d = d;
      best = v[k];
    }
  }
  return wsum > 0.0f ? sum / wsum : best;
}

}  // namespace

void upsample_ao(const Image& depth, const Image& half_depth, const float* half_ao, float depth_t, float* ao) {
  const int w = depth.width(), h = depth.height(), w2 = half_depth.width(), h2 = half_depth.height();
  constexpr float inf = std::numeric_limits<float>::infinity();
  core::parallel_for(
      h,
      [&](int y0, int y1) {
        for (int y = y0; y < y1; ++y) {
          const float* zr = depth.row(0, y);
          float* o = ao + static_cast<std::size_t>(y) * w;
          const int j0 = y >> 1, j1 = std::min(j0 + 1, h2 - 1);
          const float *t0 = half_depth.row(0, j0), *t1 = half_depth.row(0, j1);
          const float *a0 = half_ao + static_cast<std::size_t>(j0) * w2,
                      *a1 = half_ao + static_cast<std::size_t>(j1) * w2;
          const bool odd_row = (y & 1) != 0;
          // Columns in pairs: the even one lies on grid column i, the odd one between i and i + 1.
          for (int x = 0; x < w; x += 2) {
            const int i0 = x >> 1, i1 = std::min(i0 + 1, w2 - 1);
            const float z0 = zr[x];
            if (!(z0 < inf)) {
              o[x] = 1.0f;
            } else if (!odd_row) {
              o[x] = a0[i0];  // on a grid pixel: its only candidate (a sky grid pixel holds 1)
            } else {
              const float t[2] = {t0[i0], t1[i0]}, v[2] = {a0[i0], a1[i0]}, wt[2] = {0.5f, 0.5f};
              o[x] = mix(z0, depth_t, t, v, wt);
            }
            if (x + 1 >= w) break;
            const float z1 = zr[x + 1];
            if (!(z1 < inf)) {
              o[x + 1] = 1.0f;
            } else if (!odd_row) {
              const float t[2] = {t0[i0], t0[i1]}, v[2] = {a0[i0], a0[i1]}, wt[2] = {0.5f, 0.5f};
              o[x + 1] = mix(z1, depth_t, t, v, wt);
            } else {
              const float t[4] = {t0[i0], t0[i1], t1[i0], t1[i1]}, v[4] = {a0[i0], a0[i1], a1[i0], a1[i1]};
              const float wt[4] = {0.25f, 0.25f, 0.25f, 0.25f};
              o[x + 1] = mix(z1, depth_t, t, v, wt);
            }
          }
        }
      },
      8);
}

Image upsample_nearest(const Image& half, int w, int h) {
  Image out(w, h, half.channels());
  for (int c = 0; c < half.channels(); ++c)
    for (int y = 0; y < h; ++y) {
      const float* s = half.row(c, y >> 1);
      float* o = out.row(c, y);
      for (int x = 0; x < w; ++x) o[x] = s[x >> 1];
    }
  return out;
}

}  // namespace dofkit::detail::ao
