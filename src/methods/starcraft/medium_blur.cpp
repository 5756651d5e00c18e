// C2 — the medium level: a full-resolution Gaussian in which every tap is weighted by that
// tap's blur level c (rule 1: a sharp pixel, c = 0, adds nothing to a blurry neighbour).
// As a normalised convolution: medium = G * (c·rgba) / G * c. The Gaussian is the
// extended-box cascade of core/filters, O(1) per pixel for any σ.
#include <algorithm>
#include <vector>

#include "core/filters.hpp"
#include "core/parallel.hpp"
#include "methods/starcraft/final_simd.hpp"
#include "methods/starcraft/starcraft.hpp"

namespace dofkit::detail::starcraft {

void medium_blur(const Image& color, const Image& level, float sigma, Image& medium, Image& weight,
                 bool plain) {
  const int w = color.width(), h = color.height();
  medium.resize(w, h, 4);
  weight.resize(w, h, 1);
  // fast: the weight plane is filled row by row with the weighting (one pass over the rows
  // instead of a separate copy), the multiply and the normalisation below run in the SIMD
  // kernels of final_simd.cpp; same arithmetic, bit for bit.
  if (plain) std::copy(level.data().begin(), level.data().end(), weight.data().begin());
  core::parallel_for(h, [&](int y0, int y1) {
    for (int y = y0; y < y1; ++y) {
      const float* c = level.row(0, y);
      if (!plain) std::copy(c, c + w, weight.row(0, y));
      for (int ch = 0; ch < 4; ++ch) {
        const float* s = color.row(ch, y);
        float* d = medium.row(ch, y);
        for (int x = plain ? 0 : medium_weigh_simd(c, s, d, 0, w); x < w; ++x) d[x] = c[x] * s[x];
      }
    }
  }, 16);
  for (int ch = 0; ch < 4; ++ch) (plain ? core::gaussian_blur_plane_plain : core::gaussian_blur_plane)(medium.plane(ch), w, h, sigma, sigma, 3);
  (plain ? core::gaussian_blur_plane_plain : core::gaussian_blur_plane)(weight.plane(0), w, h, sigma, sigma, 3);
  // Where the weight vanishes no tap was blurry: the level is unused there (its weight in
  // the final mix is 0 unless the pixel's own c > 0.5, and then its own tap counts), so any
  // finite value will do; the source keeps the result free of 0/0.
  constexpr float kTiny = 1e-6f;
  core::parallel_for(h, [&](int y0, int y1) {
    for (int y = y0; y < y1; ++y) {
      const float* wt = weight.row(0, y);
      for (int ch = 0; ch < 4; ++ch) {
        const float* s = color.row(ch, y);
        float* d = medium.row(ch, y);
        for (int x = plain ? 0 : medium_normalise_simd(wt, s, d, 0, w); x < w; ++x)
          d[x] = wt[x] > kTiny ? d[x] / wt[x] : s[x];
      }
    }
  }, 16);
}

}  // namespace dofkit::detail::starcraft
