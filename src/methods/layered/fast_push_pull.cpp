// Push-pull hole fill, fast form: see fast_push_pull.hpp.
#include "methods/layered/fast_push_pull.hpp"

#include <algorithm>
#include <memory>

#include "core/parallel.hpp"
#include "core/row_scan.hpp"
#include "methods/layered/fast.hpp"
#include "methods/layered/fast_rows.hpp"
#include "methods/layered/inpaint.hpp"

namespace dofkit::detail::layered {

Pyramid make_pyramid(Workspace& ws, int w, int h, const std::string& prefix) {
  Pyramid p;
  int cw = w, ch = h, l = 0;
  while (cw > 1 || ch > 1) {
    cw = (cw + 1) / 2;
    ch = (ch + 1) / 2;
    ++l;
    p.val.push_back(&ws.image(prefix + "v" + std::to_string(l), cw, ch, 4));
    p.wgt.push_back(&ws.image(prefix + "w" + std::to_string(l), cw, ch, 1));
  }
  p.levels = static_cast<int>(p.val.size());
  return p;
}

void pull_upper_row(const Image& fine, const Image& fwt, Image& cv, Image& cwt, int y) {
  const int fw = fine.width(), fh = fine.height(), cw = cv.width();
  int x = 0;
  if (2 * y + 1 < fh) {  // interior blocks of full 2×2 children, 128 at a time
    const int full = fw / 2;
    for (; x < full; x += 128) {
      const int m = std::min(128, full - x);
      const float* f0[4];
      const float* f1[4];
      float* o[4];
      for (int k = 0; k < 4; ++k) {
        f0[k] = fine.row(k, 2 * y) + 2 * x;
        f1[k] = fine.row(k, 2 * y + 1) + 2 * x;
        o[k] = cv.row(k, y) + x;
      }
      const float* wa = fwt.row(0, 2 * y) + 2 * x;
      const float* wb = fwt.row(0, 2 * y + 1) + 2 * x;
      const bool any = core::any_positive(wa, 2 * m) || core::any_positive(wb, 2 * m);  // a child the pull counts
      if (!any) {  // no child with confidence: Σ w = 0 gives value 0, confidence 0
        float* cwp = cwt.row(0, y) + x;
        kern::fill_rows(o, 4, m, 0.0f);
        kern::fill_rows(&cwp, 1, m, 0.0f);
        continue;
      }
      if (kern::all_one(wa, 2 * m) && kern::all_one(wb, 2 * m)) {
        bool zero = true;
        for (int k = 0; k < 4 && zero; ++k) zero = !kern::any_bits(f0[k], 2 * m) && !kern::any_bits(f1[k], 2 * m);
        if (zero) {
          // Four children of confidence 1 and value +0 (a region where the layer is known
          // to be empty): Σ w v = +0 + 1·(+0) + … = +0, Σ w = 4, so value +0 / 4 = +0 and
          // confidence min(1, 4/4) = 1, exactly what pull_pairs_w computes.
          float* cwp = cwt.row(0, y) + x;
          kern::fill_rows(o, 4, m, 0.0f);
          kern::fill_rows(&cwp, 1, m, 1.0f);
          continue;
        }
      }
      kern::pull_pairs_w(f0, f1, wa, wb, m, o, cwt.row(0, y) + x);
    }
    x = full;
  }
  for (; x < cw; ++x)  // the rest, one pixel at a time
    pull_pixel(
        fine, [&](int fx, int fy) { return fwt.row(0, fy)[fx]; }, x, y, cv, cwt);
}

void pull_push_upper(const Pyramid& p, int first) {
  for (int l = first; l < p.levels; ++l) {
    const Image& fine = *p.val[l - 1];
    const Image& fwt = *p.wgt[l - 1];
    Image& cv = *p.val[l];
    Image& cwt = *p.wgt[l];
    core::parallel_for(
        cv.height(),
        [&](int y0, int y1) {
          for (int y = y0; y < y1; ++y) pull_upper_row(fine, fwt, cv, cwt, y);
        },
        8);
  }
  for (int l = p.levels - 2; l >= 1; --l) {
    Image& fv = *p.val[l];
    const Image& fwt = *p.wgt[l];
    const Image& cv = *p.val[l + 1];
    const int fw = fv.width(), fh = fv.height();
    const int nb = (fw + kBlock - 1) / kBlock;
    core::parallel_for(
        fh,
        [&](int y0, int y1) {
          // One cache of horizontally up-sampled coarse rows per column block (up_block's values):
          // a coarse row serves four fine rows, and is up-sampled once per task instead of four
          // times. Default-initialised buffers (only the keys are set).
          std::unique_ptr<HCache[]> cache(new HCache[nb]);
          for (int y = y0; y < y1; ++y) {
            const float* wr = fwt.row(0, y);
            for (int x0 = 0; x0 < fw; x0 += kBlock) {
              const int n = std::min(kBlock, fw - x0);
              if (!kern::any_below_one(wr + x0, n)) continue;
              HCache& hc = cache[x0 / kBlock];
              if (hc.img != &cv) hc.reset(&cv, 2, x0);
              const float* const* top;
              const float* const* bot;
              float ty;
              hc.rows(y, n, top, bot, ty);  // the vertical lerp of up_block, inside the push
              push_rows4_simd(wr + x0, top[0], bot[0], ty, n, fv.row(0, y) + x0, fv.plane_size());
            }
          }
        },
        8);
  }
}

void push_pull_fill_fast(Image& layer, const std::uint8_t* hole, bool opaque, bool under, Workspace& ws) {
  const int w = layer.width(), h = layer.height();
  const Pyramid pyr = make_pyramid(ws, w, h);
  const int levels = pyr.levels;
  auto finish = [opaque, under](float* const* d, int j, float* v) { finish_fill(opaque, under, d, j, v); };
  if (levels == 1) {  // 1×1: no pyramid, the fill is the pixel itself
    if (hole[0]) {
      float* d[4];
      for (int k = 0; k < 4; ++k) d[k] = layer.plane(k);
      float v[4];
      for (int k = 0; k < 4; ++k) v[k] = d[k][0];
      finish(d, 0, v);
    }
    return;
  }
  pull_level(
      layer, [&](int fx, int fy) { return hole[static_cast<std::size_t>(fy) * w + fx] ? 0.0f : 1.0f; }, *pyr.val[1],
      *pyr.wgt[1]);
  pull_push_upper(pyr);
  // Level 0: the hole pixels (confidence 0) take the up-sampled level 1, then the opaque /
  // under rules of inpaint.cpp, written straight into the layer.
  const Image& cv = *pyr.val[1];
  const int cw = cv.width(), ch = cv.height();
  core::parallel_for(
      h,
      [&](int y0, int y1) {
        float up[4][kBlock];
        for (int y = y0; y < y1; ++y) {
          const std::uint8_t* hr = hole + static_cast<std::size_t>(y) * w;
          for (int x0 = 0; x0 < w; x0 += kBlock) {
            const int n = std::min(kBlock, w - x0);
            if (!kern::any_byte(hr + x0, n)) continue;
            for (int k = 0; k < 4; ++k) up_block(cv.plane(k), cw, ch, y, x0, n, up[k]);
            float* d[4];
            for (int k = 0; k < 4; ++k) d[k] = layer.row(k, y) + x0;
            for (int j = 0; j < n; ++j) {
              if (!hr[x0 + j]) continue;
              const float wt = 0.0f;
              float v[4];
              for (int k = 0; k < 4; ++k) v[k] = wt * d[k][j] + (1.0f - wt) * up[k][j];
              finish(d, j, v);
            }
          }
        }
      },
      4);
}

}  // namespace dofkit::detail::layered
