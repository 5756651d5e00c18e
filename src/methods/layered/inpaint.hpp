// Push-pull (pyramid) inpainting of a layer's disoccluded pixels from the layer's own content.
#pragma once
#include <algorithm>
#include <cstdint>
#include <vector>

#include "core/parallel.hpp"
#include "dofkit/image.hpp"

namespace dofkit::detail::layered {

/// Replaces the pixels of `layer` (premultiplied RGBA) where hole != 0 by a smooth
/// extrapolation of the known pixels (Gortler et al. 1996 push-pull): "pull" builds a
/// pyramid of weight-normalised 2×2 averages of the known pixels, "push" fills each level's
/// unknown part from the bilinearly upsampled coarser level. Known pixels include
/// transparent ones, so a filled pixel's alpha is the share of this layer's content around
/// the hole (a hole bordered by this layer on one side only is filled half-transparent and
/// lets the farther layers show). `opaque` = true un-premultiplies the fill to alpha 1
/// (used for the farthest layer, the backstop that keeps the result opaque).
/// `under` = true keeps what the layer already holds at a hole pixel (hidden fragments of
/// multi-layer input) in front of the fill: layer = layer over fill there.
void push_pull_fill(Image& layer, const std::vector<std::uint8_t>& hole, bool opaque, bool under = false);

/// The pull of coarse pixel (x, y) of a pyramid level (push_pull_fill's, and impl=fast's for
/// the pixels its row kernels do not cover): value = Σ w v / Σ w over the 2×2 children of
/// `fine` in the order (0,0), (1,0), (0,1), (1,1), double sums, 0 where Σ w = 0; confidence
/// = min(1, Σ w / 4). `weight_of(fx, fy)` is the child's confidence; children with
/// confidence <= 0 or outside `fine` are skipped.
template <class WeightOf>
inline void pull_pixel(const Image& fine, const WeightOf& weight_of, int x, int y, Image& cv, Image& cwt) {
  const int fw = fine.width(), fh = fine.height();
  double sw = 0, sv[4] = {0, 0, 0, 0};
  for (int dy = 0; dy < 2; ++dy)
    for (int dx = 0; dx < 2; ++dx) {
      const int fx = 2 * x + dx, fy = 2 * y + dy;
      if (fx >= fw || fy >= fh) continue;
      const float wt = weight_of(fx, fy);
      if (wt <= 0) continue;
      sw += wt;
      for (int k = 0; k < 4; ++k) sv[k] += wt * fine.row(k, fy)[fx];
    }
  cwt.row(0, y)[x] = static_cast<float>(std::min(1.0, sw / 4.0));
  for (int k = 0; k < 4; ++k) cv.row(k, y)[x] = sw > 0 ? static_cast<float>(sv[k] / sw) : 0.0f;
}

/// pull_pixel for every pixel of the coarse level (cv, cwt already sized).
template <class WeightOf>
void pull_level(const Image& fine, const WeightOf& weight_of, Image& cv, Image& cwt) {
  core::parallel_for(
      cv.height(),
      [&](int y0, int y1) {
        for (int y = y0; y < y1; ++y)
          for (int x = 0; x < cv.width(); ++x) pull_pixel(fine, weight_of, x, y, cv, cwt);
      },
      8);
}

}  // namespace dofkit::detail::layered
