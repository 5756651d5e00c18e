// P8 (docs/methods/sterna.md): Sousa's 3×3 max "flood fill".
//
// The rings are 2 half-res px apart, so a bright source seen through the sparse kernel
// leaves one-texel gaps between taps. A per-channel max over the 3×3 neighbourhood closes
// them and grows the bokeh by one texel (13 texels across at kernel_scale 1). It is not
// energy conserving — it brightens — but gives the full, hard-edged bokeh of a real lens,
// and 49 + 9 taps cost about a third of a dense 144-tap kernel of the same width.
// Only texels whose own early-out failed are filled (nearBlur_h > 0, far_h > 0); the others
// are copied, so a far-field max can never reach into the in-focus region (far = 0 there).
// With per_pixel_scale the far neighbours must have a similar kernel: a neighbour is used
// only if its kernel radius differs by at most one texel, |far_n − far_p|·6·kernel_scale <= 1.
#include <algorithm>
#include <cmath>

#include "core/parallel.hpp"
#include "methods/sterna/passes.hpp"

namespace dofkit::detail::sterna {

void fill(const Settings& s, HalfRes& h) {
  const int w = h.w, hh = h.h;
  h.near_fill.resize(w, hh, 4);
  h.far_fill.resize(w, hh, 4);
  const float radius_per_far = kOuterRadius * s.kernel_scale;
  core::parallel_for(
      hh,
      [&](int y0, int y1) {
        for (int y = y0; y < y1; ++y) {
          for (int c = 0; c < 4; ++c) {
            std::copy(h.dof_near.row(c, y), h.dof_near.row(c, y) + w, h.near_fill.row(c, y));
            std::copy(h.dof_far.row(c, y), h.dof_far.row(c, y) + w, h.far_fill.row(c, y));
          }
          const std::uint8_t* tiles = h.tile_active.data() + static_cast<std::size_t>(y / kTile) * h.tiles_x;
          const float* nb = h.near_blur.row(0, y);
          const float* fr = h.coc.row(1, y);
          const int ys[3] = {std::max(y - 1, 0), y, std::min(y + 1, hh - 1)};
          for (int x = 0; x < w; ++x) {
            if (!tiles[x / kTile]) {
              x = (x / kTile + 1) * kTile - 1;
              continue;
            }
            const int xs[3] = {std::max(x - 1, 0), x, std::min(x + 1, w - 1)};
            if (nb[x] > 0.0f)
              for (int c = 0; c < 4; ++c) {
                float m = h.dof_near.row(c, y)[x];
                for (int j : ys)
                  for (int i : xs) m = std::max(m, h.dof_near.row(c, j)[i]);
                h.near_fill.row(c, y)[x] = m;
              }
            if (fr[x] > 0.0f) {
              bool use[3][3];
              for (int a = 0; a < 3; ++a)
                for (int b = 0; b < 3; ++b)
                  use[a][b] =
                      !s.per_pixel_scale || std::abs(h.coc.row(1, ys[a])[xs[b]] - fr[x]) * radius_per_far <= 1.0f;
              for (int c = 0; c < 4; ++c) {
                float m = h.dof_far.row(c, y)[x];
                for (int a = 0; a < 3; ++a)
                  for (int b = 0; b < 3; ++b)
                    if (use[a][b]) m = std::max(m, h.dof_far.row(c, ys[a])[xs[b]]);
                h.far_fill.row(c, y)[x] = m;
              }
            }
          }
        }
      },
      4);
}

}  // namespace dofkit::detail::sterna
