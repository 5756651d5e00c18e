// P2 (docs/methods/sterna.md): half-resolution colour, far-premultiplied colour and CoC.
//
// Half-res texel (i, j) covers the full-res quad (2i..2i+1, 2j..2j+1); on an odd-sized image
// the last column/row clamps to the edge (its quad repeats the edge pixel). Every quantity
// uses that same quad, top-left TL = (2i, 2j):
//  * coc_h = coc(TL), point-sampled: CoC is edge data and averaging would invent values that
//    exist on neither side of an edge, which the bilateral weights later rely on.
//  * colour_h = mean of the quad (feeds the near field, where bleeding is wanted).
//  * colourFar_h = bilateral mean with weights 1000 for TL and 1/(|far_k − far_TL| + 0.001)
//    otherwise — a quad that straddles a far/focus edge averages only the side TL is on —
//    then multiplied by far(TL). Premultiplying by the far factor *before* the gather's
//    bilinear taps is what keeps in-focus colour (far = 0) out of the far field (Sousa).
//  * Karis (firefly=karis): every sample's weight is further multiplied by 1/(1 + luma), and
//    the sum renormalised. A lone pixel of luma L ≫ 1 then contributes ~1/(1+L) of a normal
//    pixel's weight instead of L times its energy, so sub-pixel highlights that flicker from
//    frame to frame are suppressed while uniform regions keep their exact mean.
#include <algorithm>
#include <cmath>

#include "core/parallel.hpp"
#include "methods/sterna/passes.hpp"

namespace dofkit::detail::sterna {

void downsample(const Image& color, const FullCoc& full, const Settings& s, HalfRes& h) {
  const int W = color.width(), H = color.height();
  h.w = (W + 1) / 2;
  h.h = (H + 1) / 2;
  h.color.resize(h.w, h.h, 4);
  h.color_far.resize(h.w, h.h, 4);
  h.coc.resize(h.w, h.h, 2);
  const bool karis = s.karis;
  core::parallel_for(
      h.h,
      [&](int j0, int j1) {
        for (int j = j0; j < j1; ++j) {
          const int ys[2] = {2 * j, clampi(2 * j + 1, 0, H - 1)};
          for (int i = 0; i < h.w; ++i) {
            const int xs[2] = {2 * i, clampi(2 * i + 1, 0, W - 1)};
            float c[4][4], far[4], wk[4];
            for (int k = 0; k < 4; ++k) {
              const int x = xs[k & 1], y = ys[k >> 1];
              for (int ch = 0; ch < 4; ++ch) c[k][ch] = color.row(ch, y)[x];
              far[k] = full.coc.row(1, y)[x];
              wk[k] = karis ? 1.0f / (1.0f + std::max(0.0f, luma(c[k][0], c[k][1], c[k][2]))) : 1.0f;
            }
            // Plain (or Karis) mean.
            float wsum = 0.0f, acc[4] = {0, 0, 0, 0};
            for (int k = 0; k < 4; ++k) {
              wsum += wk[k];
              for (int ch = 0; ch < 4; ++ch) acc[ch] += wk[k] * c[k][ch];
            }
            for (int ch = 0; ch < 4; ++ch) h.color.row(ch, j)[i] = acc[ch] / wsum;
            // Far-bilateral mean, premultiplied by far(TL).
            float bsum = 0.0f, bacc[4] = {0, 0, 0, 0};
            for (int k = 0; k < 4; ++k) {
              const float wb = (k == 0 ? 1000.0f : 1.0f / (std::abs(far[k] - far[0]) + 0.001f)) * wk[k];
              bsum += wb;
              for (int ch = 0; ch < 4; ++ch) bacc[ch] += wb * c[k][ch];
            }
            for (int ch = 0; ch < 4; ++ch) h.color_far.row(ch, j)[i] = bacc[ch] / bsum * far[0];
            h.coc.row(0, j)[i] = full.coc.row(0, ys[0])[xs[0]];
            h.coc.row(1, j)[i] = far[0];
          }
        }
      },
      4);
}

}  // namespace dofkit::detail::sterna
