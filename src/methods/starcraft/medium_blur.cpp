// C2 — the medium level: a full-resolution Gaussian in which every tap is weighted by that
// tap's blur level c (rule 1: a sharp pixel, c = 0, adds nothing to a blurry neighbour).
// As a normalised convolution: medium = G * (c·rgba) / G * c. The Gaussian is the
// extended-box cascade of core/filters, O(1) per pixel for any σ.
#include <algorithm>
#include <cmath>
#include <vector>

#include <tbb/task_arena.h>

#include "core/filters.hpp"
#include "core/weighted_gaussian.hpp"
#include "core/parallel.hpp"
#include "methods/starcraft/final_simd.hpp"
#include "methods/starcraft/starcraft.hpp"

namespace dofkit::detail::starcraft {

void medium_blur(const Image& color, const Image& level, float sigma, int boxes, Image& medium, Image& weight,
                 bool plain, const Image* large) {
  const int w = color.width(), h = color.height();
  medium.resize(w, h, 4);
  weight.resize(w, h, 1);
  // Where the weight vanishes no tap was blurry: the level is unused there (its weight in
  // the final mix is 0 unless the pixel's own c > 0.5, and then its own tap counts), so any
  // finite value will do; the source keeps the result free of 0/0.
  constexpr float kTiny = 1e-6f;
  if (!plain) {
    // Fast: the multiply rides on the horizontal strip load (core/weighted_gaussian), one read
    // and write per plane and axis; the same arithmetic as the plain steps below with the fast
    // Gaussian, bit for bit. The sums come before the division so that those of the pixels
    // with a small weight can be made exact first (kExactMediumBelow), as in medium_and_final.
    const float* src[4] = {color.plane(0), color.plane(1), color.plane(2), color.plane(3)};
    float* dst[4] = {medium.plane(0), medium.plane(1), medium.plane(2), medium.plane(3)};
    core::weighted_gaussian(src, 4, level.plane(0), w, h, sigma, boxes, kTiny, dst, weight.plane(0), false);
    const int lw = large ? large->width() : 0, lh = large ? large->height() : 0;
    // The larger of the blurred level's four bilinear cells around the pixel (quarter_bilerp's
    // footprint in final.cpp), which bounds the up-sampled blurred level from above.
    auto cells_max = [&](int x, int y) {
      const int x0 = static_cast<int>(std::floor((x + 0.5f) / kDown - 0.5f));
      const int y0 = static_cast<int>(std::floor((y + 0.5f) / kDown - 0.5f));
      float m = 0.0f;
      for (int yy : {y0, y0 + 1})
        for (int xx : {x0, x0 + 1})
          m = std::max(m, large->row(4, std::clamp(yy, 0, lh - 1))[std::clamp(xx, 0, lw - 1)]);
      return m;
    };
    const MediumExact exact{src, 4, level.plane(0), w, h, sigma, boxes};
    core::parallel_for(
        h,
        [&](int y0, int y1) {
          for (int y = y0; y < y1; ++y) {
            float* wt = weight.row(0, y);
            const float* c = level.row(0, y);
            for (int x = 0; large && x < w; ++x) {
              // The final pass mixes the medium level in where its level is in (0.5, 1): its own
              // level or the blurred one (<= cells_max up to rounding; 0.49 leaves room for it).
              if (!(wt[x] < kExactMediumBelow) || !(c[x] > 0.5f || cells_max(x, y) > 0.49f)) continue;
              double sums[5];
              core::weighted_gaussian_at(exact.src, 4, exact.c, w, h, sigma, boxes, x, y, sums);
              for (int ch = 0; ch < 4; ++ch) medium.row(ch, y)[x] = static_cast<float>(sums[ch]);
              wt[x] = static_cast<float>(sums[4]);
            }
            // The division as the final mix makes it (medium_and_final): the same values.
            for (int ch = 0; ch < 4; ++ch) {
              const float* s = color.row(ch, y);
              float* d = medium.row(ch, y);
              for (int x = 0; x < w; ++x) d[x] = wt[x] > kTiny ? d[x] / wt[x] : s[x];
            }
          }
        },
        16);
    return;
  }
  std::copy(level.data().begin(), level.data().end(), weight.data().begin());
  core::parallel_for(
      h,
      [&](int y0, int y1) {
        for (int y = y0; y < y1; ++y) {
          const float* c = level.row(0, y);
          for (int ch = 0; ch < 4; ++ch) {
            const float* s = color.row(ch, y);
            float* d = medium.row(ch, y);
            for (int x = 0; x < w; ++x) d[x] = c[x] * s[x];
          }
        }
      },
      16);
  for (int ch = 0; ch < 4; ++ch) core::gaussian_blur_plane_plain(medium.plane(ch), w, h, sigma, sigma, boxes);
  core::gaussian_blur_plane_plain(weight.plane(0), w, h, sigma, sigma, boxes);
  core::parallel_for(
      h,
      [&](int y0, int y1) {
        for (int y = y0; y < y1; ++y) {
          const float* wt = weight.row(0, y);
          for (int ch = 0; ch < 4; ++ch) {
            const float* s = color.row(ch, y);
            float* d = medium.row(ch, y);
            for (int x = 0; x < w; ++x) d[x] = wt[x] > kTiny ? d[x] / wt[x] : s[x];
          }
        }
      },
      16);
}

void medium_and_final(const Image& color, const Image& depth, const Image& level, float sigma_medium, int boxes,
                      bool opaque, const Image& large, const Image& inv_depth, bool keep_own_blur, Image& out) {
  const int w = color.width(), h = color.height();
  out.resize(w, h, 4);
  const float* src[4] = {color.plane(0), color.plane(1), color.plane(2), color.plane(3)};
  // Where alpha is 1 everywhere, c·alpha = c exactly, so the alpha plane's blur is the
  // weight's blur bit for bit, and its normalised value is 1 (w / w = 1 exactly, or the
  // source's 1 where no tap carried weight): the alpha plane is left out of the passes and
  // the weight row stands in for its numerator. One of the five planes of the most
  // expensive level (`opaque` comes from the large level's reduction, which reads the alpha
  // plane anyway).
  const int nplanes = opaque ? 3 : 4;
  // One horizontal band per worker: each band re-computes rows above it to warm its vertical
  // passes up (the output does not depend on the banding), so more bands than workers would
  // only add that overhead. Cuts sit on multiples of 32 rows (the passes' re-synchronisation
  // rows, so the last pass needs no warm-up) and are moved down by about half a band's warm-up
  // (~ boxes × (r + 1) + 32 rows, r ≈ σ·sqrt(3 / boxes)) so that the bands below the first one, which pay
  // for it, get fewer rows of their own.
  const int bands = std::max(1, std::min(tbb::this_task_arena::max_concurrency(), h / 64));
  const int warm = static_cast<int>(boxes * (sigma_medium * std::sqrt(3.0f / boxes) + 1.0f) + 32.0f);
  auto cut = [&](int b) {
    if (b == 0) return 0;
    if (b == bands) return h;
    const int y = static_cast<int>(static_cast<long long>(h) * b / bands) + warm / 2;
    return std::min(h, y - y % 32);
  };
  const MediumExact exact{src, nplanes, level.plane(0), w, h, sigma_medium, boxes};
  const FinalPassViews views{color,  depth, level, large, inv_depth, keep_own_blur, out, new_final_pass_id(),
                             &exact, opaque};
  core::parallel_for(bands, [&](int b0, int b1) {
    for (int b = b0; b < b1; ++b) {
      const int y0 = cut(b), y1 = cut(b + 1);
      // The rows come before the division, which the final mix makes for the pixels it mixes
      // (with medium_blur's threshold 1e-6 and source fallback, so the same values).
      core::weighted_gaussian_rows(
          src, nplanes, level.plane(0), w, h, sigma_medium, boxes, 0.0f, y0, y1,
          [&](int y, const float* const* rows) {
            const float* wt = rows[nplanes];
            const float* med[4] = {rows[0], rows[1], rows[2], nplanes == 4 ? rows[3] : wt};
            final_pass_row(views, med, y, wt);
          },
          false);
      flush_streams();  // the mix's non-temporal stores are globally visible before the task ends
    }
  });
}

}  // namespace dofkit::detail::starcraft
