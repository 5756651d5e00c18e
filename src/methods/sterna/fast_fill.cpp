// Fast P8: the 3×3 max fill as branch-free row loops (same maxima, same order as fill.cpp).
//
// fill.cpp visits active tiles and tests nearBlur_h > 0 / far_h > 0 per texel. An inactive
// tile has both factors 0 at every texel (that is what inactive means), so the per-texel
// select alone reproduces it: texel = (factor > 0) ? max of the 3×3 window : texel. The loop
// body is then the same for every texel and vectorises; interior columns read x − 1 … x + 1
// directly and only the two border columns clamp.
//
// There is no separate fill pass over the frame: the composite asks for the filled
// rows it needs (fill_rows) just before it reads them, into a per-thread two-row buffer, so the
// 8 filled planes (16 MB at 1080p) are never written to memory and read back.
#include <algorithm>
#include <cstdint>
#include <cstring>

#include "core/parallel.hpp"
#include "methods/sterna/fast.hpp"
#include "methods/sterna/v8.hpp"

namespace dofkit::detail::sterna::fast {

namespace {

struct Rows {
  const float* r[3];  // rows y − 1, y, y + 1 (clamped)
};

__attribute__((always_inline)) inline float max9(const Rows& R, int xm, int x, int xp) {
  float m = R.r[1][x];
  for (int j = 0; j < 3; ++j) {
    m = std::max(m, R.r[j][xm]);
    m = std::max(m, R.r[j][x]);
    m = std::max(m, R.r[j][xp]);
  }
  return m;
}

// std::max(m, v) lane by lane: (m < v) ? v : m.
__attribute__((always_inline)) inline V8 vmax(V8 m, V8 v) { return m < v ? v : m; }

// max9's maximum for texels x … x + 7 (interior columns), from their centre values c: the
// centre first, then the rows in order.
__attribute__((always_inline)) inline V8 max9v(const Rows& R, int x, V8 c) {
  V8 m = c;
  for (int j = 0; j < 3; ++j) {
    m = vmax(m, load8(R.r[j] + x - 1));
    m = vmax(m, load8(R.r[j] + x));
    m = vmax(m, load8(R.r[j] + x + 1));
  }
  return m;
}

STERNA_SIMD void fill_row(const Rows& R, const float* __restrict factor, float* __restrict out, int w) {
  auto one = [&](int xm, int x, int xp) { out[x] = factor[x] > 0.0f ? max9(R, xm, x, xp) : R.r[1][x]; };
  if (w == 1) {
    one(0, 0, 0);
    return;
  }
  one(0, 0, 1);
  // Interior; a vector with no texel to fill is a copy. 32 texels at a time first, with one
  // branch for the four masks together (fewer mispredicted branches than one per vector).
  const V8 zero = V8{0, 0, 0, 0, 0, 0, 0, 0};
  int x = 1;
  for (; x + 32 <= w - 1; x += 32) {
    I8 on[4];
    for (int k = 0; k < 4; ++k) on[k] = load8(factor + x + 8 * k) > zero;
    if (!any((on[0] | on[1]) | (on[2] | on[3]))) {
      for (int k = 0; k < 4; ++k) store8(out + x + 8 * k, load8(R.r[1] + x + 8 * k));
      continue;
    }
    for (int k = 0; k < 4; ++k) {
      const V8 c = load8(R.r[1] + x + 8 * k);
      store8(out + x + 8 * k, on[k] ? max9v(R, x + 8 * k, c) : c);
    }
  }
  for (; x + 8 <= w - 1; x += 8) {
    const I8 on = load8(factor + x) > zero;
    const V8 c = load8(R.r[1] + x);
    if (!any(on)) {
      store8(out + x, c);
      continue;
    }
    store8(out + x, on ? max9v(R, x, c) : c);
  }
  for (; x < w - 1; ++x) out[x] = factor[x] > 0.0f ? max9(R, x - 1, x, x + 1) : R.r[1][x];
  one(w - 2, w - 1, w - 1);
}

// per_pixel_scale: fill.cpp's far fill, which takes a neighbour only if its kernel radius
// differs from the texel's by at most one texel, |far_n − far_p|·radius_per_far <= 1 (same
// maxima in the same order; scalar — this option's gather costs far more).
void fill_row_similar(const Rows& R, const Rows& F, float* __restrict out, int w, float radius_per_far) {
  const float* fr = F.r[1];
  for (int x = 0; x < w; ++x) {
    if (!(fr[x] > 0.0f)) {
      out[x] = R.r[1][x];
      continue;
    }
    const int xs[3] = {std::max(x - 1, 0), x, std::min(x + 1, w - 1)};
    float m = R.r[1][x];
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b)
        if (std::abs(F.r[a][xs[b]] - fr[x]) * radius_per_far <= 1.0f) m = std::max(m, R.r[a][xs[b]]);
    out[x] = m;
  }
}

}  // namespace

void fill_rows(const Settings& s, const Buffers& b, int y, float* const* near_out, float* const* far_out) {
  const int w = b.w, h = b.h;
  const int ys[3] = {std::max(y - 1, 0), y, std::min(y + 1, h - 1)};
  const Rows far_h{{b.far_h_row(ys[0]), b.far_h_row(ys[1]), b.far_h_row(ys[2])}};
  for (int c = 0; c < 4; ++c) {
    Rows rn{{b.dof_near->row(c, ys[0]), b.dof_near->row(c, ys[1]), b.dof_near->row(c, ys[2])}};
    fill_row(rn, b.near_blur->row(0, y), near_out[c], w);
    Rows rf{{b.dof_far->row(c, ys[0]), b.dof_far->row(c, ys[1]), b.dof_far->row(c, ys[2])}};
    if (s.per_pixel_scale)
      fill_row_similar(rf, far_h, far_out[c], w, kOuterRadius * s.kernel_scale);
    else
      fill_row(rf, b.far_h_row(y), far_out[c], w);
  }
}

}  // namespace dofkit::detail::sterna::fast
