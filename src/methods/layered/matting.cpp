#include "methods/layered/matting.hpp"

#include <algorithm>
#include <atomic>

#include "core/coc_range.hpp"
#include "core/parallel.hpp"
#include "render/sanitize.hpp"

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
  core::parallel_for(
      h,
      [&](int y0, int y1) {
        for (int y = y0; y < y1; ++y) {
          float* out[4];
          for (int c = 0; c < 4; ++c) out[c] = layer.row(c, y);
          std::uint8_t full = 0, holes = 0;
          for (int x = 0; x < w; ++x) {
            float acc[4] = {0, 0, 0, 0};
            // The pixel's farthest fragment: the layer is unknown there (a hole) when even
            // that one lies in front of the layer.
            float r_last = 0.0f;
            bool any = false;
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
              r_last = r;
              any = true;
            }
            if (hole && any && r_last > near_limit) {
              (*hole)[static_cast<std::size_t>(y) * w + x] = 1;
              holes = 1;
            }
            for (int c = 0; c < 4; ++c) out[c][x] = acc[c];
            full |= acc[3] > 0;
          }
          row_full[y] = full;
          row_hole[y] = holes;
        }
      },
      4);
  MatteStats s;
  s.empty = std::none_of(row_full.begin(), row_full.end(), [](std::uint8_t v) { return v != 0; });
  s.holes = std::any_of(row_hole.begin(), row_hole.end(), [](std::uint8_t v) { return v != 0; });
  return s;
}

bool coc_extremes(const Fragments& frags, double& near_px, double& far_px, bool check_colour) {
  // Row-parallel maxima, combined in row order (max is exact and order-free anyway).
  const int w = frags.width(), h = frags.height();
  std::vector<float> row_near(h, 0.0f), row_far(h, 0.0f);
  // check_colour: each row's colour is tested in the same pass, while its alpha row is in
  // L1 (every row of every fragment, all w columns: together every sample once).
  std::atomic<bool> dirty{false};
  core::parallel_for(
      h,
      [&](int y0, int y1) {
        bool bad = false;
        for (int y = y0; y < y1; ++y) {
          float n = 0.0f, f = 0.0f;
          for (std::size_t fr = 0; fr < frags.color.size(); ++fr) {
            const Image& c = *frags.color[fr];
            const float* a = c.row(3, y);
            const float* r = frags.coc[fr]->row(0, y);
            core::coc_row_range(r, a, w, n, f);  // fragments with alpha > 0 only
            if (check_colour) bad |= !rgba_row_is_sanitary(c.row(0, y), c.row(1, y), c.row(2, y), a, w);
          }
          row_near[y] = n;
          row_far[y] = f;
        }
        if (bad) dirty.store(true, std::memory_order_relaxed);
      },
      8);
  if (dirty.load()) return false;
  near_px = 0;
  far_px = 0;
  for (int y = 0; y < h; ++y) {
    near_px = std::max(near_px, static_cast<double>(row_near[y]));
    far_px = std::max(far_px, static_cast<double>(row_far[y]));
  }
  return true;
}

}  // namespace dofkit::detail::layered
