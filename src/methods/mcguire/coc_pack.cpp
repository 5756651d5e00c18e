// P1 of the McGuire method (docs/methods/mcguire.md): colour and signed CoC packed into one buffer.
//
// The signed radius r (px, near > 0) is normalised by R_max: s = clamp(r / R_max, −1, 1).
// Because r decreases monotonically with depth, one value per pixel tells field (sign),
// blur radius (|s|·R_max) and depth order (larger s = nearer) — all the blur passes need.
// The GPU original stores s·0.5 + 0.5 in an 8-bit alpha channel; we keep s as float, which
// removes the R_max/127.5 px quantisation and nothing else.
//
// Focus field: a pixel with |r| <= focus_px (default 0.5, S0's definition of "in focus")
// packs as s = 0, i.e. exactly sharp. The shader code ramps from r = 0, so a pixel at
// r = 0.4 would otherwise be lerped 0.4/R_max of the way to the blurry buffer.
#include <algorithm>
#include <cmath>

#include "core/parallel.hpp"
#include "methods/mcguire/mcguire.hpp"

namespace dofkit::detail::mcguire {

void pack_coc(const Image& colour, const Image& coc, const Rect& src, const Constants& k, Image& packed) {
  packed.resize(src.w, src.h, kPacked);
  const float inv_rmax = k.r_max > 0 ? 1.0f / static_cast<float>(k.r_max) : 0.0f;
  core::parallel_for(
      src.h,
      [&](int y0, int y1) {
        for (int y = y0; y < y1; ++y) {
          for (int c = 0; c < 4; ++c) std::copy_n(colour.row(c, src.y + y) + src.x, src.w, packed.row(c, y));
          const float* r = coc.row(0, src.y + y) + src.x;
          float* s = packed.row(4, y);
          for (int x = 0; x < src.w; ++x)
            s[x] = std::fabs(r[x]) <= k.focus_px ? 0.0f : std::clamp(r[x] * inv_rmax, -1.0f, 1.0f);
        }
      },
      8);
}

}  // namespace dofkit::detail::mcguire
