// P7 (docs/methods/sterna.md): the 49-tap gather of the near and far fields.
//
// For a half-res texel p with centre c:
//   near(p) = (1/49) Σ_k colour_h(c + s·o_k)                          if nearBlur_h(p) > 0
//           = colour_h(p)                                             otherwise
//   far(p)  = Σ_k colourFar_h(c + s·o_k) / Σ_k far_h(c + s·o_k)       if far_h(p) > 0
//           = 0                                                       otherwise
// with bilinear (clamp-to-edge) lookups, o_0 = 0 and s = kernel_scale. colourFar_h is colour
// × far, so the ratio is a far-weighted mean: in-focus texels (far = 0) contribute nothing
// and a texel half-way into the far ramp counts half — the renormalisation that stops dark
// halos (Sterna Listing 3.5). The centre term guarantees a non-zero denominator.
//
// CPU layout: the offsets are the same for every texel, so each tap's bilinear split
// (integer offset + 4 weights) is computed once per frame. The sources are copied into
// planes padded by the kernel reach (edge replicated), so a tap is 4 unclamped loads and the
// loops run taps-outermost over a whole row segment (vectorisable). Work is done only in
// 8×8 tiles where some nearBlur_h or far_h is > 0; the other tiles get the per-texel
// early-out values directly (near = colour_h, far = 0). Cost: 49 bilinear taps (196 loads)
// per field per texel in active tiles, none elsewhere.
//
// per_pixel_scale (§3.5, far field only): the offsets of texel p are scaled by
// s·far_h(p), so each texel needs its own bilinear split (scalar path).
#include <algorithm>
#include <cmath>
#include <vector>

#include "core/parallel.hpp"
#include "methods/sterna/passes.hpp"

