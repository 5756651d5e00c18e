// P9 (docs/methods/sterna.md): upsample the two fields and blend them over the full-res colour,
// far first, near last (the near field must end up on top).
//
// Footprint: full-res pixel q = (x, y) has its centre at (x + ½)/2 in half-res texel units,
// i.e. u = x/2 − ¼ from the centre of texel 0. The 2×2 bilinear footprint is therefore
// texels (⌊u⌋, ⌊u⌋ + 1) with fraction ¾ for even x and ¼ for odd x (same in y), clamped at
// the border. Colour and CoC are always read from this same footprint (the demo mixes two).
//
// Far: bilinear weights b_k are divided by (|far(q) − far_h,k| + 0.001), so texels whose far
// factor differs from the pixel's own — the other side of a depth edge — are ignored, and the
// far field is blended in by compositeBlend · far(q). [our choice] Texels with far_h = 0 hold
// the gather's black "no far field here" marker, not a colour; the formula above still gives
// them weight b_k/(far(q) + 0.001) — a 0.3 % darkening at far/focus borders, and a constant
// image would not stay constant — so they get weight 0. If all four are such texels (q is a
// far pixel in a quad whose top-left is in focus) the far blend is skipped and q stays sharp. (per_pixel_scale: the far
// kernel already has the pixel's size, so the blend only fades out kernels under one half-res texel: compositeBlend ·
// min(1, radius_full_px / 2).) Near: the near field and the dilated near CoC are upsampled with the same filter
// (bilinear, or a cubic B-spline — Sousa's "bicubic": C², non-negative weights, so no
// ringing on HDR highlights) and the field is blended by compositeBlend · nearBlur(q).
#include <algorithm>
#include <cmath>
#include <vector>

#include "core/parallel.hpp"
#include "methods/sterna/passes.hpp"

namespace dofkit::detail::sterna {

void composite(const Image& color, const FullCoc& full, const Settings& s, const HalfRes& h, Image& out) {
  const int W = color.width(), H = color.height();
  out.resize(W, H, 4);
  std::vector<UpsampleAxis> ax(W), ay(H);
  for (int x = 0; x < W; ++x) ax[x] = upsample_axis(x, h.w);
  for (int y = 0; y < H; ++y) ay[y] = upsample_axis(y, h.h);
  const float blend = s.composite_blend;
  const float radius_per_far = 2.0f * kOuterRadius * s.kernel_scale;  // full-res px at far = 1

  core::parallel_for(
      H,
      [&](int y0, int y1) {
        std::vector<std::uint8_t> near_tiles(h.tiles_x);
        for (int y = y0; y < y1; ++y) {
          for (int c = 0; c < 4; ++c) std::copy(color.row(c, y), color.row(c, y) + W, out.row(c, y));
          if (blend <= 0.0f) continue;
          const UpsampleAxis& Y = ay[y];
          const float* ffull = full.coc.row(1, y);
          // Near can reach a pixel only from its own tile or a neighbour (filter reach <= 2
          // texels), so tiles with no near texel around them skip the near upsample entirely.
          const int ty = std::min(y / 2, h.h - 1) / kTile;
          for (int tx = 0; tx < h.tiles_x; ++tx) {
            bool any = false;
            for (int j = std::max(ty - 1, 0); j <= std::min(ty + 1, h.tiles_y - 1); ++j)
              for (int i = std::max(tx - 1, 0); i <= std::min(tx + 1, h.tiles_x - 1); ++i)
                any |= (h.tile_active[static_cast<std::size_t>(j) * h.tiles_x + i] & 1) != 0;
            near_tiles[tx] = any;
          }
          for (int x = 0; x < W; ++x) {
            const bool near_possible = near_tiles[std::min(x / 2, h.w - 1) / kTile] != 0;
            const float fq = ffull[x];
            if (fq <= 0.0f && !near_possible) continue;  // a copy
            const UpsampleAxis& X = ax[x];
            float res[4];
            for (int c = 0; c < 4; ++c) res[c] = out.row(c, y)[x];
            if (fq > 0.0f) {
              float t = blend * fq;
              if (s.per_pixel_scale) t = blend * std::min(1.0f, fq * radius_per_far / 2.0f);
              float wsum = 0.0f, acc[4] = {0, 0, 0, 0};
              for (int b = 0; b < 2; ++b)
                for (int a = 0; a < 2; ++a) {
                  const int i = X.i[1 + a], j = Y.i[1 + b];
                  const float fk = h.coc.row(1, j)[i];
                  if (!(fk > 0.0f)) continue;  // no far field computed there (black marker)
                  const float wk = X.b[a] * Y.b[b] / (std::abs(fq - fk) + 0.001f);
                  wsum += wk;
                  for (int c = 0; c < 4; ++c) acc[c] += wk * h.far_fill.row(c, j)[i];
                }
              if (wsum > 0.0f)
                for (int c = 0; c < 4; ++c) res[c] += (acc[c] / wsum - res[c]) * t;
            }
            if (near_possible) {
              float nb = 0.0f, nf[4] = {0, 0, 0, 0};
              if (s.bicubic_near) {
                for (int b = 0; b < 4; ++b)
                  for (int a = 0; a < 4; ++a) {
                    const int i = X.i[a], j = Y.i[b];
                    const float wk = X.c[a] * Y.c[b];
                    nb += wk * h.near_blur.row(0, j)[i];
                    for (int c = 0; c < 4; ++c) nf[c] += wk * h.near_fill.row(c, j)[i];
                  }
              } else {
                for (int b = 0; b < 2; ++b)
                  for (int a = 0; a < 2; ++a) {
                    const int i = X.i[1 + a], j = Y.i[1 + b];
                    const float wk = X.b[a] * Y.b[b];
                    nb += wk * h.near_blur.row(0, j)[i];
                    for (int c = 0; c < 4; ++c) nf[c] += wk * h.near_fill.row(c, j)[i];
                  }
              }
              const float t = blend * std::min(nb, 1.0f);
              if (t > 0.0f)
                for (int c = 0; c < 4; ++c) res[c] += (nf[c] - res[c]) * t;
            }
            for (int c = 0; c < 4; ++c) out.row(c, y)[x] = res[c];
          }
        }
      },
      8);
}

}  // namespace dofkit::detail::sterna
