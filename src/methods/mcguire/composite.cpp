// P4 of the McGuire method (docs/methods/mcguire.md): full-resolution composite.
//
//   out = lerp(sharp, blurry, |s|) · (1 − α_near) + near      (near premultiplied, "over")
//
// s is the packed normalised CoC of the pixel. Far pixels: the lerp fades from the sharp
// input to the blurry buffer as the radius grows (farRescale makes |s| reach 1 at the
// largest far radius rather than at R_max). Near pixels: s > 0.1 is stretched by 1.5 so the
// sharp image disappears quickly under a near object; the near buffer then goes "over".
// The coverage boost raises the near α (book/demo; g3d boosted it in the vertical pass).
//
// The low-resolution buffers are sampled bilinearly. Their texel i holds the value of full-
// resolution pixel f·i (point decimation picks the left/top pixel of each group), so texel
// coordinate t = x / f puts the sample exactly where the data came from; a centred lookup
// ((x + 0.5)/f − 0.5) would shift the blurry image by (f − 1)/2 px (lowres_offset_fix=off).
#include <algorithm>
#include <cmath>
#include <vector>

#include "core/parallel.hpp"
#include "methods/mcguire/blur_weights.hpp"
#include "methods/mcguire/mcguire.hpp"

namespace dofkit::detail::mcguire {

namespace {
struct Tap2 {
  int i0, i1;
  float w1;  // weight of i1; i0 gets 1 − w1
};
std::vector<Tap2> bilinear_taps(int n_out, int n_low, int f, bool fix) {
  std::vector<Tap2> taps(n_out);
  for (int x = 0; x < n_out; ++x) {
    const double t = fix ? static_cast<double>(x) / f : (x + 0.5) / f - 0.5;
    const double fl = std::floor(t);
    const int i = static_cast<int>(fl);
    taps[x] = {std::clamp(i, 0, n_low - 1), std::clamp(i + 1, 0, n_low - 1), static_cast<float>(t - fl)};
  }
  return taps;
}
}  // namespace

void composite(const Image& packed, int ox, int oy, const Image& blur, const Image& near, const Constants& k,
               const Rect& inner, Image& out, Image* weights) {
  const std::vector<Tap2> tx = bilinear_taps(inner.w, blur.width(), k.f, k.lowres_offset_fix);
  const std::vector<Tap2> ty = bilinear_taps(inner.h, blur.height(), k.f, k.lowres_offset_fix);
  if (weights) weights->resize(inner.w, inner.h, 4);
  core::parallel_for(
      inner.h,
      [&](int y0, int y1) {
        for (int y = y0; y < y1; ++y) {
          const Tap2 vy = ty[y];
          for (int x = 0; x < inner.w; ++x) {
            const Tap2 vx = tx[x];
            auto lerp2 = [&](const Image& img, int c) {
              const float top = img.at(vx.i0, vy.i0, c) + (img.at(vx.i1, vy.i0, c) - img.at(vx.i0, vy.i0, c)) * vx.w1;
              const float bot = img.at(vx.i0, vy.i1, c) + (img.at(vx.i1, vy.i1, c) - img.at(vx.i0, vy.i1, c)) * vx.w1;
              return top + (bot - top) * vy.w1;
            };
            float n[5];
            for (int c = 0; c < 5; ++c) n[c] = lerp2(near, c);
            float s = packed.at(ox + x, oy + y, 4);
            if (s < 0) s = std::max(s * k.far_rescale, -1.0f);
            float blur_amount;
            if (k.variant == Variant::g3d) {
              // The blurry buffer already holds a per-pixel radius (its Gaussian follows |r_B|), so
              // it replaces the sharp image as soon as the far radius is R_max/12.
              blur_amount = saturate(-12.0f * s);
            } else {
              if (k.double_coc) s = std::clamp(2.0f * s, -1.0f, 1.0f);
              if (k.coverage_boost != 1.0f) {
                // a'/α with α > 0 is min(boost, 1/α); the shader's max(α, 0.001) guard against a
                // division by zero would break the colour/alpha ratio for α < 0.001.
                const float a = saturate(k.coverage_boost * n[4]);
                const float g = n[4] > 0 ? a / n[4] : 0.0f;
                for (int c = 0; c < 4; ++c) n[c] *= g;
                n[4] = a;
              }
              if (s > 0.1f) s = std::min(1.5f * s, 1.0f);
              blur_amount = std::fabs(s);
            }
            const float keep = 1.0f - n[4];
            for (int c = 0; c < 4; ++c) {
              const float sharp = packed.at(ox + x, oy + y, c);
              float v = sharp + (lerp2(blur, c) - sharp) * blur_amount;
              if (k.variant == Variant::g3d) v = std::max(v, 0.0f);
              out.at(inner.x + x, inner.y + y, c) = v * keep + n[c];
            }
            if (weights) {
              weights->at(x, y, 0) = n[4];
              weights->at(x, y, 1) = keep * blur_amount;
              weights->at(x, y, 2) = keep * (1.0f - blur_amount);
              weights->at(x, y, 3) = 1.0f;
            }
          }
        }
      },
      4);
}

}  // namespace dofkit::detail::mcguire