namespace dofkit::detail::sterna {

namespace {

constexpr std::uint8_t kNearBit = 1, kFarBit = 2;

struct Tap {
  int dx, dy;                // integer part of the offset (texels)
  float w00, w10, w01, w11;  // bilinear weights of (dx,dy), (dx+1,dy), (dx,dy+1), (dx+1,dy+1)
};

Tap split(float ox, float oy) {
  // A lookup at c + o, where c = (i + ½, j + ½), lies between texels i + floor(ox) and the
  // next one with fraction ox − floor(ox) (texel centres are at integer + ½).
  const float fx0 = std::floor(ox), fy0 = std::floor(oy);
  const float fx = ox - fx0, fy = oy - fy0;
  return {static_cast<int>(fx0), static_cast<int>(fy0), (1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy};
}

// A set of planes copied with an edge-replicated border of `pad` texels.
struct Padded {
  int pad = 0, pw = 0, ph = 0;
  std::vector<std::vector<float>> planes;
  const float* row(int c, int y) const { return planes[c].data() + static_cast<std::size_t>(y + pad) * pw + pad; }
};

void make_padded(const std::vector<const float*>& src, int w, int h, int pad, Padded& out) {
  out.pad = pad;
  out.pw = w + 2 * pad;
  out.ph = h + 2 * pad;
  out.planes.assign(src.size(), std::vector<float>(static_cast<std::size_t>(out.pw) * out.ph));
  core::parallel_for(
      out.ph,
      [&](int y0, int y1) {
        for (int py = y0; py < y1; ++py) {
          const int y = clampi(py - pad, 0, h - 1);
          for (std::size_t c = 0; c < src.size(); ++c) {
            const float* s = src[c] + static_cast<std::size_t>(y) * w;
            float* d = out.planes[c].data() + static_cast<std::size_t>(py) * out.pw;
            for (int px = 0; px < pad; ++px) d[px] = s[0];
            std::copy(s, s + w, d + pad);
            for (int px = pad + w; px < out.pw; ++px) d[px] = s[w - 1];
          }
        }
      },
      16);
}

// acc[x] += Σ bilinear tap of plane rows over x in [0, n).
inline void accumulate(float* acc, const Padded& P, int c, int y, int x0, int n, const Tap& t) {
  const float* r0 = P.row(c, y + t.dy) + x0 + t.dx;
  const float* r1 = P.row(c, y + t.dy + 1) + x0 + t.dx;
  const float w00 = t.w00, w10 = t.w10, w01 = t.w01, w11 = t.w11;
  for (int x = 0; x < n; ++x) acc[x] += w00 * r0[x] + w10 * r0[x + 1] + w01 * r1[x] + w11 * r1[x + 1];
}

inline float bilinear(const Padded& P, int c, float x, float y) {
  // (x, y) in texel units of the unpadded image, centres at integer + ½; stays inside the pad.
  const float fx = x - 0.5f, fy = y - 0.5f;
  const float x0 = std::floor(fx), y0 = std::floor(fy);
  const float tx = fx - x0, ty = fy - y0;
  const float* r0 = P.row(c, static_cast<int>(y0)) + static_cast<int>(x0);
  const float* r1 = P.row(c, static_cast<int>(y0) + 1) + static_cast<int>(x0);
  return (1 - ty) * ((1 - tx) * r0[0] + tx * r0[1]) + ty * ((1 - tx) * r1[0] + tx * r1[1]);
}

}  // namespace

void gather(const Settings& s, HalfRes& h) {
  const int w = h.w, hh = h.h;
  h.tiles_x = (w + kTile - 1) / kTile;
  h.tiles_y = (hh + kTile - 1) / kTile;
  h.tile_active.assign(static_cast<std::size_t>(h.tiles_x) * h.tiles_y, 0);
  // Tile classification.
  core::parallel_for(h.tiles_y, [&](int t0, int t1) {
    for (int ty = t0; ty < t1; ++ty)
      for (int y = ty * kTile; y < std::min(hh, (ty + 1) * kTile); ++y) {
        const float* nb = h.near_blur.row(0, y);
        const float* fr = h.coc.row(1, y);
        for (int x = 0; x < w; ++x) {
          std::uint8_t bits = (nb[x] > 0.0f ? kNearBit : 0) | (fr[x] > 0.0f ? kFarBit : 0);
          h.tile_active[static_cast<std::size_t>(ty) * h.tiles_x + x / kTile] |= bits;
        }
      }
  });

  const std::vector<Offset>& off = s.offsets;
  const float ks = s.kernel_scale;
  float reach = 0.0f;
  for (const Offset& o : off) reach = std::max(reach, std::max(std::abs(o.x), std::abs(o.y)) * ks);
  const int pad = static_cast<int>(std::ceil(reach)) + 2;
  Padded near_src, far_src;
  make_padded({h.color.plane(0), h.color.plane(1), h.color.plane(2), h.color.plane(3)}, w, hh, pad, near_src);
  make_padded({h.color_far.plane(0), h.color_far.plane(1), h.color_far.plane(2), h.color_far.plane(3), h.coc.plane(1)},
              w, hh, pad, far_src);
  std::vector<Tap> taps;
  for (const Offset& o : off) taps.push_back(split(o.x * ks, o.y * ks));
  const float inv_taps = 1.0f / static_cast<float>(off.size());

  h.dof_near.resize(w, hh, 4);
  h.dof_far.resize(w, hh, 4);
  core::parallel_for(
      hh,
      [&](int y0, int y1) {
        std::vector<float> acc(static_cast<std::size_t>(9) * w);
        for (int y = y0; y < y1; ++y) {
          const std::uint8_t* tiles = h.tile_active.data() + static_cast<std::size_t>(y / kTile) * h.tiles_x;
          const float* nb = h.near_blur.row(0, y);
          const float* fr = h.coc.row(1, y);
          // Early-out values everywhere first; active runs overwrite them.
          for (int c = 0; c < 4; ++c) {
            std::copy(h.color.row(c, y), h.color.row(c, y) + w, h.dof_near.row(c, y));
            std::fill(h.dof_far.row(c, y), h.dof_far.row(c, y) + w, 0.0f);
          }
          for (int tx = 0; tx < h.tiles_x;) {
            if (!tiles[tx]) {
              ++tx;
              continue;
            }
            std::uint8_t bits = 0;
            int te = tx;
            while (te < h.tiles_x && tiles[te]) bits |= tiles[te++];
            const int x0 = tx * kTile, x1 = std::min(w, te * kTile), n = x1 - x0;
            tx = te;
            if (bits & kNearBit) {
              float* a = acc.data();
              std::fill(a, a + 4 * n, 0.0f);
              for (const Tap& t : taps)
                for (int c = 0; c < 4; ++c) accumulate(a + c * n, near_src, c, y, x0, n, t);
              for (int x = 0; x < n; ++x)
                if (nb[x0 + x] > 0.0f)
                  for (int c = 0; c < 4; ++c) h.dof_near.row(c, y)[x0 + x] = a[c * n + x] * inv_taps;
            }
            if (!(bits & kFarBit)) continue;
            if (!s.per_pixel_scale) {
              float* a = acc.data() + 4 * w;
              std::fill(a, a + 5 * n, 0.0f);
              for (const Tap& t : taps)
                for (int c = 0; c < 5; ++c) accumulate(a + c * n, far_src, c, y, x0, n, t);
              for (int x = 0; x < n; ++x)
                if (fr[x0 + x] > 0.0f) {
                  const float inv = 1.0f / a[4 * n + x];
                  for (int c = 0; c < 4; ++c) h.dof_far.row(c, y)[x0 + x] = a[c * n + x] * inv;
                }
            } else {
              for (int x = x0; x < x1; ++x) {
                if (!(fr[x] > 0.0f)) continue;
                const float sc = ks * fr[x];
                const float cx = x + 0.5f, cy = y + 0.5f;
                float num[4] = {0, 0, 0, 0}, den = 0.0f;
                for (const Offset& o : off) {
                  const float px = cx + o.x * sc, py = cy + o.y * sc;
                  for (int c = 0; c < 4; ++c) num[c] += bilinear(far_src, c, px, py);
                  den += bilinear(far_src, 4, px, py);
                }
                for (int c = 0; c < 4; ++c) h.dof_far.row(c, y)[x] = num[c] / den;
              }
            }
          }
        }
      },
      4);
}

}  // namespace dofkit::detail::sterna
