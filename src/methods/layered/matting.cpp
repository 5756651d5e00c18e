#include "methods/layered/matting.hpp"

#include <algorithm>

#include "core/parallel.hpp"

namespace dofkit::detail::layered {

MatteStats matte_layer(const Fragments& frags, const LayerPlan& plan, int k, Image& layer,
                       std::vector<std::uint8_t>* hole) {
  const int w = frags.width(), h = frags.height();
  layer.resize(w, h, 4);
  if (hole) hole->assign(static_cast<std::size_t>(w) * h, 0);
  const int nf = static_cast<int>(frags.color.size());
  const double near_limit = plan.near_limit(k);
  // Per-row flags, reduced in row order afterwards (deterministic for any partition).
  std::vector<std::uint8_t> row_full(h, 0), row_hole(h, 0);
  core::parallel_for(h, [&](int y0, int y1) {
    for (int y = y0; y < y1; ++y) {
      float* out[4];
      for (int c = 0; c < 4; ++c) out[c] = layer.row(c, y);
      std::uint8_t full = 0, holes = 0;
      for (int x = 0; x < w; ++x) {
        float acc[4] = {0, 0, 0, 0};
        for (int f = 0; f < nf; ++f) {
          const Image& col = *frags.color[f];
          const float a = col.row(3, y)[x];
          if (!(a > 0)) continue;
          const float r = frags.coc[f]->row(0, y)[x];
          const float wk = plan.weight(k, r);
          if (wk > 0) {
            const float t = (1.0f - acc[3]) * wk;
            for (int c = 0; c < 4; ++c) acc[c] += t * col.row(c, y)[x];
          }
          if (f == 0 && hole && r > near_limit) {
            (*hole)[static_cast<std::size_t>(y) * w + x] = 1;
            holes = 1;
          }
        }
        for (int c = 0; c < 4; ++c) out[c][x] = acc[c];
        full |= acc[3] > 0;
      }
      row_full[y] = full;
      row_hole[y] = holes;
    }
  }, 4);
  MatteStats s;
  s.empty = std::none_of(row_full.begin(), row_full.end(), [](std::uint8_t v) { return v != 0; });
  s.holes = std::any_of(row_hole.begin(), row_hole.end(), [](std::uint8_t v) { return v != 0; });
  return s;
}

void coc_extremes(const Fragments& frags, double& near_px, double& far_px) {
  near_px = 0;
  far_px = 0;
  const std::size_t n = frags.color.front()->plane_size();
  for (std::size_t f = 0; f < frags.color.size(); ++f) {
    const float* a = frags.color[f]->plane(3);
    const float* r = frags.coc[f]->plane(0);
    for (std::size_t i = 0; i < n; ++i) {
      if (!(a[i] > 0)) continue;
      near_px = std::max(near_px, static_cast<double>(r[i]));
      far_px = std::max(far_px, -static_cast<double>(r[i]));
    }
  }
}

}  // namespace dofkit::detail::layered
