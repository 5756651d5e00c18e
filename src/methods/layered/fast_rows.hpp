// The row-block machinery every fast pass of the layered method shares: rows are processed in
// blocks of kBlock columns (stack buffers); a reduced (half- or quarter-resolution) image is
// read back at full resolution by the 2× / 4× bilinear up-sampling computed on the fly (up_h,
// up_block, HCache), exactly what core::sample_bilinear computes (the oracle: composite.cpp's
// up-sampling, and inpaint.cpp's push); ZeroMap marks where a reduced accumulator is +0 so
// readers can skip it; AccRows reads an accumulator's rows whichever resolution it holds;
// Matte is LayerPlan::weight with the plan's numbers hoisted (anchors.cpp, the oracle).
#pragma once
#include <algorithm>
#include <cstddef>
#include <cstdint>

#include "core/filters.hpp"
#include "methods/layered/anchors.hpp"
#include "methods/layered/fast.hpp"
#include "methods/layered/fast_kernels.hpp"
#include "methods/layered/fused_simd.hpp"

namespace dofkit::detail::layered {

constexpr int kBlock = 256;  // columns per block of the row passes (stack buffers)

// ---------------------------------------------------------------------------------------
// 2× bilinear up-sampling (composite.cpp's half-resolution blur and inpaint.cpp's push).
// Fine pixel centre x + 0.5 lies at (x + 0.5)/2 in coarse units, so with the coarse sample
// i at i + 0.5: fine x = 2i sits a quarter-pixel *before* coarse i (between i − 1 and i, weight
// 0.75 on i) and x = 2i + 1 a quarter after it (between i and i + 1, weight 0.25 on i + 1),
// indices clamped to the edge. These are exactly the footprints core::bilinear_footprint
// computes ((x + 0.5)·0.5 − 0.5 and its fraction are exact in float), and the lerps below
// are core::sample_bilinear's, in its order (horizontal, then vertical), so the result is
// bit-identical to one sample_bilinear call per pixel.

// dst[j] = horizontal lerp of coarse row src (cw samples) at fine column x0 + j.
inline void up_h(const float* src, int cw, int x0, int n, float* dst, bool exact = false) {
  auto one = [&](int x) {
    const int i = x >> 1;
    int a, b;
    float t;
    if (x & 1) {
      a = i;
      b = i + 1 < cw ? i + 1 : cw - 1;
      t = 0.25f;
    } else {
      a = i > 0 ? i - 1 : 0;
      b = i;
      t = 0.75f;
    }
    return src[a] + (src[b] - src[a]) * t;
  };
  // Interior pairs (x = 2i, 2i + 1 with 1 <= i <= cw − 2) need no clamp: a branch-free loop
  // the compiler vectorises; the few edge columns take the general form.
  const int x1 = x0 + n;
  int x = x0;
  for (; x < x1 && (x < 2 || (x & 1)); ++x) dst[x - x0] = one(x);
  const int i_end = std::min((x1 >> 1), cw - 1);  // pairs with 2i + 1 < x1 and i + 1 <= cw − 1
  int i = x >> 1;
  if (i < i_end) {
    if (exact)
      up_pairs_exact_simd(src, i, i_end, dst + (x - x0));
    else
      kern::up_pairs(src, i, i_end, dst + (x - x0));
    i = i_end;
  }
  for (x = 2 * i; x < x1; ++x) dst[x - x0] = one(x);
}

// The same for 4× (composite.cpp reduce_and_blur); x0 is a multiple of 4.
inline void up_h4(const float* src, int cw, int x0, int n, float* dst, bool exact = false) {
  auto one = [&](int x) {
    const int i = x >> 2, q = x & 3;
    int a, b;
    float t;
    if (q < 2) {
      a = i > 0 ? i - 1 : 0;
      b = i;
      t = q == 0 ? 0.625f : 0.875f;
    } else {
      a = i;
      b = i + 1 < cw ? i + 1 : cw - 1;
      t = q == 2 ? 0.125f : 0.375f;
    }
    return src[a] + (src[b] - src[a]) * t;
  };
  const int x1 = x0 + n;
  int x = x0;
  for (; x < x1 && (x < 4 || (x & 3)); ++x) dst[x - x0] = one(x);
  const int i_end = std::min(x1 >> 2, cw - 1);  // quads with 4i + 3 < x1 and i + 1 <= cw − 1
  int i = x >> 2;
  if (i < i_end) {
    if (exact)
      up_quads_exact_simd(src, i, i_end, dst + (x - x0));
    else
      kern::up_quads(src, i, i_end, dst + (x - x0));
    i = i_end;
  }
  for (x = std::max(x, 4 * i); x < x1; ++x) dst[x - x0] = one(x);
}

// Vertical footprint of fine row y on a coarse axis of ch rows (factor 2 or 4).
struct RowFoot {
  const float* a;
  const float* b;
  float t;
};
inline RowFoot row_foot(const float* plane, int cw, int ch, int y, int factor) {
  int ya, yb;
  float ty;
  core::bilinear_footprint((y + 0.5f) * (factor == 4 ? 0.25f : 0.5f), ch, ya, yb, ty);
  return {plane + static_cast<std::size_t>(ya) * cw, plane + static_cast<std::size_t>(yb) * cw, ty};
}

// dst[j] = the 2× (or 4×) up-sampling of `plane` (cw × ch) at fine (x0 + j, y).
inline void up_block(const float* plane, int cw, int ch, int y, int x0, int n, float* dst, int factor = 2) {
  const RowFoot f = row_foot(plane, cw, ch, y, factor);
  float top[kBlock], bot[kBlock];
  if (factor == 4) {
    up_h4(f.a, cw, x0, n, top);
    up_h4(f.b, cw, x0, n, bot);
  } else {
    up_h(f.a, cw, x0, n, top);
    up_h(f.b, cw, x0, n, bot);
  }
  kern::lerp_rows(top, bot, f.t, n, dst);
}

// Where a reduced accumulator is exactly +0 (all bits clear), per coarse row and fine column
// block of kBlock pixels: nz[cy · nb + b] = 0 if every channel of coarse row cy is +0 over the
// coarse columns the 2× / 4× up-sampling of fine columns [b·kBlock, b·kBlock + n) reads,
// [x0/f − 1, (x0 + n − 1)/f + 1] (clamped). The up-sampling of such samples is exactly +0 —
// each lerp is +0 + (+0 − +0)·t with t >= 0 finite — so a reader may take rows of +0 instead
// of computing them, and a composite of an empty layer over them is +0 (the same bits).
// The near accumulator F is +0 wherever nothing near lies within its blur's support (the
// core Gaussian's running sums are recomputed from scratch every 32 samples, so they return
// to +0 there); the map is measured from the data, so nothing here relies on that.
struct ZeroMap {
  const std::uint8_t* nz = nullptr;
  int nb = 0, ch = 0, factor = 2;
  // True if fine rows [y_first, y_last] of block x0 read only +0 samples.
  bool zero(int y_first, int y_last, int x0) const { return !nz ? false : max_code(y_first, y_last, x0) == 0; }
  // True if they read a tiny sample (0 < |x| < 2^-96, any_tiny): subnormals, or close to
  // them. The kernels that multiply such rows then multiply through double (the same bits,
  // without the float multiply's ~20× microcode assist on subnormal operands or results).
  // build_zero_map marks such samples only where core::exact_tiny_multiplies() holds, so
  // elsewhere this is always false and every kernel takes the float multiplies.
  bool tiny(int y_first, int y_last, int x0) const { return nz && max_code(y_first, y_last, x0) == 2; }
  // The largest nz code (0 +0, 1 non-zero, 2 with a tiny sample where the exact multiplies are
  // taken) of the coarse rows read.
  int max_code(int y_first, int y_last, int x0) const {
    const float scale = factor == 4 ? 0.25f : 0.5f;
    int ya, yb, yc, yd;
    float t;
    core::bilinear_footprint((y_first + 0.5f) * scale, ch, ya, yb, t);
    core::bilinear_footprint((y_last + 0.5f) * scale, ch, yc, yd, t);
    int m = 0;
    for (int cy = std::min(ya, yb); cy <= std::max(yc, yd); ++cy) m = std::max(m, code(cy, x0));
    return m;
  }
  // The nz code of coarse row cy for the block that starts at fine column x0.
  int code(int cy, int x0) const { return nz[static_cast<std::size_t>(cy) * nb + x0 / kBlock]; }
};

// Horizontally up-sampled coarse rows of one column block, kept while the rows of a band are
// produced (a coarse row serves up to four fine rows): same values as up_block computes.
struct HCache {
  const Image* img = nullptr;
  int x0 = -1, factor = 2;
  int key[4] = {-1, -1, -1, -1};
  int next = 0;
  float v[4][4][kBlock];
  // The ZeroMap of img (optional): rows whose code is 2 (tiny samples) are up-sampled with the
  // exact multiplies (up_*_exact_simd).
  const ZeroMap* zm = nullptr;
  void reset(const Image* im, int fac, int bx0, const ZeroMap* z = nullptr) {
    img = im;
    factor = fac;
    x0 = bx0;
    zm = z;
    key[0] = key[1] = key[2] = key[3] = -1;
    next = 0;
  }
  // The 4 channels of coarse row cy, fine columns [x0, x0 + n).
  float (*row(int cy, int n))[kBlock] {
    for (int i = 0; i < 4; ++i)
      if (key[i] == cy) return v[i];
    const int i = next;
    next = (next + 1) & 3;
    key[i] = cy;
    const int cw = img->width();
    // The coarse columns up_h / up_h4 read, [x0/f − 1, (x0 + n − 1)/f + 1] (clamped).
    const int c0 = std::max(0, x0 / factor - 1), c1 = std::min(cw, (x0 + n - 1) / factor + 2);
    const bool exact = zm && zm->code(cy, x0) == 2;
    for (int c = 0; c < 4; ++c) {
      const float* src = img->row(c, cy);
      if (factor == 4)
        up_h4(src, cw, x0, n, v[i][c], exact);
      else
        up_h(src, cw, x0, n, v[i][c], exact);
      // The same columns of the coarse row this block's next band up-samples in this row's
      // place (a band of 4 fine rows advances 4 / factor coarse rows): the band's other
      // blocks run in between, which is long, and these 256–512-byte runs of a plane are too
      // short for the hardware prefetchers to find by themselves (up_pairs / up_quads waited
      // on their loads).
      const int ahead = 4 / factor;
      if (cy + ahead < img->height())
        for (int x = c0; x < c1; x += 16) __builtin_prefetch(src + static_cast<std::size_t>(ahead) * cw + x);
    }
    return v[i];
  }
  // The two cached coarse rows and the vertical weight of fine row y (what get interpolates).
  void rows(int y, int n, const float* const*& a, const float* const*& b, float& ty) {
    int ya, yb;
    core::bilinear_footprint((y + 0.5f) * (factor == 4 ? 0.25f : 0.5f), img->height(), ya, yb, ty);
    float(*ra)[kBlock] = row(ya, n);
    float(*rb)[kBlock] = row(yb, n);
    for (int c = 0; c < 4; ++c) {
      pa[c] = ra[c];
      pb[c] = rb[c];
    }
    a = pa;
    b = pb;
  }
  const float* pa[4];
  const float* pb[4];
  // The 2× / 4× up-sampling of all channels at fine row y (up_block's result); with
  // plus_zero, +0 + that (see lerp_rows4). Written only at columns [lo, hi) of the n
  // (the cached horizontal rows still cover all n).
  void get(int y, int n, float (*dst)[kBlock], bool plus_zero = false) { get(y, n, 0, n, dst, plus_zero); }
  void get(int y, int n, int lo, int hi, float (*dst)[kBlock], bool plus_zero = false) {
    int ya, yb;
    float ty;
    core::bilinear_footprint((y + 0.5f) * (factor == 4 ? 0.25f : 0.5f), img->height(), ya, yb, ty);
    float(*a)[kBlock] = row(ya, n);
    float(*b)[kBlock] = row(yb, n);
    kern::lerp_rows4(a[0], b[0], ty, lo, hi, plus_zero, dst[0]);
  }
};

// LayerPlan::weight(k, ·) with the plan's numbers hoisted out of the pixel loop; same
// comparisons and the same double arithmetic, so the same float result.
struct Matte {
  bool first, last;
  double a_prev, a_k, a_next, band;
  Matte(const LayerPlan& p, int k)
      : first(k == 0),
        last(k == p.count - 1),
        a_prev(k > 0 ? p.anchor[k - 1] : 0.0),
        a_k(p.anchor[k]),
        a_next(k + 1 < p.count ? p.anchor[k + 1] : 0.0),
        band(p.band) {}
  // The banded ramp of anchors.cpp (same double arithmetic).
  static double banded(double u, double band) {
    if (band <= 0) return u >= 0.5 ? 1.0 : 0.0;
    const double v = (u - 0.5) / band + 0.5;
    return v <= 0 ? 0.0 : (v >= 1 ? 1.0 : v);
  }
  float operator()(float r) const {
    if (!first && r > a_k) {
      const double u = (r - a_k) / (a_prev - a_k);
      if (u > 1) return 0.0f;
      return banded(u, band) < 1.0 ? 1.0f : 0.0f;
    }
    if (r >= a_k || last) return 1.0f;
    const double u = (r - a_next) / (a_k - a_next);
    if (u <= 0) return 0.0f;
    return static_cast<float>(banded(u, band));
  }
};

// Measures the ZeroMap of `img` (reduced by `factor` from a fine width fw) into nz (ch · nb
// bytes; fast_rows.cpp).
ZeroMap build_zero_map(const Image& img, int factor, int fw, std::uint8_t* nz);

// kBlock floats of +0: the rows of an accumulator that a ZeroMap shows to be +0.
// Four rows, so that they have the row caches' layout (channel c at + c·kRowStride, which
// the fused kernels rely on: fused_simd.hpp).
static_assert(kBlock == kRowStride);
alignas(64) inline const float kZero4[4][kBlock] = {};
inline const float* const kZeroRow = kZero4[0];
inline const float* const kZeroRows[4] = {kZero4[0], kZero4[1], kZero4[2], kZero4[3]};

// A read-only view of an accumulator's content by row blocks: the full image, or the
// up-sampling of its half-resolution image computed on the fly.
struct AccRows {
  const Image* full = nullptr;
  const Image* half = nullptr;  // reduced by `factor` (2 or 4)
  int factor = 2;
  const ZeroMap* zm = nullptr;  // where `half` is +0 (optional)
  AccRows(const Image* f, const Image* hf, int fac, const ZeroMap* z = nullptr)
      : full(f), half(hf), factor(fac), zm(hf ? z : nullptr) {}
  // True if the rows [y_first, y_last] of block x0 are known to be +0.
  bool zero(int y_first, int y_last, int x0) const { return zm && zm->zero(y_first, y_last, x0); }
  // True if they read tiny samples (ZeroMap::tiny).
  bool tiny(int y_first, int y_last, int x0) const { return zm && zm->tiny(y_first, y_last, x0); }
  explicit AccRows(const FastAccumulator& a) {
    if (!a.has_content()) return;
    if (a.half_pending()) {
      half = &a.half();
      factor = a.factor();
    } else {
      full = &a.full();
    }
  }
  bool present() const { return full || half; }
  // Pointers to the 4 channels of row y, columns [x0, x0 + n); `buf` receives up-sampled rows.
  void get(int y, int x0, int n, float (*buf)[kBlock], const float* p[4], HCache* cache = nullptr) const {
    if (full) {
      for (int c = 0; c < 4; ++c) p[c] = full->row(c, y) + x0;
    } else if (cache) {
      if (cache->img != half || cache->x0 != x0) cache->reset(half, factor, x0, zm);
      cache->get(y, n, buf);
      for (int c = 0; c < 4; ++c) p[c] = buf[c];
    } else {
      for (int c = 0; c < 4; ++c) {
        up_block(half->plane(c), half->width(), half->height(), y, x0, n, buf[c], factor);
        p[c] = buf[c];
      }
    }
  }
};

}  // namespace dofkit::detail::layered
