// Fast P4 of the McGuire method (impl=fast): the arithmetic of composite() in the same
// order, organised by rows. The bilinear lookup there is top + (bot − top)·w_y with
// top/bot the horizontal lerps of two low-res rows; every output row between two low-res
// rows reuses the same two horizontally interpolated rows, so each chunk of output rows
// keeps them (9 channels: near 5 + blurry 4) and only redoes one when the low-res row
// changes. The per-pixel composite then runs over contiguous arrays with no branches that
// the compiler cannot turn into selects, so it vectorises.
#include <algorithm>
#include <cmath>

#include "core/parallel.hpp"
#include "methods/mcguire/blur_weights.hpp"
#include "methods/mcguire/fast.hpp"

namespace dofkit::detail::mcguire {

namespace {

// Bilinear taps of composite.cpp (texel coordinate x/f, or (x+0.5)/f − 0.5 without the fix).
void fill_taps(int n_out, int n_low, int f, bool fix, int* i0, int* i1, float* w1) {
  for (int x = 0; x < n_out; ++x) {
    const double t = fix ? static_cast<double>(x) / f : (x + 0.5) / f - 0.5;
    const double fl = std::floor(t);
    const int i = static_cast<int>(fl);
    i0[x] = std::clamp(i, 0, n_low - 1);
    i1[x] = std::clamp(i + 1, 0, n_low - 1);
    w1[x] = static_cast<float>(t - fl);
  }
}

// One low-res row (9 channels) interpolated to inner.w columns.
void h_interp(const Image& blur, const Image& near, int row, int w, const int* i0, const int* i1, const float* w1,
              float* dst) {
  for (int c = 0; c < 9; ++c) {
    const float* a = c < 5 ? near.row(c, row) : blur.row(c - 5, row);
    float* o = dst + static_cast<std::size_t>(c) * w;
    for (int x = 0; x < w; ++x) o[x] = a[i0[x]] + (a[i1[x]] - a[i0[x]]) * w1[x];
  }
}

template <bool G3D>
void composite_row(const float* __restrict top, const float* __restrict bot, float wy, int w, const float* col[4],
                   const float* __restrict sp, const Constants& k, float* out[4]) {
  const float far_rescale = k.far_rescale, boost = k.coverage_boost;
  const bool dbl = k.double_coc, do_boost = boost != 1.0f;
  const float* __restrict c0 = col[0];
  const float* __restrict c1 = col[1];
  const float* __restrict c2 = col[2];
  const float* __restrict c3 = col[3];
  float* __restrict o0 = out[0];
  float* __restrict o1 = out[1];
  float* __restrict o2 = out[2];
  float* __restrict o3 = out[3];
  auto L = [&](int c, int x) {
    const float t = top[static_cast<std::size_t>(c) * w + x];
    return t + (bot[static_cast<std::size_t>(c) * w + x] - t) * wy;
  };
  for (int x = 0; x < w; ++x) {
    float n0 = L(0, x), n1 = L(1, x), n2 = L(2, x), n3 = L(3, x), n4 = L(4, x);
    float s = sp[x];
    s = s < 0 ? std::max(s * far_rescale, -1.0f) : s;
    float ba;
    if constexpr (G3D) {
      ba = saturate(-12.0f * s);
    } else {
      if (dbl) s = std::clamp(2.0f * s, -1.0f, 1.0f);
      if (do_boost) {
        const float a = saturate(boost * n4);
        const float g = n4 > 0 ? a / n4 : 0.0f;
        n0 *= g;
        n1 *= g;
        n2 *= g;
        n3 *= g;
        n4 = a;
      }
      s = s > 0.1f ? std::min(1.5f * s, 1.0f) : s;
      ba = std::fabs(s);
    }
    const float keep = 1.0f - n4;
    float v0 = c0[x] + (L(5, x) - c0[x]) * ba;
    float v1 = c1[x] + (L(6, x) - c1[x]) * ba;
    float v2 = c2[x] + (L(7, x) - c2[x]) * ba;
    float v3 = c3[x] + (L(8, x) - c3[x]) * ba;
    if constexpr (G3D) {
      v0 = std::max(v0, 0.0f);
      v1 = std::max(v1, 0.0f);
      v2 = std::max(v2, 0.0f);
      v3 = std::max(v3, 0.0f);
    }
    o0[x] = v0 * keep + n0;
    o1[x] = v1 * keep + n1;
    o2[x] = v2 * keep + n2;
    o3[x] = v3 * keep + n3;
  }
}

}  // namespace

void composite_fast(const Image& packed, int ox, int oy, const Image& blur, const Image& near, const Constants& k,
                    const Rect& inner, Image& out, Workspace& ws) {
  const int w = inner.w, h = inner.h;
  Image& taps = ws.image("mcguire.fast.c_taps", std::max(w, h), 6, 1);
  int* tx0 = reinterpret_cast<int*>(taps.row(0, 0));
  int* tx1 = reinterpret_cast<int*>(taps.row(0, 1));
  int* ty0 = reinterpret_cast<int*>(taps.row(0, 3));
  int* ty1 = reinterpret_cast<int*>(taps.row(0, 4));
  float* wx = taps.row(0, 2);
  float* wyv = taps.row(0, 5);
  fill_taps(w, blur.width(), k.f, k.lowres_offset_fix, tx0, tx1, wx);
  fill_taps(h, blur.height(), k.f, k.lowres_offset_fix, ty0, ty1, wyv);
  const int nchunk = std::min(h, 64);
  Image& cache = ws.image("mcguire.fast.c_rows", 9 * w, 2 * nchunk, 1);
  core::parallel_for(nchunk, [&](int c0, int c1) {
    for (int chunk = c0; chunk < c1; ++chunk) {
      float* row_a = cache.row(0, 2 * chunk);
      float* row_b = cache.row(0, 2 * chunk + 1);
      int have_a = -1, have_b = -1;
      const int y0 = static_cast<int>(static_cast<long long>(h) * chunk / nchunk);
      const int y1 = static_cast<int>(static_cast<long long>(h) * (chunk + 1) / nchunk);
      for (int y = y0; y < y1; ++y) {
        const int r0 = ty0[y], r1 = ty1[y];
        // Keep whichever cached row is still needed; refill the other(s).
        if (have_a != r0 && have_b == r0) {
          std::swap(row_a, row_b);
          std::swap(have_a, have_b);
        }
        if (have_a != r0) {
          h_interp(blur, near, r0, w, tx0, tx1, wx, row_a);
          have_a = r0;
        }
        if (have_b != r1) {
          if (r1 == r0) {
            std::copy_n(row_a, 9 * static_cast<std::size_t>(w), row_b);
          } else {
            h_interp(blur, near, r1, w, tx0, tx1, wx, row_b);
          }
          have_b = r1;
        }
        const float* col[4];
        float* o[4];
        for (int c = 0; c < 4; ++c) {
          col[c] = packed.row(c, oy + y) + ox;
          o[c] = out.row(c, inner.y + y) + inner.x;
        }
        const float* sp = packed.row(4, oy + y) + ox;
        if (k.variant == Variant::g3d)
          composite_row<true>(row_a, row_b, wyv[y], w, col, sp, k, o);
        else
          composite_row<false>(row_a, row_b, wyv[y], w, col, sp, k, o);
      }
    }
  });
}

}  // namespace dofkit::detail::mcguire
