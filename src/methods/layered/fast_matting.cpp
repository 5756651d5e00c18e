// Matting pass, fast form (oracle: matting.cpp's matte_layer, bit for bit; tests/layered).
// Inputs: the fragments (colour + CoC per fragment) and the layer plan. Output: layer k =
// Σ over fragments, front to back, of (1 − acc.a)·w_k(r)·I, and its hole mask (the farthest
// fragment's r > near_limit(k)). The matte is evaluated inline (Matte, no call per
// fragment) and the flags are OR-reduced without per-row vectors.
#include <atomic>

#include "core/parallel.hpp"
#include "methods/layered/fast.hpp"
#include "methods/layered/fast_rows.hpp"

namespace dofkit::detail::layered {

MatteStats matte_layer_fast(const Fragments& frags, const LayerPlan& plan, int k, Image& layer, std::uint8_t* hole) {
  const int w = frags.width(), h = frags.height();
  layer.resize(w, h, 4);
  const int nf = static_cast<int>(frags.color.size());
  const double near_limit = plan.near_limit(k);
  const Matte matte(plan, k);
  // OR-reductions: the result does not depend on the order.
  std::atomic<bool> any_full{false}, any_hole{false};
  core::parallel_for(
      h,
      [&](int y0, int y1) {
        bool full = false, holes = false;
        for (int y = y0; y < y1; ++y) {
          float* out[4];
          for (int c = 0; c < 4; ++c) out[c] = layer.row(c, y);
          std::uint8_t* hr = hole ? hole + static_cast<std::size_t>(y) * w : nullptr;
          if (nf == 1) {
            // One fragment per pixel (RGB-D input): acc = 0 + (1 − 0)·w_k·I, as below.
            const float* in[4];
            for (int c = 0; c < 4; ++c) in[c] = frags.color[0]->row(c, y);
            const float* rr = frags.coc[0]->row(0, y);
            for (int x = 0; x < w; ++x) {
              const float a = in[3][x];
              float wk = 0.0f;
              std::uint8_t hv = 0;
              if (a > 0) {
                const float r = rr[x];
                wk = matte(r);
                hv = r > near_limit;
              }
              const float t = (1.0f - 0.0f) * wk;
              for (int c = 0; c < 4; ++c) out[c][x] = wk > 0 ? 0.0f + t * in[c][x] : 0.0f;
              full |= out[3][x] > 0;
              if (hr) {
                hr[x] = hv;
                holes |= hv != 0;
              }
            }
            continue;
          }
          for (int x = 0; x < w; ++x) {
            float acc[4] = {0, 0, 0, 0};
            std::uint8_t hv = 0;
            for (int f = 0; f < nf; ++f) {
              const Image& col = *frags.color[f];
              const float a = col.row(3, y)[x];
              if (!(a > 0)) continue;
              const float r = frags.coc[f]->row(0, y)[x];
              const float wk = matte(r);
              if (wk > 0) {
                const float t = (1.0f - acc[3]) * wk;
                for (int c = 0; c < 4; ++c) acc[c] += t * col.row(c, y)[x];
              }
              hv = r > near_limit;  // the farthest fragment decides (matting.cpp)
            }
            for (int c = 0; c < 4; ++c) out[c][x] = acc[c];
            full |= acc[3] > 0;
            if (hr) {
              hr[x] = hv;
              holes |= hv != 0;
            }
          }
        }
        if (full) any_full.store(true, std::memory_order_relaxed);
        if (holes) any_hole.store(true, std::memory_order_relaxed);
      },
      4);
  MatteStats s;
  s.empty = !any_full.load();
  s.holes = any_hole.load();
  return s;
}

}  // namespace dofkit::detail::layered
