// Pass 2 (sc2) — the quarter-resolution depth the samples read (§5.5 "SSAO Performance": the
// full-res depth "down sampled to a smaller depth buffer that is a quarter size of the
// original on each side").
// Input: the full-res depth. Output: ceil(W/4) × ceil(H/4) texels, each from its 4×4 block
// (clipped at the right and bottom border) by `how`: min (the nearest surface), max, mean, or
// nearest (the block's pixel (1, 1), or the last one of a clipped block).
// Oracle: none needed — one scalar implementation (row-parallel, per-texel independent).
#include <algorithm>
#include <cmath>

#include "core/parallel.hpp"
#include "effects/ssao/ssao.hpp"

namespace dofkit::detail::ao {

void downsample_depth(const Image& depth, const std::string& how, Image& out) {
  const int w = depth.width(), h = depth.height();
  const int qw = (w + 3) / 4, qh = (h + 3) / 4;
  out.resize(qw, qh, 1);
  const int mode = how == "min" ? 0 : how == "max" ? 1 : how == "mean" ? 2 : 3;
  core::parallel_for(
      qh,
      [&](int j0, int j1) {
        for (int j = j0; j < j1; ++j) {
          const int y0 = 4 * j, y1 = std::min(h, y0 + 4);
          float* o = out.row(0, j);
          for (int i = 0; i < qw; ++i) {
            const int x0 = 4 * i, x1 = std::min(w, x0 + 4);
            if (mode == 3) {
              o[i] = depth.row(0, std::min(y0 + 1, y1 - 1))[std::min(x0 + 1, x1 - 1)];
              continue;
            }
            float lo = depth.row(0, y0)[x0], hi = lo, sum = 0;
            for (int y = y0; y < y1; ++y)
              for (int x = x0; x < x1; ++x) {
                const float z = depth.row(0, y)[x];
                lo = std::min(lo, z);
                hi = std::max(hi, z);
                sum += z;
              }
            o[i] = mode == 0 ? lo : mode == 1 ? hi : sum / static_cast<float>((y1 - y0) * (x1 - x0));
          }
        }
      },
      4);
}

}  // namespace dofkit::detail::ao
