// Push-pull level 1 (and 2) of a fused layer, pulled from the codes and the colour instead of
// a stored layer (oracle: inpaint.cpp's pull_level over the matted layer; tests/layered).
// Inputs: a FusedLayer; outputs: the pyramid's level-1 values and confidences (cv, cwt) and,
// optionally, level 2. The push back down is fast_push_pull.cpp's pull_push_upper.
#include <algorithm>

#include "core/parallel.hpp"
#include "methods/layered/fast_push_pull.hpp"
#include "methods/layered/fused_layer.hpp"

namespace dofkit::detail::layered {

void pull_row(const FusedLayer& L, int yc, Image& cv, Image& cwt, float (*r)[4][kBlock], std::uint8_t (*hb)[kBlock],
              bool skip_hole_values) {
  const int w = L.w, h = L.h;
  const int rows = 2 * yc + 1 < h ? 2 : 1;
  for (int x0 = 0; x0 < w; x0 += kBlock) {
    const int n = std::min(kBlock, w - x0);
    int xc = x0 / 2;
    if (rows == 2) {  // full 2×2 blocks
      float* cvp[4];
      for (int k = 0; k < 4; ++k) cvp[k] = cv.row(k, yc) + xc;
      const int m = n / 2;
      const FusedLayer::Cls c0 = L.cls(2 * yc, x0), c1 = L.cls(2 * yc + 1, x0);
      if (c0 == c1 && c0 != FusedLayer::kGeneral && 2 * m == n) {
        // Four known zeros: value 0 / 4 = 0, confidence 1; four holes: 0 and 0.
        if (!(skip_hole_values && c0 == FusedLayer::kEmptyHole)) kern::fill_rows(cvp, 4, m, 0.0f);
        float* cwp = cwt.row(0, yc) + xc;
        kern::fill_rows(&cwp, 1, m, c0 == FusedLayer::kEmptyKnown ? 1.0f : 0.0f);
        continue;
      }
      // Both rows are +0 outside the union [lo, hi) of their spans (FusedLayer::matte), and
      // the pairs [p0, p1) = [lo / 2, ⌈hi / 2⌉) cover it. pull_pairs reads the rows at fine
      // columns [2·p0, 2·p1) only, so with no odd last column (2m = n; else the scalar tail
      // below reads the block's last column) only those are completed with +0 outside each
      // row's own span.
      const bool exact = 2 * m == n;
      if (exact) {
        // One kernel from the codes and the colour (pull_pairs_simd): the same values as the
        // matte, the hole flags and pull_pairs below. The pairs [p0, p1) as below.
        const std::pair<int, int> sq[2] = {L.span(2 * yc, x0, n), L.span(2 * yc + 1, x0, n)};
        const int lo = std::min(sq[0].first, sq[1].first), hi = std::max(sq[0].second, sq[1].second);
        const int p0 = hi > lo ? std::min(lo / 2, m) : 0, p1 = hi > lo ? std::max(p0, std::min((hi + 1) / 2, m)) : 0;
        PullRows pr;
        for (int dy = 0; dy < 2; ++dy) {
          const std::size_t base = static_cast<std::size_t>(2 * yc + dy) * w + x0;
          pr.code[dy] = L.code + base;
          pr.w0[dy] = L.w0 + base;
          for (int ch = 0; ch < 4; ++ch) pr.in[dy][ch] = L.color->row(ch, 2 * yc + dy) + x0;
        }
        pr.k = L.k;
        pull_pairs_simd(pr, m, p0, p1, cvp, cwt.row(0, yc) + xc);
        continue;
      }
      const std::pair<int, int> sp[2] = {L.matte(2 * yc, x0, n, r[0], hb[0], !exact),
                                         L.matte(2 * yc + 1, x0, n, r[1], hb[1], !exact)};
      const int lo = std::min(sp[0].first, sp[1].first), hi = std::max(sp[0].second, sp[1].second);
      const int p0 = hi > lo ? std::min(lo / 2, m) : 0, p1 = hi > lo ? std::max(p0, std::min((hi + 1) / 2, m)) : 0;
      if (exact)
        for (int dy = 0; dy < 2; ++dy) {
          const int a = 2 * p0, e = 2 * p1;
          const int l = sp[dy].second > sp[dy].first ? std::clamp(sp[dy].first, a, e) : e;
          const int u = sp[dy].second > sp[dy].first ? std::clamp(sp[dy].second, l, e) : e;
          for (int ch = 0; ch < 4; ++ch) {
            std::fill(r[dy][ch] + a, r[dy][ch] + l, 0.0f);
            std::fill(r[dy][ch] + u, r[dy][ch] + e, 0.0f);
          }
        }
      kern::pull_pairs(r[0], r[1], hb[0], hb[1], m, p0, p1, cvp, cwt.row(0, yc) + xc);
      xc += m;
    } else {
      L.matte(2 * yc, x0, n, r[0], hb[0]);
    }
    for (; xc < (x0 + n + 1) / 2; ++xc) {
      double sw = 0, sv[4] = {0, 0, 0, 0};
      for (int dy = 0; dy < 2; ++dy)
        for (int dx = 0; dx < 2; ++dx) {
          const int fx = 2 * xc + dx, fy = 2 * yc + dy;
          if (fx >= w || fy >= h) continue;
          const float wt = hb[dy][fx - x0] ? 0.0f : 1.0f;
          if (wt <= 0) continue;
          sw += wt;
          for (int k = 0; k < 4; ++k) sv[k] += wt * r[dy][k][fx - x0];
        }
      cwt.row(0, yc)[xc] = static_cast<float>(std::min(1.0, sw / 4.0));
      for (int k = 0; k < 4; ++k) cv.row(k, yc)[xc] = sw > 0 ? static_cast<float>(sv[k] / sw) : 0.0f;
    }
  }
}

void pull_from_layer(const FusedLayer& L, Image& cv, Image& cwt, Image* cv2, Image* cwt2) {
  const int rows = cv2 ? cv2->height() : cv.height();
  core::parallel_for(
      rows,
      [&](int y0, int y1) {
        float r[2][4][kBlock];
        std::uint8_t hb[2][kBlock];
        for (int y = y0; y < y1; ++y) {
          if (!cv2) {
            pull_row(L, y, cv, cwt, r, hb);
            continue;
          }
          for (int yc = 2 * y; yc < std::min(2 * y + 2, cv.height()); ++yc) pull_row(L, yc, cv, cwt, r, hb, true);
          pull_upper_row(cv, cwt, *cv2, *cwt2, y);
        }
      },
      cv2 ? 2 : 4);
}

}  // namespace dofkit::detail::layered
