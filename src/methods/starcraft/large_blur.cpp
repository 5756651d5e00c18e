// C3 — the large level and the blurred CoC, at W/4 × H/4 (5 planes).
// The chapter downsamples the source colour and the level c into one buffer (colour in RGB,
// c in alpha), blurs the colour with every tap weighted by its c and blurs c unweighted.
// As a normalised convolution both are one Gaussian: planes 0-3 hold G * (c·rgba), plane 4
// holds G * c. Plane 4 is at once the normaliser of the colour and the blurred CoC of rule 2
// ("blurry pixels make their neighbours blurry"); the final pass divides after up-sampling,
// so the weighting stays consistent between grid points.
//
// Reduction of each 4×4 block ([uncertain] in the chapter): the block's colour is the
// c-weighted mean of its pixels, so a sharp pixel inside a block adds nothing to the large
// level even before the blur; the block's level is the mean c (default) or the max c.
#include <algorithm>
#include <atomic>

#include "core/filters.hpp"
#include "core/parallel.hpp"
#include "methods/starcraft/final_simd.hpp"
#include "methods/starcraft/starcraft.hpp"
#include "render/sanitize.hpp"

namespace dofkit::detail::starcraft {

bool large_blur(const Image& color, const Image& level, float sigma_total, bool reduce_max, Image& large, bool plain,
                bool* alpha_is_one, bool check_colour) {
  const int w = color.width(), h = color.height();
  const int lw = down_size(w), lh = down_size(h);
  large.resize(lw, lh, 5);
  // One block in the plain form (double sums). The fast form uses it only for the partial
  // blocks at the right and bottom borders.
  // Whether every alpha is exactly 1, found while the colour is read anyway (see
  // medium_and_final). Each block row clears a shared flag: the same answer for any split.
  std::atomic<bool> opaque{true};
  // check_colour: every sample read also passes render()'s sanitation test (the frame has
  // not been checked; see MethodContext::colour_dirty). Each block row reads its own
  // samples, so together they read every sample of the image once.
  std::atomic<bool> sanitary{true};
  auto block = [&](int i, int j, bool& alpha_one, bool& clean) {
    double wsum[4] = {0, 0, 0, 0}, psum[4] = {0, 0, 0, 0}, csum = 0;
    float cmax = 0;
    int n = 0;
    for (int y = j * kDown; y < std::min(h, (j + 1) * kDown); ++y) {
      const float* c = level.row(0, y);
      for (int x = i * kDown; x < std::min(w, (i + 1) * kDown); ++x, ++n) {
        csum += c[x];
        cmax = std::max(cmax, c[x]);
        if (color.row(3, y)[x] != 1.0f) alpha_one = false;
        for (int ch = 0; ch < 4; ++ch) {
          const float v = color.row(ch, y)[x];
          if (check_colour) clean &= sample_is_sanitary(v, ch == 3);
          wsum[ch] += static_cast<double>(c[x]) * v;
          psum[ch] += v;
        }
      }
    }
    const double cb = reduce_max ? cmax : csum / n;
    for (int ch = 0; ch < 4; ++ch) {
      // c_block · (c-weighted block colour); with the mean reduction this is Σ c·rgba / n.
      const double col = csum > 0 ? wsum[ch] / csum : psum[ch] / n;
      large.row(ch, j)[i] = static_cast<float>(cb * col);
    }
    large.row(4, j)[i] = static_cast<float>(cb);
  };
  const int full_cols = w / kDown;  // blocks with all 4 columns inside the image
  core::parallel_for(
      lh,
      [&](int j0, int j1) {
        bool alpha_one = true, clean = true;
        for (int j = j0; j < j1; ++j) {
          int i = 0;
          if (!plain && (j + 1) * kDown <= h) {
            const float* rows[4][5];
            for (int k = 0; k < 4; ++k) {
              for (int ch = 0; ch < 4; ++ch) rows[k][ch] = color.row(ch, j * kDown + k);
              rows[k][4] = level.row(0, j * kDown + k);
            }
            float* const out[5] = {large.row(0, j), large.row(1, j), large.row(2, j), large.row(3, j), large.row(4, j)};
            i = large_reduce_simd(rows, reduce_max, out, 0, full_cols, alpha_one, check_colour ? &clean : nullptr);
          }
          for (; i < lw; ++i) block(i, j, alpha_one, clean);
        }
        if (!alpha_one) opaque.store(false, std::memory_order_relaxed);
        if (!clean) sanitary.store(false, std::memory_order_relaxed);
      },
      4);
  if (alpha_is_one) *alpha_is_one = opaque.load();
  if (!sanitary.load()) return false;  // the caller renders again from sanitised colour
  const float s = quarter_res_sigma(sigma_total);
  // Opaque frame (fast form): every block's alpha term is its level term — Σ c·1 sums the same
  // values in the same order as Σ c, so the c-weighted alpha is exactly 1 (or the mean of
  // ones, 1) and plane 3 = c_block · 1 = plane 4, bit for bit, in the vector and the scalar
  // reductions alike. Its blur is then plane 4's blur: blurred once and copied.
  const bool alpha_is_weight = !plain && opaque.load();
  for (int ch = 0; ch < 5; ++ch) {
    if (alpha_is_weight && ch == 3) continue;
    (plain ? core::gaussian_blur_plane_plain : core::gaussian_blur_plane)(large.plane(ch), lw, lh, s, s, 3);
  }
  if (alpha_is_weight) std::copy(large.plane(4), large.plane(4) + large.plane_size(), large.plane(3));
  return true;
}

}  // namespace dofkit::detail::starcraft
