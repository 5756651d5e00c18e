// Definitions of the row kernels declared in fast_kernels.hpp.
#include "methods/layered/fast_kernels.hpp"

#include <algorithm>
#include <bit>
#include <cstring>

#include "core/clones.hpp"
#include "core/filters.hpp"

namespace dofkit::detail::layered {

// Hot row kernels, compiled for AVX-512 / AVX2 / baseline x86-64 and chosen at run time
// (DOFKIT_CLONES: without FMA contraction, so every target rounds like the plain form,
// bit-identical); no-trapping-math lets the compiler evaluate both sides of a select.
#define LAYERED_SIMD DOFKIT_CLONES DOFKIT_NO_TRAPPING_MATH

namespace kern {

// dst[j] = lerp(src[i−1], src[i], 0.75) for fine x = 2i and lerp(src[i], src[i+1], 0.25) for
// x = 2i + 1, for the pairs i in [i0, i1) (all neighbours in range); dst points at x = 2·i0.
LAYERED_SIMD void up_pairs(const float* __restrict src, int i0, int i1, float* __restrict dst) {
  const int m = i1 - i0;
  const float* s = src + i0;
  for (int i = 0; i < m; ++i) {
    const float lo = s[i - 1], mid = s[i], hi = s[i + 1];
    dst[2 * i] = lo + (mid - lo) * 0.75f;
    dst[2 * i + 1] = mid + (hi - mid) * 0.25f;
  }
}

// The 4× form: fine x = 4i + q sits at i + (q − 1.5)/4 in coarse units, so q = 0, 1 lerp
// (i − 1, i) with weights 0.625, 0.875 on i and q = 2, 3 lerp (i, i + 1) with 0.125, 0.375.
LAYERED_SIMD void up_quads(const float* __restrict src, int i0, int i1, float* __restrict dst) {
  const int m = i1 - i0;
  const float* s = src + i0;
  for (int i = 0; i < m; ++i) {
    const float lo = s[i - 1], mid = s[i], hi = s[i + 1];
    dst[4 * i] = lo + (mid - lo) * 0.625f;
    dst[4 * i + 1] = lo + (mid - lo) * 0.875f;
    dst[4 * i + 2] = mid + (hi - mid) * 0.125f;
    dst[4 * i + 3] = mid + (hi - mid) * 0.375f;
  }
}

// dst = top + (bot − top)·t.
LAYERED_SIMD void lerp_rows(const float* __restrict top, const float* __restrict bot, float t, int n,
                            float* __restrict dst) {
  for (int j = 0; j < n; ++j) dst[j] = top[j] + (bot[j] - top[j]) * t;
}

// lerp_rows of four channel rows kBlock floats apart (the row caches' layout), columns
// [lo, hi), in one call instead of four; with plus_zero dst = +0 + (top + (bot − top)·t):
// lerp_rows followed by fill_row's "+0 +" of an all-hole block.
LAYERED_SIMD void lerp_rows4(const float* __restrict top, const float* __restrict bot, float t, int lo, int hi,
                             bool plus_zero, float* __restrict dst) {
  for (int c = 0; c < 4; ++c) {
    const float* __restrict a = top + 256 * c;
    const float* __restrict b = bot + 256 * c;
    float* __restrict d = dst + 256 * c;
    if (plus_zero)
      for (int j = lo; j < hi; ++j) d[j] = 0.0f + (a[j] + (b[j] - a[j]) * t);
    else
      for (int j = lo; j < hi; ++j) d[j] = a[j] + (b[j] - a[j]) * t;
  }
}

// matting.cpp for one fragment per pixel from the per-pixel codes (see FusedLayer).
// Columns [lo, hi) of the block (the caller's span; the rest of o is left alone).
LAYERED_SIMD void matte_row(const std::uint16_t* __restrict code, const float* __restrict w0, const float* const* in,
                            int k, int lo, int hi, float (*o)[256]) {
  // w_k: w0 where j0 = k; 1 where j0 + 1 = k with the second-layer bit, i.e. where the low
  // six bits are (k − 1) | 32 (no code has those for k = 0); 0 elsewhere. Compared in 16 bits
  // and w0 loaded unconditionally, so it vectorises without masked loads.
  const std::uint16_t k0 = static_cast<std::uint16_t>(k);
  const std::uint16_t k1 = static_cast<std::uint16_t>(k >= 1 ? ((k - 1) | 32) : 0xffff);
  float wk[256];
  for (int j = lo; j < hi; ++j) {
    const std::uint16_t cd = code[j];
    const float wv = w0[j];
    const float second = (cd & 63) == k1 ? 1.0f : 0.0f;
    wk[j] = (cd & 31) == k0 ? wv : second;
  }
  // t = (1 − 0)·w_k = w_k exactly; acc = 0 + t·I where w_k > 0, else 0 (matting.cpp's order).
  const float* __restrict s0 = in[0];
  const float* __restrict s1 = in[1];
  const float* __restrict s2 = in[2];
  const float* __restrict s3 = in[3];
  float* __restrict d0 = o[0];
  float* __restrict d1 = o[1];
  float* __restrict d2 = o[2];
  float* __restrict d3 = o[3];
  for (int j = lo; j < hi; ++j) {
    const float t = (1.0f - 0.0f) * wk[j];
    // No select needed: w_k is exactly 0 where the pixel is not in layer k (else > 0), and the
    // colour is finite (render() sanitises it, or layered's own check in coc_extremes passed
    // before this pass), so 0 + 0·I = 0 + (±0) = +0, matting.cpp's value. The unconditional
    // form streams the rows with plain loads; the select made GCC emit masked loads
    // (vmaskmovps), ~20 % of this kernel's time.
    d0[j] = 0.0f + t * s0[j];
    d1[j] = 0.0f + t * s1[j];
    d2[j] = 0.0f + t * s2[j];
    d3[j] = 0.0f + t * s3[j];
  }
}

// The hole flags of layer k (a hole from layer hk = code >> 6 on), columns [lo, n).
LAYERED_SIMD void hole_row(const std::uint16_t* __restrict code, int k, int lo, int n, std::uint8_t* __restrict hb) {
  for (int j = lo; j < n; ++j) hb[j] = k >= (code[j] >> 6) ? 1 : 0;
}

// inpaint.cpp's level-0 fill (confidence 0: v = 0·v + 1·up) and final rules at hole pixels,
// columns [lo, n) of the block (the rest of o is left alone).
LAYERED_SIMD void fill_row(const std::uint8_t* __restrict hb, float (*up)[256], bool opaque, bool under, int lo, int n,
                           float (*o)[256]) {
  const float wt = 0.0f;
  if (!opaque && !under) {  // the common case: the fill replaces the hole pixel
    for (int c = 0; c < 4; ++c) {
      float* __restrict d = o[c];
      const float* __restrict u = up[c];
      for (int j = lo; j < n; ++j) {
        const float v = wt * d[j] + (1.0f - wt) * u[j];
        d[j] = hb[j] ? v : d[j];
      }
    }
    return;
  }
  for (int j = lo; j < n; ++j) {
    float v[4];
    for (int c = 0; c < 4; ++c) v[c] = wt * o[c][j] + (1.0f - wt) * up[c][j];
    const bool norm = opaque && v[3] > 1e-6f;
    const float a = v[3];
    for (int c = 0; c < 3; ++c) v[c] = norm ? v[c] / a : v[c];
    v[3] = norm ? 1.0f : v[3];
    const float t = 1.0f - o[3][j];
    for (int c = 0; c < 4; ++c) {
      const float r = under ? o[c][j] + t * v[c] : v[c];
      o[c][j] = hb[j] ? r : o[c][j];
    }
  }
}

// c = c + (1 − c.a)·a (layer in front) or c = a + (1 − a.a)·c.
LAYERED_SIMD void over_rows(float (*c)[256], const float* const* a, bool layer_in_front, int n) {
  if (layer_in_front) {
    for (int i = 0; i < n; ++i) {
      const float t = 1.0f - c[3][i];
      for (int ch = 0; ch < 4; ++ch) c[ch][i] = c[ch][i] + t * a[ch][i];
    }
  } else {
    for (int i = 0; i < n; ++i) {
      const float t = 1.0f - a[3][i];
      for (int ch = 0; ch < 4; ++ch) c[ch][i] = a[ch][i] + t * c[ch][i];
    }
  }
}

// 2×2 box: d[xh] = 0.25·(a[2xh] + a[2xh+1] + b[2xh] + b[2xh+1]) for xh in [0, m) (all in range).
LAYERED_SIMD void down_pairs(const float* __restrict a, const float* __restrict b, int m, float* __restrict d) {
  for (int xh = 0; xh < m; ++xh) d[xh] = 0.25f * (a[2 * xh] + a[2 * xh + 1] + b[2 * xh] + b[2 * xh + 1]);
}

// True if some x in [0, n) has 0 < |x| < 2^-96: subnormals, or values a few multiplies away
// from them (the accumulator's blur tails; see ZeroMap::tiny).
LAYERED_SIMD bool any_tiny(const float* __restrict p, int n) {
  const std::uint32_t lim = core::kTinyMagnitudeBits - 1u;
  std::uint32_t any = 0;
  for (int i = 0; i < n; ++i) {
    const std::uint32_t u = std::bit_cast<std::uint32_t>(p[i]) & 0x7fffffffu;
    any |= (u - 1u) < lim ? 1u : 0u;  // u = 0 wraps: not counted
  }
  return any != 0;
}

// Summary of one row block of the code pass (render_gaussian_fused): pres = the layers any
// pixel has a non-zero matte in, hk = smallest | largest hole start << 8, and into ne the
// layers with a non-zero matted alpha: layer j0 where 0 + (1 − 0)·w0·a > 0 (that is,
// w0·a > 0), layer j0 + 1 (weight 1) where 0 + 1·a > 0, always true for a coded pixel
// (a > 0). The no-layer code j0 = 31 only ever sets bit 31 (masked; layers are < 17) and
// never the second-layer bit.
//
// Also the same layer bits per 16-pixel chunk: cm[c] for pixels [16c, 16c + 16) ∩ [0, n),
// and the chunk's smallest hk in ch[c].
LAYERED_SIMD void code_summary(const std::uint16_t* __restrict code, const float* __restrict w0,
                               const float* __restrict a, int n, std::uint32_t* pres, std::uint32_t* hk,
                               std::uint32_t* ne, std::uint32_t* __restrict cm, std::uint32_t* __restrict ch) {
  std::uint32_t p = 0, e = 0, mn = 255, mx = 0;
  for (int j = 0; j < n; ++j) {
    const std::uint32_t cd = code[j], j0 = cd & 31u, hkc = cd >> 6;
    const std::uint32_t b0 = 1u << j0, b1 = ((cd >> 5) & 1u) << ((j0 + 1u) & 31u);
    p |= b0 | b1;
    e |= (w0[j] * a[j] > 0 ? b0 : 0u) | b1;
    mx = hkc > mx ? hkc : mx;
  }
  for (int c = 0; 16 * c < n; ++c) {
    std::uint32_t q = 0, m = 255;
    if (16 * c + 16 <= n) {
      for (int j = 16 * c; j < 16 * c + 16; ++j) {
        const std::uint32_t cd = code[j], j0 = cd & 31u, hkc = cd >> 6;
        q |= (1u << j0) | (((cd >> 5) & 1u) << ((j0 + 1u) & 31u));
        m = hkc < m ? hkc : m;
      }
    } else {
      for (int j = 16 * c; j < n; ++j) {
        const std::uint32_t cd = code[j], j0 = cd & 31u, hkc = cd >> 6;
        q |= (1u << j0) | (((cd >> 5) & 1u) << ((j0 + 1u) & 31u));
        m = hkc < m ? hkc : m;
      }
    }
    cm[c] = q;
    ch[c] = m;
    mn = m < mn ? m : mn;
  }
  *pres = p & 0x7fffffffu;
  *hk = mn | (mx << 8);
  *ne |= e & 0x7fffffffu;
}

// The push at one pyramid level: v ← w v + (1 − w) up where w < 1 (as a select, so it
// vectorises; a pixel with w >= 1 keeps its value), with up = top + (bot − top)·t, the
// vertical lerp of two horizontally up-sampled coarse rows (lerp_rows' expression) computed
// in the same loop instead of stored to a row buffer first.
//
// Where w = 0 (no confident child) the pull stored v = +0 (Σ w = 0 gives 0, every pull and
// shortcut), so w v + (1 − w) up = 0·(+0) + 1·up = +0 + up: that is what is written there,
// without v. The value does not depend on what v holds, so a pull may leave v unwritten where
// w = 0 if this push runs over the level (see pull_row's skip_hole_values).
//
// The push is push_rows4_simd (fused_simd.cpp): four channels per call, and per vector of
// pixels nothing where every w >= 1.

// The sum both pulls share, for one channel: the 2×2 children of coarse pixel x (masked
// fine rows z0, z1: a skipped child is +0) de-interleaved with plain strided copies, then
// summed in double in pull_level's order and divided by Σ w (0 where Σ w = 0).
//
// With rw non-null (every Σ w of the block 0 or a power of two, rw[x] = 1 / sw[x] exactly
// there, see pull_pairs_w), sv · rw[x] instead of sv / sw[x]: the same double, since both
// round the same exact value sv·2^−k, which is representable (sv, a sum of four floats
// weighted by confidences, is 0 or far above double's subnormal range).
LAYERED_SIMD void pull_sum(const float* __restrict z0, const float* __restrict z1, int m, const double* __restrict sw,
                           const double* __restrict rw, float* __restrict d) {
  float e0[128], o0[128], e1[128], o1[128];
  for (int x = 0; x < m; ++x) {
    e0[x] = z0[2 * x];
    o0[x] = z0[2 * x + 1];
    e1[x] = z1[2 * x];
    o1[x] = z1[2 * x + 1];
  }
  if (rw) {
    for (int x = 0; x < m; ++x) {
      double sv = 0;
      sv += static_cast<double>(e0[x]);
      sv += static_cast<double>(o0[x]);
      sv += static_cast<double>(e1[x]);
      sv += static_cast<double>(o1[x]);
      d[x] = sw[x] > 0 ? static_cast<float>(sv * rw[x]) : 0.0f;
    }
    return;
  }
  for (int x = 0; x < m; ++x) {
    double sv = 0;
    sv += static_cast<double>(e0[x]);
    sv += static_cast<double>(o0[x]);
    sv += static_cast<double>(e1[x]);
    sv += static_cast<double>(o1[x]);
    d[x] = sw[x] > 0 ? static_cast<float>(sv / sw[x]) : 0.0f;
  }
}

// Pull of level 1 from two level-0 rows for coarse pixels [0, m) whose 2×2 children all lie
// in the image: children (0,0), (1,0), (0,1), (1,1) in pull_level's order; a hole child is
// skipped there, here it adds +0 (exact: the sums start at +0 and never become −0).
// Values only for the pairs [c0, c1) (0 <= c0 <= c1 <= m), reading the rows only at fine
// columns [2·c0, 2·c1): the caller guarantees that the layer is +0 in both rows outside
// them, where the value is then +0, what the full computation gives (every child adds +0,
// +0 / Σ w = +0, or 0 where Σ w = 0). The confidences depend on the hole flags only and are
// computed for all m pairs.
LAYERED_SIMD void pull_pairs(float (*r0)[256], float (*r1)[256], const std::uint8_t* __restrict h0,
                             const std::uint8_t* __restrict h1, int m, int c0, int c1, float* const* cv,
                             float* __restrict cw) {
  // De-interleave the children into contiguous arrays, a hole child as +0 (float), then sum
  // in double in pull_level's order.
  double sw[128];
  // Σ w over the children is the count of non-hole children (0 … 4: exact in float too);
  // counted from contiguous 0 / 1 rows so the loops vectorise.
  float n0[256], n1[256];
  for (int j = 0; j < 2 * m; ++j) {
    n0[j] = h0[j] ? 0.0f : 1.0f;
    n1[j] = h1[j] ? 0.0f : 1.0f;
  }
  for (int x = 0; x < m; ++x) {
    const double s = static_cast<double>(n0[2 * x] + n0[2 * x + 1] + n1[2 * x] + n1[2 * x + 1]);
    sw[x] = s;
    cw[x] = static_cast<float>(s / 4.0 < 1.0 ? s / 4.0 : 1.0);  // std::min(1.0, s / 4.0)
  }
  // Mask the holes on the contiguous fine rows (a blend), then de-interleave with plain
  // strided copies: both vectorise, the masked strided form did not. (No std:: helpers in
  // these kernels: a different target attribute stops them from being inlined.)
  for (int c = 0; c < 4; ++c) {
    float* __restrict d = cv[c];
    for (int x = 0; x < c0; ++x) d[x] = 0.0f;
    for (int x = c1; x < m; ++x) d[x] = 0.0f;
    if (c1 <= c0) continue;
    const float* __restrict a = r0[c] + 2 * c0;
    const float* __restrict b = r1[c] + 2 * c0;
    const std::uint8_t* __restrict g0 = h0 + 2 * c0;
    const std::uint8_t* __restrict g1 = h1 + 2 * c0;
    float z0[256], z1[256];
    for (int j = 0; j < 2 * (c1 - c0); ++j) {
      z0[j] = g0[j] ? 0.0f : a[j];
      z1[j] = g1[j] ? 0.0f : b[j];
    }
    pull_sum(z0, z1, c1 - c0, sw + c0, nullptr, d + c0);
  }
}

// pull_level with confidences: coarse pixels [0, m) whose 2×2 children lie in the image; a
// child of confidence <= 0 is skipped there and adds +0 here.
LAYERED_SIMD void pull_pairs_w(const float* const* f0, const float* const* f1, const float* __restrict w0,
                               const float* __restrict w1, int m, float* const* cv, float* __restrict cw) {
  double sw[128];
  // The same skip-and-sum on contiguous rows first (masked weights and products: a child of
  // confidence <= 0 becomes +0, which adds exactly what skipping adds), then plain strided
  // de-interleaves: all of it vectorises.
  float m0[256], m1[256];
  for (int j = 0; j < 2 * m; ++j) {
    m0[j] = w0[j] > 0 ? w0[j] : 0.0f;
    m1[j] = w1[j] > 0 ? w1[j] : 0.0f;
  }
  for (int x = 0; x < m; ++x) {
    double s = 0;
    s += static_cast<double>(m0[2 * x]);
    s += static_cast<double>(m0[2 * x + 1]);
    s += static_cast<double>(m1[2 * x]);
    s += static_cast<double>(m1[2 * x + 1]);
    sw[x] = s;
    cw[x] = static_cast<float>(s / 4.0 < 1.0 ? s / 4.0 : 1.0);  // std::min(1.0, s / 4.0)
  }
  // If every Σ w is 0 or a power of two (a zero mantissa field: Σ w is a sum of confidences,
  // each at least 4^−l at level l, so never subnormal), its reciprocal is exact: the exponent negated,
  // bits(2^−e) = (2046 << 52) − bits(2^e) (meaningless where Σ w = 0, which pull_sum masks).
  // pull_sum then multiplies instead of dividing (one division per channel and pixel, the
  // bulk of the pull's time on AVX-512): inside a layer's region Σ w = 4 (all children
  // confident), and only blocks on a hole's border keep the division.
  double rw[128];
  std::uint64_t mant = 0;
  for (int x = 0; x < m; ++x) {
    std::uint64_t b;
    __builtin_memcpy(&b, &sw[x], 8);
    mant |= b & ((std::uint64_t{1} << 52) - 1);
    const std::uint64_t r = (std::uint64_t{2046} << 52) - b;
    __builtin_memcpy(&rw[x], &r, 8);
  }
  const double* rp = mant == 0 ? rw : nullptr;
  for (int c = 0; c < 4; ++c) {
    const float* __restrict a = f0[c];
    const float* __restrict b = f1[c];
    float z0[256], z1[256];
    for (int j = 0; j < 2 * m; ++j) {
      z0[j] = w0[j] > 0 ? w0[j] * a[j] : 0.0f;
      z1[j] = w1[j] > 0 ? w1[j] * b[j] : 0.0f;
    }
    pull_sum(z0, z1, m, sw, rp, cv[c]);
  }
}

// One channel of the final composite's last step: o = f + u·(c + t·b) with t = 1 − c.a and
// u = 1 − f.a, i.e. c over b, then f over that (final_composite's order); b or f may be null
// (no content: that step is skipped).
LAYERED_SIMD void final_channel(const float* __restrict c, const float* __restrict t, const float* __restrict b,
                                const float* __restrict u, const float* __restrict f, int n, float* __restrict o) {
  if (b && f) {
    for (int i = 0; i < n; ++i) o[i] = f[i] + u[i] * (c[i] + t[i] * b[i]);
  } else if (b) {
    for (int i = 0; i < n; ++i) o[i] = c[i] + t[i] * b[i];
  } else if (f) {
    for (int i = 0; i < n; ++i) o[i] = f[i] + u[i] * c[i];
  } else {
    for (int i = 0; i < n; ++i) o[i] = c[i];
  }
}

// t = 1 − a.
LAYERED_SIMD void one_minus(const float* __restrict a, int n, float* __restrict t) {
  for (int i = 0; i < n; ++i) t[i] = 1.0f - a[i];
}

// The code pass (render_gaussian_fused) for 16 pixels whose codes are all known: if every
// pixel is transparent (!(a > 0)) or has CoC bits `bits`, writes the codes (`cd` and weight
// wv, or the no-layer code and 0) and returns true; otherwise writes nothing.
LAYERED_SIMD bool code_run16(const float* __restrict a, const float* __restrict r, std::uint32_t bits, std::uint16_t cd,
                             float wv, std::uint16_t* __restrict code, float* __restrict w0) {
  int bad = 0;
  for (int j = 0; j < 16; ++j) {
    std::uint32_t b;
    __builtin_memcpy(&b, r + j, 4);
    bad |= (a[j] > 0) & (b != bits);
  }
  if (bad) return false;
  const std::uint16_t none = static_cast<std::uint16_t>(31u | (31u << 6));  // kNoLayer, hk 31
  for (int j = 0; j < 16; ++j) {
    const bool on = a[j] > 0;
    code[j] = on ? cd : none;
    w0[j] = on ? wv : 0.0f;
  }
  return true;
}

// True if any of b[0 … n) is non-zero (a hole flag), as an integer OR so it vectorises.
LAYERED_SIMD bool any_byte(const std::uint8_t* __restrict b, int n) {
  unsigned any = 0;
  for (int i = 0; i < n; ++i) any |= b[i];
  return any != 0;
}

// True if any of w[0 … n) is < 1 (a pixel the push changes).
LAYERED_SIMD bool any_below_one(const float* __restrict w, int n) {
  int any = 0;
  for (int i = 0; i < n; ++i) any |= w[i] < 1.0f;
  return any != 0;
}

// True if every w[0 … n) is exactly 1.
LAYERED_SIMD bool all_one(const float* __restrict w, int n) {
  int bad = 0;
  for (int i = 0; i < n; ++i) bad |= w[i] != 1.0f;
  return bad == 0;
}

// True if any of p[0 … n) has a bit set (anything but +0), as an integer OR so it vectorises.
LAYERED_SIMD bool any_bits(const float* __restrict p, int n) {
  std::uint32_t acc = 0;
  for (int i = 0; i < n; ++i) {
    std::uint32_t b;
    __builtin_memcpy(&b, p + i, 4);
    acc |= b;
  }
  return acc != 0;
}

// p[r][0 … n) = v for the rows r in [0, rows). The short constant fills of the shortcuts
// (a pull block of known zeros or holes, a +0 band block) are 64–128 floats: GCC expands
// std::fill of +0 there into `rep stos`, whose start-up (~40 cycles) costs more than the
// stores (perf: 44 % of pull_row's samples); a vector loop of the clone's width does not.
LAYERED_SIMD void fill_rows(float* const* p, int rows, int n, float v) {
  for (int r = 0; r < rows; ++r) {
    float* __restrict d = p[r];
    for (int j = 0; j < n; ++j) d[j] = v;
  }
}

}  // namespace kern

}  // namespace dofkit::detail::layered
