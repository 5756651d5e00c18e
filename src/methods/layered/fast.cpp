#include "methods/layered/fast.hpp"

#include <algorithm>
#include <atomic>
#include <bit>
#include <memory>
#include <optional>
#include <cmath>
#include <utility>

#include "core/clones.hpp"
#include "core/filters.hpp"
#include "core/parallel.hpp"
#include "core/pass_profile.hpp"
#include "core/row_scan.hpp"
#include "methods/layered/composite.hpp"
#include "methods/layered/fused_simd.hpp"
#include "methods/layered/inpaint.hpp"

namespace dofkit::detail::layered {

namespace {

constexpr int kBlock = 256;  // columns per block of the row passes (stack buffers)

}  // namespace

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

namespace {

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

// The banded ramp of anchors.cpp (same double arithmetic).
inline double banded(double u, double band) {
  if (band <= 0) return u >= 0.5 ? 1.0 : 0.0;
  const double v = (u - 0.5) / band + 0.5;
  return v <= 0 ? 0.0 : (v >= 1 ? 1.0 : v);
}

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

}  // namespace

// ---------------------------------------------------------------------------------------
MatteStats matte_layer_fast(const Fragments& frags, const LayerPlan& plan, int k, Image& layer, std::uint8_t* hole) {
  const int w = frags.width(), h = frags.height();
  layer.resize(w, h, 4);
  const int nf = static_cast<int>(frags.color.size());
  const double near_limit = plan.near_limit(k);
  const Matte matte(plan, k);
  // OR-reductions: the result does not depend on the order.
  std::atomic<bool> any_full{false}, any_hole{false};
  core::parallel_for(
      h,
      [&](int y0, int y1) {
        bool full = false, holes = false;
        for (int y = y0; y < y1; ++y) {
          float* out[4];
          for (int c = 0; c < 4; ++c) out[c] = layer.row(c, y);
          std::uint8_t* hr = hole ? hole + static_cast<std::size_t>(y) * w : nullptr;
          if (nf == 1) {
            // One fragment per pixel (RGB-D input): acc = 0 + (1 − 0)·w_k·I, as below.
            const float* in[4];
            for (int c = 0; c < 4; ++c) in[c] = frags.color[0]->row(c, y);
            const float* rr = frags.coc[0]->row(0, y);
            for (int x = 0; x < w; ++x) {
              const float a = in[3][x];
              float wk = 0.0f;
              std::uint8_t hv = 0;
              if (a > 0) {
                const float r = rr[x];
                wk = matte(r);
                hv = r > near_limit;
              }
              const float t = (1.0f - 0.0f) * wk;
              for (int c = 0; c < 4; ++c) out[c][x] = wk > 0 ? 0.0f + t * in[c][x] : 0.0f;
              full |= out[3][x] > 0;
              if (hr) {
                hr[x] = hv;
                holes |= hv != 0;
              }
            }
            continue;
          }
          for (int x = 0; x < w; ++x) {
            float acc[4] = {0, 0, 0, 0};
            std::uint8_t hv = 0;
            for (int f = 0; f < nf; ++f) {
              const Image& col = *frags.color[f];
              const float a = col.row(3, y)[x];
              if (!(a > 0)) continue;
              const float r = frags.coc[f]->row(0, y)[x];
              const float wk = matte(r);
              if (wk > 0) {
                const float t = (1.0f - acc[3]) * wk;
                for (int c = 0; c < 4; ++c) acc[c] += t * col.row(c, y)[x];
              }
              hv = r > near_limit;  // the farthest fragment decides (matting.cpp)
            }
            for (int c = 0; c < 4; ++c) out[c][x] = acc[c];
            full |= acc[3] > 0;
            if (hr) {
              hr[x] = hv;
              holes |= hv != 0;
            }
          }
        }
        if (full) any_full.store(true, std::memory_order_relaxed);
        if (holes) any_hole.store(true, std::memory_order_relaxed);
      },
      4);
  MatteStats s;
  s.empty = !any_full.load();
  s.holes = any_hole.load();
  return s;
}

// ---------------------------------------------------------------------------------------
namespace {

// The push-pull pyramid above level 0 (levels 1 … L, down to 1×1), from the workspace.
struct Pyramid {
  std::vector<Image*> val{nullptr}, wgt{nullptr};  // index 0 unused (level 0 = the layer)
  int levels = 1;                                  // including level 0
};
Pyramid make_pyramid(Workspace& ws, int w, int h, const std::string& prefix = "layered.pp") {
  Pyramid p;
  int cw = w, ch = h, l = 0;
  while (cw > 1 || ch > 1) {
    cw = (cw + 1) / 2;
    ch = (ch + 1) / 2;
    ++l;
    p.val.push_back(&ws.image(prefix + "v" + std::to_string(l), cw, ch, 4));
    p.wgt.push_back(&ws.image(prefix + "w" + std::to_string(l), cw, ch, 1));
  }
  p.levels = static_cast<int>(p.val.size());
  return p;
}

// Row y of pyramid level l + 1 (cv, cwt) pulled from level l (fine, fwt): pull_level's
// arithmetic, with the shortcuts below. Needs fine rows 2y and 2y + 1 (where it exists) only.
void pull_upper_row(const Image& fine, const Image& fwt, Image& cv, Image& cwt, int y) {
  const int fw = fine.width(), fh = fine.height(), cw = cv.width();
  int x = 0;
  if (2 * y + 1 < fh) {  // interior blocks of full 2×2 children, 128 at a time
    const int full = fw / 2;
    for (; x < full; x += 128) {
      const int m = std::min(128, full - x);
      const float* f0[4];
      const float* f1[4];
      float* o[4];
      for (int k = 0; k < 4; ++k) {
        f0[k] = fine.row(k, 2 * y) + 2 * x;
        f1[k] = fine.row(k, 2 * y + 1) + 2 * x;
        o[k] = cv.row(k, y) + x;
      }
      const float* wa = fwt.row(0, 2 * y) + 2 * x;
      const float* wb = fwt.row(0, 2 * y + 1) + 2 * x;
      const bool any = core::any_positive(wa, 2 * m) || core::any_positive(wb, 2 * m);  // a child the pull counts
      if (!any) {  // no child with confidence: Σ w = 0 gives value 0, confidence 0
        float* cwp = cwt.row(0, y) + x;
        kern::fill_rows(o, 4, m, 0.0f);
        kern::fill_rows(&cwp, 1, m, 0.0f);
        continue;
      }
      if (kern::all_one(wa, 2 * m) && kern::all_one(wb, 2 * m)) {
        bool zero = true;
        for (int k = 0; k < 4 && zero; ++k) zero = !kern::any_bits(f0[k], 2 * m) && !kern::any_bits(f1[k], 2 * m);
        if (zero) {
          // Four children of confidence 1 and value +0 (a region where the layer is known
          // to be empty): Σ w v = +0 + 1·(+0) + … = +0, Σ w = 4, so value +0 / 4 = +0 and
          // confidence min(1, 4/4) = 1, exactly what pull_pairs_w computes.
          float* cwp = cwt.row(0, y) + x;
          kern::fill_rows(o, 4, m, 0.0f);
          kern::fill_rows(&cwp, 1, m, 1.0f);
          continue;
        }
      }
      kern::pull_pairs_w(f0, f1, wa, wb, m, o, cwt.row(0, y) + x);
    }
    x = full;
  }
  for (; x < cw; ++x)  // the rest, one pixel at a time
    pull_pixel(
        fine, [&](int fx, int fy) { return fwt.row(0, fy)[fx]; }, x, y, cv, cwt);
}

// Pull of levels `first` … L (first >= 2) from the level below, then the push from the top
// down to level 1: v ← w v + (1 − w) up(v_{l+1}) where w < 1. With first = 3, level 2 has
// been pulled already, row by row, by the pass that wrote level 1 (pull_upper_row on level
// 1's rows while they were in cache): the same rows from the same inputs.
void pull_push_upper(const Pyramid& p, int first = 2) {
  for (int l = first; l < p.levels; ++l) {
    const Image& fine = *p.val[l - 1];
    const Image& fwt = *p.wgt[l - 1];
    Image& cv = *p.val[l];
    Image& cwt = *p.wgt[l];
    core::parallel_for(
        cv.height(),
        [&](int y0, int y1) {
          for (int y = y0; y < y1; ++y) pull_upper_row(fine, fwt, cv, cwt, y);
        },
        8);
  }
  for (int l = p.levels - 2; l >= 1; --l) {
    Image& fv = *p.val[l];
    const Image& fwt = *p.wgt[l];
    const Image& cv = *p.val[l + 1];
    const int fw = fv.width(), fh = fv.height();
    const int nb = (fw + kBlock - 1) / kBlock;
    core::parallel_for(
        fh,
        [&](int y0, int y1) {
          // One cache of horizontally up-sampled coarse rows per column block (up_block's values):
          // a coarse row serves four fine rows, and is up-sampled once per task instead of four
          // times. Default-initialised buffers (only the keys are set).
          std::unique_ptr<HCache[]> cache(new HCache[nb]);
          for (int y = y0; y < y1; ++y) {
            const float* wr = fwt.row(0, y);
            for (int x0 = 0; x0 < fw; x0 += kBlock) {
              const int n = std::min(kBlock, fw - x0);
              if (!kern::any_below_one(wr + x0, n)) continue;
              HCache& hc = cache[x0 / kBlock];
              if (hc.img != &cv) hc.reset(&cv, 2, x0);
              const float* const* top;
              const float* const* bot;
              float ty;
              hc.rows(y, n, top, bot, ty);  // the vertical lerp of up_block, inside the push
              push_rows4_simd(wr + x0, top[0], bot[0], ty, n, fv.row(0, y) + x0, fv.plane_size());
            }
          }
        },
        8);
  }
}

// inpaint.cpp's final rules for a hole pixel j of the layer rows d, fill value v.
inline void finish_fill(bool opaque, bool under, float* const* d, int j, float* v) {
  if (opaque && v[3] > 1e-6f) {
    for (int k = 0; k < 3; ++k) v[k] /= v[3];
    v[3] = 1.0f;
  }
  if (under) {
    const float t = 1.0f - d[3][j];
    for (int k = 0; k < 4; ++k) d[k][j] += t * v[k];
  } else {
    for (int k = 0; k < 4; ++k) d[k][j] = v[k];
  }
}

}  // namespace

void push_pull_fill_fast(Image& layer, const std::uint8_t* hole, bool opaque, bool under, Workspace& ws) {
  const int w = layer.width(), h = layer.height();
  const Pyramid pyr = make_pyramid(ws, w, h);
  const int levels = pyr.levels;
  auto finish = [opaque, under](float* const* d, int j, float* v) { finish_fill(opaque, under, d, j, v); };
  if (levels == 1) {  // 1×1: no pyramid, the fill is the pixel itself
    if (hole[0]) {
      float* d[4];
      for (int k = 0; k < 4; ++k) d[k] = layer.plane(k);
      float v[4];
      for (int k = 0; k < 4; ++k) v[k] = d[k][0];
      finish(d, 0, v);
    }
    return;
  }
  pull_level(
      layer, [&](int fx, int fy) { return hole[static_cast<std::size_t>(fy) * w + fx] ? 0.0f : 1.0f; }, *pyr.val[1],
      *pyr.wgt[1]);
  pull_push_upper(pyr);
  // Level 0: the hole pixels (confidence 0) take the up-sampled level 1, then the opaque /
  // under rules of inpaint.cpp, written straight into the layer.
  const Image& cv = *pyr.val[1];
  const int cw = cv.width(), ch = cv.height();
  core::parallel_for(
      h,
      [&](int y0, int y1) {
        float up[4][kBlock];
        for (int y = y0; y < y1; ++y) {
          const std::uint8_t* hr = hole + static_cast<std::size_t>(y) * w;
          for (int x0 = 0; x0 < w; x0 += kBlock) {
            const int n = std::min(kBlock, w - x0);
            if (!kern::any_byte(hr + x0, n)) continue;
            for (int k = 0; k < 4; ++k) up_block(cv.plane(k), cw, ch, y, x0, n, up[k]);
            float* d[4];
            for (int k = 0; k < 4; ++k) d[k] = layer.row(k, y) + x0;
            for (int j = 0; j < n; ++j) {
              if (!hr[x0 + j]) continue;
              const float wt = 0.0f;
              float v[4];
              for (int k = 0; k < 4; ++k) v[k] = wt * d[k][j] + (1.0f - wt) * up[k][j];
              finish(d, j, v);
            }
          }
        }
      },
      4);
}

// ---------------------------------------------------------------------------------------
namespace {

// Blocks build_zero_map has marked tiny (code 2), for the tests (tiny_block_count).
std::atomic<std::uint64_t> g_tiny_blocks{0};

// Measures the ZeroMap of `img` (reduced by `factor` from a fine width fw) into nz (ch · nb bytes).
ZeroMap build_zero_map(const Image& img, int factor, int fw, std::uint8_t* nz) {
  ZeroMap z;
  z.nz = nz;
  z.nb = (fw + kBlock - 1) / kBlock;
  z.ch = img.height();
  z.factor = factor;
  const int cw = img.width(), nb = z.nb;
  // Code 2 (tiny) only where the exact multiplies pay (core::exact_tiny_multiplies); elsewhere
  // such blocks are 1 and take the float kernels: the same bits.
  const bool exact = core::exact_tiny_multiplies();
  core::parallel_for(
      img.height(),
      [&](int y0, int y1) {
        std::uint64_t tiny_blocks = 0;
        for (int y = y0; y < y1; ++y)
          for (int b = 0; b < nb; ++b) {
            const int x0 = b * kBlock, n = std::min(kBlock, fw - x0);
            const int lo = std::max(0, x0 / factor - 1), hi = std::min(cw - 1, (x0 + n - 1) / factor + 1);
            bool any = false;
            for (int c = 0; c < 4 && !any; ++c) {
              const float* r = img.row(c, y);
              // A dense accumulator is settled by its first sample; a sparse one needs the scan.
              any = kern::any_bits(r + lo, 1) || kern::any_bits(r + lo, hi - lo + 1);
            }
            bool tiny = false;
            for (int c = 0; c < 4 && any && exact && !tiny; ++c) tiny = kern::any_tiny(img.row(c, y) + lo, hi - lo + 1);
            nz[static_cast<std::size_t>(y) * nb + b] = tiny ? 2 : (any ? 1 : 0);
            tiny_blocks += tiny ? 1 : 0;
          }
        if (tiny_blocks) g_tiny_blocks.fetch_add(tiny_blocks, std::memory_order_relaxed);
      },
      8);
  return z;
}

// kBlock floats of +0: the rows of an accumulator that a ZeroMap shows to be +0.
// Four rows, so that they have the row caches' layout (channel c at + c·kRowStride, which
// the fused kernels rely on: fused_simd.hpp).
static_assert(kBlock == kRowStride);
alignas(64) const float kZero4[4][kBlock] = {};
const float* const kZeroRow = kZero4[0];
const float* const kZeroRows[4] = {kZero4[0], kZero4[1], kZero4[2], kZero4[3]};

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

}  // namespace

void FastAccumulator::settle() {
  if (has_ && pending_var_ > 0) {
    const double sigma = std::sqrt(pending_var_);
    if (half_res_ && quarter_res_ && sigma >= 8.0) {
      if (lazy_up_) resolved();
      // composite.cpp's reduction and blur, up-sampling deferred as below.
      Image& q = ws_.image(name_ + ".quarter", (full_->width() + 3) / 4, (full_->height() + 3) / 4, 4);
      reduce_and_blur(*full_, 4, sigma, q);
      half_ = &q;
      factor_ = 4;
      lazy_up_ = true;
    } else if (half_res_ && sigma >= 4.0) {
      if (lazy_up_) resolved();
      // composite.cpp's reduction and blur (2×2 box down, blur of the remaining variance);
      // the bilinear up-sampling is deferred: the next composite or read does it on the fly.
      Image& half = ws_.image(name_ + ".half", (full_->width() + 1) / 2, (full_->height() + 1) / 2, 4);
      reduce_and_blur(*full_, 2, sigma, half);
      half_ = &half;
      factor_ = 2;
      lazy_up_ = true;
    } else {
      if (lazy_up_) resolved();
      core::gaussian_blur(*full_, static_cast<float>(sigma));
    }
  }
  pending_var_ = 0;
}

const Image& FastAccumulator::resolved() {
  if (pending_var_ > 0) settle();
  if (lazy_up_) {
    Image& img = *full_;
    const Image& half = *half_;
    const int w = img.width(), h = img.height();
    core::parallel_for(
        h,
        [&](int y0, int y1) {
          for (int c = 0; c < 4; ++c)
            for (int y = y0; y < y1; ++y)
              for (int x0 = 0; x0 < w; x0 += kBlock)
                up_block(half.plane(c), half.width(), half.height(), y, x0, std::min(kBlock, w - x0),
                         img.row(c, y) + x0, factor_);
        },
        4);
    lazy_up_ = false;
  }
  return *full_;
}

void FastAccumulator::combine(Image& layer, bool layer_in_front) {
  settle();
  if (!has_) {
    full_ = &ws_.image(name_ + ".full", layer.width(), layer.height(), 4);
    std::swap(*full_, layer);
    has_ = true;
    return;
  }
  if (!lazy_up_) {
    if (layer_in_front)
      over(layer, *full_, *full_);
    else
      over(*full_, layer, *full_);
    return;
  }
  // composite.cpp's over() with the accumulator's up-sampled rows read from the half image.
  Image& img = *full_;
  const AccRows acc(*this);
  const int w = img.width(), h = img.height();
  core::parallel_for(
      h,
      [&](int y0, int y1) {
        float buf[4][kBlock];
        float t[kBlock];
        for (int y = y0; y < y1; ++y)
          for (int x0 = 0; x0 < w; x0 += kBlock) {
            const int n = std::min(kBlock, w - x0);
            const float* a[4];
            acc.get(y, x0, n, buf, a);
            const float* l[4];
            for (int c = 0; c < 4; ++c) l[c] = layer.row(c, y) + x0;
            const float* const* f = layer_in_front ? l : a;
            const float* const* b = layer_in_front ? a : l;
            for (int i = 0; i < n; ++i) t[i] = 1.0f - f[3][i];
            float out[4][kBlock];
            for (int c = 0; c < 4; ++c)
              for (int i = 0; i < n; ++i) out[c][i] = f[c][i] + t[i] * b[c][i];
            for (int c = 0; c < 4; ++c) std::copy(out[c], out[c] + n, img.row(c, y) + x0);
          }
      },
      4);
  lazy_up_ = false;
}

void FastAccumulator::composite_front(Image& layer) { combine(layer, true); }
void FastAccumulator::composite_back(Image& layer) { combine(layer, false); }

void final_composite(FastAccumulator& front, const Image* focus, FastAccumulator& back, int w, int h, Image& out) {
  front.settle();
  back.settle();
  out.resize(w, h, 4);
  const AccRows F(front), B(back);
  core::parallel_for(
      h,
      [&](int y0, int y1) {
        float fb[4][kBlock], bb[4][kBlock];
        float cur[4][kBlock];
        for (int y = y0; y < y1; ++y)
          for (int x0 = 0; x0 < w; x0 += kBlock) {
            const int n = std::min(kBlock, w - x0);
            for (int c = 0; c < 4; ++c) {
              if (focus)
                std::copy(focus->row(c, y) + x0, focus->row(c, y) + x0 + n, cur[c]);
              else
                std::fill(cur[c], cur[c] + n, 0.0f);
            }
            if (B.present()) {  // out = out over B
              const float* b[4];
              B.get(y, x0, n, bb, b);
              float t[kBlock];
              for (int i = 0; i < n; ++i) t[i] = 1.0f - cur[3][i];
              for (int c = 0; c < 4; ++c)
                for (int i = 0; i < n; ++i) cur[c][i] = cur[c][i] + t[i] * b[c][i];
            }
            if (F.present()) {  // out = F over out
              const float* f[4];
              F.get(y, x0, n, fb, f);
              float t[kBlock];
              for (int i = 0; i < n; ++i) t[i] = 1.0f - f[3][i];
              for (int c = 0; c < 4; ++c)
                for (int i = 0; i < n; ++i) cur[c][i] = f[c][i] + t[i] * cur[c][i];
            }
            for (int c = 0; c < 4; ++c) std::copy(cur[c], cur[c] + n, out.row(c, y) + x0);
          }
      },
      4);
}

// ---------------------------------------------------------------------------------------
// The fused Gaussian stack for one fragment per pixel (render_gaussian_fused).
namespace {

constexpr unsigned kNoLayer = 31;

// Layer k of the single-fragment input, produced row block by row block from the per-pixel
// codes (the only layers with a non-zero matte, see render_gaussian_fused) instead of being
// stored: the matte of matting.cpp and, at hole pixels, the push-pull fill of inpaint.cpp.
struct FusedLayer {
  const Image* color = nullptr;
  const float* w0 = nullptr;            // matte in the pixel's first layer j0
  const std::uint16_t* code = nullptr;  // j0 | (second layer j0 + 1 at weight 1) << 5 | hk << 6
  int w = 0, h = 0, k = 0;
  bool fill = false;          // fill the holes (k >= hk)
  const Image* l1 = nullptr;  // pushed pyramid level 1 (null: 1×1 image, fill = self)
  bool opaque = false, under = false;
  // Per row block of kBlock pixels (row y, block x0 / kBlock): the layers any pixel has a
  // non-zero matte in, and the smallest / largest hk (hole from layer hk on) in the block.
  const std::uint32_t* bpres = nullptr;
  const std::uint32_t* bhk = nullptr;
  // Per row block and layer j < 16 (index 16·block + j), for the layers in bpres only: the
  // span lo | hi << 16 of columns (relative to the block) outside which layer j's matte is
  // zero (block_spans).
  const std::uint32_t* bspan = nullptr;
  // Per row block and layer j < 16 (index 16·block + j), for the j with hmin <= j < hmax
  // (bhk) only: the span lo | hi << 16 of columns (relative to the block) outside which no
  // pixel is a hole of layer j (hole_spans; it holds at least one).
  const std::uint32_t* bhole = nullptr;
  int nb = 0;

  enum Cls { kGeneral, kEmptyKnown, kEmptyHole };
  // kEmptyKnown: the layer is 0 and no pixel is a hole in this block; kEmptyHole: 0 and every
  // pixel is a hole. (Their values are exactly what the general code computes there.)
  Cls cls(int y, int x0) const {
    const std::size_t i = static_cast<std::size_t>(y) * nb + x0 / kBlock;
    if ((bpres[i] >> k) & 1u) return kGeneral;
    const int hmin = static_cast<int>(bhk[i] & 255u), hmax = static_cast<int>(bhk[i] >> 8);
    if (k < hmin) return kEmptyKnown;
    if (k >= hmax) return kEmptyHole;
    return kGeneral;
  }

  // The span matte() returns for row y, block x0, without computing the values.
  std::pair<int, int> span(int y, int x0, int n) const {
    const std::size_t bi = static_cast<std::size_t>(y) * nb + x0 / kBlock;
    if (!((bpres[bi] >> k) & 1u)) return {n, 0};
    const std::uint32_t sp = bspan[16 * bi + static_cast<std::size_t>(k)];
    return {static_cast<int>(sp & 0xffffu), static_cast<int>(sp >> 16)};
  }
  // matting.cpp's values of row y, columns [x0, x0 + n); hole flags into hb if non-null.
  // Returns the span [lo, hi) (relative to x0; lo >= hi if empty) outside which the values
  // are +0.
  //
  // Why only the span is evaluated: matte_row gives 0 + t·I with t = w_k, and w_k is non-zero
  // only at pixels whose code names layer k (j0 = k, or j0 + 1 = k with the second-layer
  // bit): the code pass stores every other layer's matte as exactly 0 (see
  // render_gaussian_fused). Elsewhere t = 0 and I is finite (checked before this pass), so
  // 0·I = ±0 and 0 + (±0) = +0: the +0 written outside the span is bit for bit what
  // matte_row computes there. Every pixel whose code names k lies in the span (block_spans:
  // the chunk masks cover all columns), so no non-zero value lies outside; a layer not in
  // bpres has no such pixel in the block.
  // With zero_outside false, o outside the span is left as it was (the caller fills what it
  // reads there).
  std::pair<int, int> matte(int y, int x0, int n, float (*o)[kBlock], std::uint8_t* hb,
                            bool zero_outside = true) const {
    const Cls c = cls(y, x0);
    if (c != kGeneral) {
      for (int ch = 0; ch < 4; ++ch) std::fill(o[ch], o[ch] + n, 0.0f);
      if (hb) std::fill(hb, hb + n, static_cast<std::uint8_t>(c == kEmptyHole ? 1 : 0));
      return {n, 0};
    }
    const std::size_t bi = static_cast<std::size_t>(y) * nb + x0 / kBlock;
    const std::size_t base = static_cast<std::size_t>(y) * w + x0;
    int lo = n, hi = 0;
    if ((bpres[bi] >> k) & 1u) {
      const std::uint32_t sp = bspan[16 * bi + static_cast<std::size_t>(k)];
      lo = static_cast<int>(sp & 0xffffu);
      hi = static_cast<int>(sp >> 16);
    }
    if (hi <= lo) {
      if (zero_outside)
        for (int ch = 0; ch < 4; ++ch) std::fill(o[ch], o[ch] + n, 0.0f);
    } else {
      const float* in[4];
      for (int ch = 0; ch < 4; ++ch) {
        if (zero_outside) {
          std::fill(o[ch], o[ch] + lo, 0.0f);
          std::fill(o[ch] + hi, o[ch] + n, 0.0f);
        }
        in[ch] = color->row(ch, y) + x0;
      }
      kern::matte_row(code + base, w0 + base, in, k, lo, hi, o);
    }
    if (hb) {
      // The flags are k >= hk per pixel; all 0 below the block's smallest hk, all 1 from its
      // largest on.
      const int hmin = static_cast<int>(bhk[bi] & 255u), hmax = static_cast<int>(bhk[bi] >> 8);
      if (k < hmin || k >= hmax) {
        std::fill(hb, hb + n, static_cast<std::uint8_t>(k >= hmax ? 1 : 0));
      } else {  // 0 outside the hole span (bhole), no hole there
        const std::uint32_t hs = bhole[16 * bi + static_cast<std::size_t>(k)];
        const int a0 = static_cast<int>(hs & 0xffffu), a1 = static_cast<int>(hs >> 16);
        std::fill(hb, hb + a0, static_cast<std::uint8_t>(0));
        kern::hole_row(code + base, k, a0, a1, hb);
        std::fill(hb + a1, hb + n, static_cast<std::uint8_t>(0));
      }
    }
    return {lo, hi};
  }
  // The layer with its holes filled.
  //
  // The fill (fill_row, or finish_fill for a 1×1 image) changes hole pixels only and leaves
  // every other pixel's matte value as it is, so it runs on the block's hole span [a0, a1)
  // only (bhole: every hole pixel of layer k lies in it), and the hole flags are needed
  // (hole_row) only there: the columns outside hold no hole and keep the matte's values,
  // what the fill over the whole block leaves there.
  void get(int y, int x0, int n, float (*o)[kBlock], HCache* cache = nullptr) const {
    if (fill && l1 && cache && !opaque && !under && cls(y, x0) == kEmptyHole) {
      // Every pixel is a hole over a zero matte: fill_row gives 0·0 + (1 − 0)·up = +0 + up
      // everywhere, computed here straight into o.
      if (cache->img != l1 || cache->x0 != x0) cache->reset(l1, 2, x0);
      cache->get(y, n, o, true);
      return;
    }
    matte(y, x0, n, o, nullptr);
    if (!fill) return;
    // The flags are k >= hk per pixel: none below the block's smallest hk, all from its
    // largest on (as in matte).
    const std::size_t bi = static_cast<std::size_t>(y) * nb + x0 / kBlock;
    const int hmin = static_cast<int>(bhk[bi] & 255u), hmax = static_cast<int>(bhk[bi] >> 8);
    if (k < hmin) return;
    std::uint8_t hb[kBlock];
    int a0 = 0, a1 = n;
    if (k >= hmax) {
      std::fill(hb, hb + n, static_cast<std::uint8_t>(1));
    } else {
      const std::uint32_t hs = bhole[16 * bi + static_cast<std::size_t>(k)];
      a0 = static_cast<int>(hs & 0xffffu);
      a1 = static_cast<int>(hs >> 16);
      kern::hole_row(code + static_cast<std::size_t>(y) * w + x0, k, a0, a1, hb);
    }
    float up[4][kBlock];
    if (l1 && cache) {
      if (cache->img != l1 || cache->x0 != x0) cache->reset(l1, 2, x0);
      cache->get(y, n, a0, a1, up);  // the fill reads up only at [a0, a1)
    } else {
      for (int c = 0; c < 4; ++c) {
        if (l1)
          up_block(l1->plane(c), l1->width(), l1->height(), y, x0, n, up[c]);
        else
          std::copy(o[c], o[c] + n, up[c]);  // 1×1: the fill is the pixel itself
      }
    }
    if (l1) {
      kern::fill_row(hb, up, opaque, under, a0, a1, o);
      return;
    }
    float* d[4] = {o[0], o[1], o[2], o[3]};
    for (int j = a0; j < a1; ++j) {
      if (!hb[j]) continue;
      float v[4];
      for (int c = 0; c < 4; ++c) v[c] = up[c][j];
      finish_fill(opaque, under, d, j, v);
    }
  }
};

// Pyramid level 1 of the layer (pull_level's arithmetic, children from the generator): coarse
// row yc. r / hb: scratch for two fine rows.
//
// skip_hole_values: a block of four holes gets its confidences (0) but not its values (+0):
// only for a level the push then runs over (a pyramid above level 1), which writes +0 + up
// wherever w = 0 without reading v (push_rows4_simd); before it, v is read where w = 0 only by
// the pull of level 2, which skips such children (their products are masked to +0), so no
// value depends on what v held there. Saves 4 of the 5 plane fills of such blocks.
void pull_row(const FusedLayer& L, int yc, Image& cv, Image& cwt, float (*r)[4][kBlock], std::uint8_t (*hb)[kBlock],
              bool skip_hole_values = false) {
  const int w = L.w, h = L.h;
  const int rows = 2 * yc + 1 < h ? 2 : 1;
  for (int x0 = 0; x0 < w; x0 += kBlock) {
    const int n = std::min(kBlock, w - x0);
    int xc = x0 / 2;
    if (rows == 2) {  // full 2×2 blocks
      float* cvp[4];
      for (int k = 0; k < 4; ++k) cvp[k] = cv.row(k, yc) + xc;
      const int m = n / 2;
      const FusedLayer::Cls c0 = L.cls(2 * yc, x0), c1 = L.cls(2 * yc + 1, x0);
      if (c0 == c1 && c0 != FusedLayer::kGeneral && 2 * m == n) {
        // Four known zeros: value 0 / 4 = 0, confidence 1; four holes: 0 and 0.
        if (!(skip_hole_values && c0 == FusedLayer::kEmptyHole)) kern::fill_rows(cvp, 4, m, 0.0f);
        float* cwp = cwt.row(0, yc) + xc;
        kern::fill_rows(&cwp, 1, m, c0 == FusedLayer::kEmptyKnown ? 1.0f : 0.0f);
        continue;
      }
      // Both rows are +0 outside the union [lo, hi) of their spans (FusedLayer::matte), and
      // the pairs [p0, p1) = [lo / 2, ⌈hi / 2⌉) cover it. pull_pairs reads the rows at fine
      // columns [2·p0, 2·p1) only, so with no odd last column (2m = n; else the scalar tail
      // below reads the block's last column) only those are completed with +0 outside each
      // row's own span.
      const bool exact = 2 * m == n;
      if (exact) {
        // One kernel from the codes and the colour (pull_pairs_simd): the same values as the
        // matte, the hole flags and pull_pairs below. The pairs [p0, p1) as below.
        const std::pair<int, int> sq[2] = {L.span(2 * yc, x0, n), L.span(2 * yc + 1, x0, n)};
        const int lo = std::min(sq[0].first, sq[1].first), hi = std::max(sq[0].second, sq[1].second);
        const int p0 = hi > lo ? std::min(lo / 2, m) : 0, p1 = hi > lo ? std::max(p0, std::min((hi + 1) / 2, m)) : 0;
        PullRows pr;
        for (int dy = 0; dy < 2; ++dy) {
          const std::size_t base = static_cast<std::size_t>(2 * yc + dy) * w + x0;
          pr.code[dy] = L.code + base;
          pr.w0[dy] = L.w0 + base;
          for (int ch = 0; ch < 4; ++ch) pr.in[dy][ch] = L.color->row(ch, 2 * yc + dy) + x0;
        }
        pr.k = L.k;
        pull_pairs_simd(pr, m, p0, p1, cvp, cwt.row(0, yc) + xc);
        continue;
      }
      const std::pair<int, int> sp[2] = {L.matte(2 * yc, x0, n, r[0], hb[0], !exact),
                                         L.matte(2 * yc + 1, x0, n, r[1], hb[1], !exact)};
      const int lo = std::min(sp[0].first, sp[1].first), hi = std::max(sp[0].second, sp[1].second);
      const int p0 = hi > lo ? std::min(lo / 2, m) : 0, p1 = hi > lo ? std::max(p0, std::min((hi + 1) / 2, m)) : 0;
      if (exact)
        for (int dy = 0; dy < 2; ++dy) {
          const int a = 2 * p0, e = 2 * p1;
          const int l = sp[dy].second > sp[dy].first ? std::clamp(sp[dy].first, a, e) : e;
          const int u = sp[dy].second > sp[dy].first ? std::clamp(sp[dy].second, l, e) : e;
          for (int ch = 0; ch < 4; ++ch) {
            std::fill(r[dy][ch] + a, r[dy][ch] + l, 0.0f);
            std::fill(r[dy][ch] + u, r[dy][ch] + e, 0.0f);
          }
        }
      kern::pull_pairs(r[0], r[1], hb[0], hb[1], m, p0, p1, cvp, cwt.row(0, yc) + xc);
      xc += m;
    } else {
      L.matte(2 * yc, x0, n, r[0], hb[0]);
    }
    for (; xc < (x0 + n + 1) / 2; ++xc) {
      double sw = 0, sv[4] = {0, 0, 0, 0};
      for (int dy = 0; dy < 2; ++dy)
        for (int dx = 0; dx < 2; ++dx) {
          const int fx = 2 * xc + dx, fy = 2 * yc + dy;
          if (fx >= w || fy >= h) continue;
          const float wt = hb[dy][fx - x0] ? 0.0f : 1.0f;
          if (wt <= 0) continue;
          sw += wt;
          for (int k = 0; k < 4; ++k) sv[k] += wt * r[dy][k][fx - x0];
        }
      cwt.row(0, yc)[xc] = static_cast<float>(std::min(1.0, sw / 4.0));
      for (int k = 0; k < 4; ++k) cv.row(k, yc)[xc] = sw > 0 ? static_cast<float>(sv[k] / sw) : 0.0f;
    }
  }
}

// Pyramid level 1 of the layer (cv, cwt) and, if cv2 is non-null, level 2 from it (cv2,
// cwt2): row y of level 2 right after the level-1 rows 2y, 2y + 1 it reads, while they are
// in cache (pull_upper_row; the values do not depend on when a row is pulled).
void pull_from_layer(const FusedLayer& L, Image& cv, Image& cwt, Image* cv2, Image* cwt2) {
  const int rows = cv2 ? cv2->height() : cv.height();
  core::parallel_for(
      rows,
      [&](int y0, int y1) {
        float r[2][4][kBlock];
        std::uint8_t hb[2][kBlock];
        for (int y = y0; y < y1; ++y) {
          if (!cv2) {
            pull_row(L, y, cv, cwt, r, hb);
            continue;
          }
          for (int yc = 2 * y; yc < std::min(2 * y + 2, cv.height()); ++yc) pull_row(L, yc, cv, cwt, r, hb, true);
          pull_upper_row(cv, cwt, *cv2, *cwt2, y);
        }
      },
      cv2 ? 2 : 4);
}

// The pull of the next layer's pyramid levels 1 and (if cv2 is non-null) 2, done in the same
// pass as a composite (the two read the same input rows, once from memory; level 2 reads
// level 1's rows while they are in cache).
struct NextPull {
  const FusedLayer* L = nullptr;
  Image* cv = nullptr;
  Image* cwt = nullptr;
  Image* cv2 = nullptr;
  Image* cwt2 = nullptr;
};

// The spans of FusedLayer::bspan for one row block of n <= kBlock pixels, from its chunk
// masks (kern::code_summary): for each layer k named in the block, [lo, hi) from the start
// of the first to the end of the last 16-pixel chunk naming k. Every pixel whose code names k
// lies in one of those chunks, so in the span (it may also hold pixels that do not: their
// matte is computed, and is 0, as before).
void block_spans(const std::uint32_t* cm, int n, std::uint32_t* span) {
  const int nc = (n + 15) / 16;
  std::uint32_t lo[16], hi[16];
  std::uint32_t seen = 0;
  for (int c = 0; c < nc; ++c) {
    const std::uint32_t b = cm[c] & 0xffffu;
    for (std::uint32_t f = b & ~seen; f; f &= f - 1) lo[std::countr_zero(f)] = static_cast<std::uint32_t>(16 * c);
    seen |= b;
  }
  seen = 0;
  for (int c = nc - 1; c >= 0; --c) {
    const std::uint32_t b = cm[c] & 0xffffu;
    for (std::uint32_t f = b & ~seen; f; f &= f - 1)
      hi[std::countr_zero(f)] = static_cast<std::uint32_t>(std::min(n, 16 * c + 16));
    seen |= b;
  }
  for (std::uint32_t f = seen; f; f &= f - 1) {
    const int k = std::countr_zero(f);
    span[k] = lo[k] | hi[k] << 16;
  }
}

// FusedLayer::bhole for one row block of n <= kBlock pixels, from the smallest hk of each
// 16-pixel chunk (kern::code_summary), for the layers k in [hmin, min(hmax, 16)) only (the
// block's smallest / largest hk: below, no pixel is a hole, from hmax on every pixel is, and
// FusedLayer decides those from bhk without reading bhole): [lo, hi) from the start of the
// first to the end of the last chunk with a pixel of hk <= k (a hole of layer k). Every hole
// pixel of k lies in such a chunk, so in the span, and at least one chunk (one holding hk =
// hmin) qualifies. The first chunk for k comes no later than for k − 1 (more chunks
// qualify), so one pass in each direction sets each layer once: a chunk sets the layers from
// its own smallest hk up to (not including) the smallest hk of the chunks before it.
void hole_spans(const std::uint32_t* ch, int n, std::uint32_t hk, std::uint32_t* span) {
  const std::uint32_t hmin = hk & 255u, hmax = std::min(hk >> 8, 16u);
  std::uint32_t s = hmax;
  for (int c = 0; s > hmin; ++c)
    for (; s > ch[c]; --s) span[s - 1] = static_cast<std::uint32_t>(16 * c);
  s = hmax;
  for (int c = (n + 15) / 16 - 1; s > hmin; --c)
    for (; s > ch[c]; --s) span[s - 1] |= static_cast<std::uint32_t>(std::min(n, 16 * c + 16)) << 16;
}

std::atomic<std::uint64_t> g_fused_renders{0};
// Band blocks of composite passes written as +0 without computing them (see composite_pass).
std::atomic<std::uint64_t> zero_blocks{0};

// Row y of block x0 of layer k (FusedLayer::get's values: the matte inside the layer's span,
// the fill inside its hole span) in one kernel (crow_row_simd), and with am = 1 / 2 "over" (or
// under) an accumulator of +0 rows / of the up-sampling of `acc` (reduced by `factor`, rows
// cached in acc_cache). For a layer whose fill, if any, has a pyramid level (L.l1).
void fused_row(const FusedLayer& L, int y, int x0, int n, HCache& fill_cache, int am, HCache* acc_cache,
               const Image* acc, int factor, bool front, float (*c)[kBlock], const ZeroMap* azm = nullptr) {
  const int k = L.k;
  const std::size_t bi = static_cast<std::size_t>(y) * L.nb + x0 / kBlock;
  const std::size_t base = static_cast<std::size_t>(y) * L.w + x0;
  CrowRow r;
  r.code = L.code + base;
  r.w0 = L.w0 + base;
  for (int ch = 0; ch < 4; ++ch) r.in[ch] = L.color->row(ch, y) + x0;
  r.k = k;
  const std::pair<int, int> sp = L.span(y, x0, n);
  int a0 = n, a1 = 0;
  if (L.fill) {
    const int hmin = static_cast<int>(L.bhk[bi] & 255u), hmax = static_cast<int>(L.bhk[bi] >> 8);
    if (k >= hmax) {
      a0 = 0;
      a1 = n;
    } else if (k >= hmin) {
      const std::uint32_t hs = L.bhole[16 * bi + static_cast<std::size_t>(k)];
      a0 = static_cast<int>(hs & 0xffffu);
      a1 = static_cast<int>(hs >> 16);
    }
  }
  const float* const* ft = kZeroRows;
  const float* const* fb = kZeroRows;
  r.fty = 0.0f;
  if (a1 > a0) {
    if (fill_cache.img != L.l1 || fill_cache.x0 != x0) fill_cache.reset(L.l1, 2, x0);
    fill_cache.rows(y, n, ft, fb, r.fty);
  }
  r.opaque = L.opaque;
  r.under = L.under;
  const float* const* at = kZeroRows;
  const float* const* ab = kZeroRows;
  r.aty = 0.0f;
  r.am = am;
  if (am == 2) {
    if (acc_cache->img != acc || acc_cache->x0 != x0) acc_cache->reset(acc, factor, x0, azm);
    acc_cache->rows(y, n, at, ab, r.aty);
  }
  // Rows of the HCaches or kZeroRows: channel ch at + ch·kRowStride, as crow_row_simd reads them.
  r.ft = ft[0];
  r.fb = fb[0];
  r.at = at[0];
  r.ab = ab[0];
  r.front = front;
  crow_row_simd(r, n, sp.first, sp.second, a0, a1, c);
}

// One composite step of an accumulator: C = L over A (layer_in_front) or A over L (A absent:
// C = L), written at full resolution into dst_full (which may be A's own full image) or
// reduced by composite.cpp's 2×2 box into dst_half.
void composite_pass(const FusedLayer& L, const AccRows& A, bool layer_in_front, Image* dst_full, Image* dst_half,
                    Image* dst_quarter, const NextPull& next) {
  const int w = L.w, h = L.h;
  struct Scratch {
    float rows[4][4][kBlock];
    float tmp[4][kBlock];
    float pr[2][4][kBlock];
    std::uint8_t phb[2][kBlock];
    float qacc[4 * (kBlock / 4)];  // lerp_quads_acc_simd's partial 4×4 sums
    HCache* acc;                   // nbc caches of A's rows, one per column block
    HCache* fill;                  // nbc caches of the fill's pyramid level
  };
  // Per column block, caches of the horizontally up-sampled coarse rows of A and of the
  // fill's pyramid level: kept across the bands of a task, so a coarse row shared by
  // neighbouring bands is up-sampled once per task (was once per band: 2–3 times).
  const int nbc = (w + kBlock - 1) / kBlock;
  auto empty = [&](int y, int x0) {
    const FusedLayer::Cls cl = L.cls(y, x0);
    return cl == FusedLayer::kEmptyKnown || (cl == FusedLayer::kEmptyHole && !L.fill);
  };
  // A row of a block where layer k is not known empty, in one kernel (fused_row).
  auto crow_fused = [&](int y, int x0, int n, float(*c)[kBlock], Scratch& s, bool azero) {
    const int am = !A.present() ? 0 : (azero ? 1 : 2);
    fused_row(L, y, x0, n, s.fill[x0 / kBlock], am, &s.acc[x0 / kBlock], A.half, A.factor, layer_in_front, c, A.zm);
  };
  // azero: A's rows here are known to be +0 (ZeroMap): they are taken as rows of +0 instead
  // of being up-sampled (the same values, see ZeroMap).
  auto crow = [&](int y, int x0, int n, float(*c)[kBlock], Scratch& s, bool azero) {
    if (empty(y, x0)) {
      // L = 0 here: 0 over A = A and A over 0 = A (exactly, up to the sign of a zero).
      if (!A.present() || azero) {
        for (int ch = 0; ch < 4; ++ch) std::fill(c[ch], c[ch] + n, 0.0f);
        return;
      }
      const float* a[4];
      A.get(y, x0, n, c, a, &s.acc[x0 / kBlock]);
      for (int ch = 0; ch < 4; ++ch)
        if (a[ch] != c[ch]) std::copy(a[ch], a[ch] + n, c[ch]);
      return;
    }
    if (!A.full && (!L.fill || L.l1)) {  // the fused row (kern::crow_row), same values
      crow_fused(y, x0, n, c, s, azero);
      return;
    }
    L.get(y, x0, n, c, &s.fill[x0 / kBlock]);
    if (!A.present()) return;
    if (azero) {
      kern::over_rows(c, kZeroRows, layer_in_front, n);
      return;
    }
    const float* a[4];
    A.get(y, x0, n, s.tmp, a, &s.acc[x0 / kBlock]);
    kern::over_rows(c, a, layer_in_front, n);
  };
  // Bands of 4 full-resolution rows, column block by column block: the composite of rows
  // 4b … 4b + 3 (clamped to the image), then 4 full rows, 2 half rows (composite.cpp's 2×2
  // box) or 1 quarter row (its 4×4 box) of output; then the next layer's coarse rows 2b,
  // 2b + 1 from the same input rows.
  const int bands = (h + 3) / 4;
  const int hh = (h + 1) / 2;
  core::parallel_for(
      bands,
      [&](int b0, int b1) {
        // Default-initialised (new T, not make_unique): only the caches set their keys; the
        // buffers are written before they are read; zeroing ~60 KB per band task cost ~36 M
        // instructions per 1080p render.
        std::unique_ptr<Scratch> sp(new Scratch);
        Scratch& s = *sp;
        std::unique_ptr<HCache[]> caches(new HCache[2 * nbc]);
        s.acc = caches.get();
        s.fill = caches.get() + nbc;
        // Counted per task and added once (an atomic add per block bounced the counter's cache
        // line between the two cores).
        std::uint64_t task_zero_blocks = 0;
        for (int b = b0; b < b1; ++b) {
          int ys[4], src[4];
          for (int dy = 0; dy < 4; ++dy) ys[dy] = std::min(4 * b + dy, h - 1);
          for (int x0 = 0; x0 < w; x0 += kBlock) {
            const int n = std::min(kBlock, w - x0);
            const bool azero = A.present() && A.zero(ys[0], ys[3], x0);
            if ((!A.present() || azero) && empty(ys[0], x0) && empty(ys[1], x0) && empty(ys[2], x0) &&
                empty(ys[3], x0)) {
              // An empty layer over (or under) +0: the composite is +0, and so are its 2×2 and
              // 4×4 box means (0.25 · (+0 + … + +0) = +0).
              ++task_zero_blocks;
              float* d[4];
              if (dst_full) {
                for (int dy = 0; dy < 4 && 4 * b + dy < h; ++dy) {
                  for (int ch = 0; ch < 4; ++ch) d[ch] = dst_full->row(ch, 4 * b + dy) + x0;
                  kern::fill_rows(d, 4, n, 0.0f);
                }
              } else if (dst_quarter) {
                for (int ch = 0; ch < 4; ++ch) d[ch] = dst_quarter->row(ch, b) + x0 / 4;
                kern::fill_rows(d, 4, (x0 + n + 3) / 4 - x0 / 4, 0.0f);
              } else {
                for (int yh = 2 * b; yh < std::min(2 * b + 2, hh); ++yh) {
                  for (int ch = 0; ch < 4; ++ch) d[ch] = dst_half->row(ch, yh) + x0 / 2;
                  kern::fill_rows(d, 4, (x0 + n + 1) / 2 - x0 / 2, 0.0f);
                }
              }
              continue;
            }
            if (A.half && !azero && !dst_full && n % (dst_quarter ? 4 : 2) == 0 && empty(ys[0], x0) &&
                empty(ys[1], x0) && empty(ys[2], x0) && empty(ys[3], x0)) {
              // An empty layer over a reduced accumulator that is not +0 here (a quarter of the
              // band blocks on the bench frame): every row is A's up-sampling (crow's A.get, the
              // vertical lerp of the cached rows), and the 2×2 / 4×4 box reads it straight from
              // the lerps in the same kernel (lerp_quads_acc_simd / lerp_pairs_box_simd: the same
              // lerps and the same sums in the same order as lerp_rows4 then down_quads_simd /
              // down_pairs), instead of storing the four rows first. With n a multiple of the box
              // width there is no clamped last output (the general path below takes the rest).
              HCache& ac = s.acc[x0 / kBlock];
              if (ac.img != A.half || ac.x0 != x0) ac.reset(A.half, A.factor, x0, A.zm);
              const bool exact = A.tiny(ys[0], ys[3], x0);
              if (dst_quarter) {
                const int m = n / 4;
                for (int dy = 0; dy < 4; ++dy) {  // rows in order: the sums' order (see lerp_quads_acc_simd)
                  const float* const* top;
                  const float* const* bot;
                  float ty;
                  ac.rows(ys[dy], n, top, bot, ty);
                  lerp_quads_acc_simd(top[0], bot[0], ty, m, dy == 0, s.qacc, exact);
                }
                for (int ch = 0; ch < 4; ++ch) {
                  float* d = dst_quarter->row(ch, b) + x0 / 4;
                  const float* q = s.qacc + (kBlock / 4) * ch;
                  for (int x = 0; x < m; ++x) d[x] = 0.0625f * q[x];
                }
              } else {
                for (int yh = 2 * b; yh < std::min(2 * b + 2, hh); ++yh) {
                  const int da = 2 * (yh - 2 * b);  // rows 2yh and min(2yh + 1, h − 1) of the band
                  const float* const* ta;
                  const float* const* ba;
                  const float* const* tb;
                  const float* const* bb;
                  float tya, tyb;
                  // The second row's cache lookup may replace an entry, not the first row's
                  // (HCache::row: rows asked in increasing order; the pointers are read before).
                  ac.rows(ys[da], n, ta, ba, tya);
                  const float* a0 = ta[0];
                  const float* a1 = ba[0];
                  ac.rows(ys[da + 1], n, tb, bb, tyb);
                  float* d[4];
                  for (int ch = 0; ch < 4; ++ch) d[ch] = dst_half->row(ch, yh) + x0 / 2;
                  lerp_pairs_box_simd(a0, a1, tya, tb[0], bb[0], tyb, n / 2, d, exact);
                }
              }
              continue;
            }
            for (int dy = 0; dy < 4; ++dy) {
              src[dy] = dy;
              if (dy > 0 && ys[dy] == ys[dy - 1])
                src[dy] = src[dy - 1];
              else
                crow(ys[dy], x0, n, s.rows[dy], s, azero);
            }
            if (dst_full) {
              for (int dy = 0; dy < 4 && 4 * b + dy < h; ++dy)
                for (int ch = 0; ch < 4; ++ch)
                  std::copy(s.rows[dy][ch], s.rows[dy][ch] + n, dst_full->row(ch, 4 * b + dy) + x0);
            } else if (dst_quarter) {
              Image& q = *dst_quarter;
              const int m = n / 4;  // quads inside the block (x0 is a multiple of 4)
              for (int ch = 0; ch < 4; ++ch) {
                const float* r[4];
                for (int dy = 0; dy < 4; ++dy) r[dy] = s.rows[src[dy]][ch];
                float* d = q.row(ch, b);
                down_quads_simd(r[0], r[1], r[2], r[3], m, d + x0 / 4);
                for (int xq = x0 / 4 + m; xq < (x0 + n + 3) / 4; ++xq) {
                  float sum = 0.0f;
                  for (int dy = 0; dy < 4; ++dy)
                    for (int dx = 0; dx < 4; ++dx) sum += r[dy][std::min(4 * xq + dx, w - 1) - x0];
                  d[xq] = 0.0625f * sum;
                }
              }
            } else {
              Image& half = *dst_half;
              for (int yh = 2 * b; yh < std::min(2 * b + 2, hh); ++yh) {
                const int da = 2 * (yh - 2 * b);  // rows 2yh and min(2yh + 1, h − 1) of the band
                for (int ch = 0; ch < 4; ++ch) {
                  const float* pa = s.rows[src[da]][ch];
                  const float* pb = s.rows[src[da + 1]][ch];
                  float* d = half.row(ch, yh);
                  const int m = n / 2;  // pairs inside the block (x0 is even)
                  kern::down_pairs(pa, pb, m, d + x0 / 2);
                  for (int xh = x0 / 2 + m; xh < (x0 + n + 1) / 2; ++xh) {
                    const int xa = 2 * xh - x0, xb = std::min(2 * xh + 1, w - 1) - x0;
                    d[xh] = 0.25f * (pa[xa] + pa[xb] + pb[xa] + pb[xb]);
                  }
                }
              }
            }
          }
          if (next.L) {
            for (int yc = 2 * b; yc < std::min(2 * b + 2, hh); ++yc)
              pull_row(*next.L, yc, *next.cv, *next.cwt, s.pr, s.phb, next.cv2 != nullptr);
            // Level 2's row b reads level 1's rows 2b, 2b + 1: those just written (level 2 has
            // (hh + 1) / 2 = bands rows).
            if (next.cv2) pull_upper_row(*next.cv, *next.cwt, *next.cv2, *next.cwt2, b);
          }
        }
        if (task_zero_blocks) zero_blocks.fetch_add(task_zero_blocks, std::memory_order_relaxed);
      },
      1);
}

}  // namespace

std::uint64_t fused_render_count() { return g_fused_renders.load(); }
std::uint64_t zero_block_count() { return zero_blocks.load(); }
std::uint64_t tiny_block_count() { return g_tiny_blocks.load(); }

bool render_gaussian_fused(const MethodContext& ctx, const Fragments& frags, const LayerPlan& plan, bool half_res,
                           bool quarter_res, bool do_fill, bool fill_under, Image& out) {
  if (frags.color.size() != 1 || plan.count > 16) return false;
  // Debug views need the stored layers and accumulators: the per-layer path provides them.
  for (const char* v : {"front", "back"})
    if (ctx.debug.wants(v)) return false;
  for (int k = 0; k < 16; ++k)
    for (const char* suffix : {"_matted", "_blurred"})
      if (ctx.debug.wants(("layer_" + std::to_string(k) + suffix).c_str())) return false;

  const Image& color = *frags.color[0];
  const Image& coc = *frags.coc[0];
  const int w = color.width(), h = color.height(), K = plan.count;
  Workspace& ws = ctx.workspace;
  const std::size_t npix = static_cast<std::size_t>(w) * h;
  float* w0 = ws.image("layered.w0", w, h, 1).plane(0);
  std::uint16_t* code = ws.plane<std::uint16_t>("layered.code", npix);

  // Code pass. A fragment of CoC r has a non-zero matte in at most two adjacent layers (its
  // plateau layer at weight 1 and the nearer one on the ramp; anchors.cpp). With j the first
  // layer whose anchor a_j <= r, only j − 1 and j can be non-zero: for k <= j − 2,
  // r < a_{k+1} makes u <= 0 in the ramp branch, and for k >= j + 1, r >= a_{k−1} makes
  // u >= 1 (rounding is monotonic) in the farther branch, both exactly 0 (the tests compare
  // every layer against the plain matte). Those three are
  // evaluated with the plan's own arithmetic (Matte) and stored as (j0, w_{j0}, w_{j0+1} = 1?).
  // The holes of the visible fragment, r > near_limit(k), are an up-set k >= hk because
  // near_limit decreases with k. Anything unexpected sends the frame down the per-layer path.
  std::vector<Matte> mattes;
  std::vector<double> nl(K);
  for (int k = 0; k < K; ++k) {
    mattes.emplace_back(plan, k);
    nl[k] = plan.near_limit(k);
  }
  const int nb = (w + kBlock - 1) / kBlock;
  const std::size_t nblocks = static_cast<std::size_t>(nb) * h;
  std::uint32_t* bpres = ws.plane<std::uint32_t>("layered.block_layers", nblocks);
  std::uint32_t* bhk = ws.plane<std::uint32_t>("layered.block_holes", nblocks);
  std::uint32_t* bspan = ws.plane<std::uint32_t>("layered.spans", 16 * nblocks);
  std::uint32_t* bhole = ws.plane<std::uint32_t>("layered.holes", 16 * nblocks);
  std::atomic<std::uint32_t> nonempty{0}, holes{0};
  std::atomic<bool> bail{false};
  std::optional<core::PassScope> code_pass(std::in_place, "code pass");
  core::parallel_for(
      h,
      [&](int y0, int y1) {
        std::uint32_t ne = 0, ho = 0;
        bool bad = false;
        double anchor[16];
        for (int k = 0; k < K; ++k) anchor[k] = plan.anchor[k];
        bool have = false;
        std::uint32_t last_bits = 0;
        unsigned j0 = kNoLayer, hk = 0;
        float wv = 0.0f;
        bool second = false;
        for (int y = y0; y < y1; ++y) {
          const float* al = color.row(3, y);
          const float* rr = coc.row(0, y);
          const std::size_t base = static_cast<std::size_t>(y) * w;
          for (int x = 0; x < w; ++x) {
            // Runs of 16 pixels that change nothing (each transparent or of the last CoC) are
            // written by one vectorised kernel with the codes the loop below would write.
            while (have && x + 16 <= w &&
                   kern::code_run16(al + x, rr + x, last_bits,
                                    static_cast<std::uint16_t>(j0 | (second ? 32u : 0u) | (hk << 6)), wv,
                                    code + base + x, w0 + base + x))
              x += 16;
            if (x >= w) break;
            const float a = al[x];
            if (!(a > 0)) {
              code[base + x] = static_cast<std::uint16_t>(kNoLayer | (31u << 6));
              w0[base + x] = 0.0f;
              continue;
            }
            const float r = rr[x];
            const std::uint32_t rbits = std::bit_cast<std::uint32_t>(r);
            if (!have || rbits != last_bits) {  // the codes depend on r only: reuse along flat runs
              have = true;
              last_bits = rbits;
              int j = 0;
              while (j < K && !(anchor[j] <= r)) ++j;
              j0 = kNoLayer;
              wv = 0.0f;
              second = false;
              for (int k = std::max(j - 1, 0); k <= std::min(j, K - 1); ++k) {
                const float wk = mattes[k](r);
                if (!(wk > 0)) continue;
                if (j0 == kNoLayer) {
                  j0 = static_cast<unsigned>(k);
                  wv = wk;
                } else if (k == static_cast<int>(j0) + 1 && wk == 1.0f && !second) {
                  second = true;
                } else {
                  bad = true;
                }
              }
              hk = static_cast<unsigned>(K);
              if (do_fill) {
                // Only near_limit(j), near_limit(j + 1) can lie on either side of r: for k <= j − 1
                // near_limit(k) >= a_k > r, for k >= j + 2 near_limit(k) <= a_{k−1} < a_j <= r.
                const bool hj = j < K && r > nl[j];
                const bool hj1 = j + 1 < K && r > nl[j + 1];
                if (hj && !hj1 && j + 1 < K) bad = true;
                hk = static_cast<unsigned>(std::min(K, hj ? j : (hj1 ? j + 1 : j + 2)));
                ho |= ((1u << K) - 1u) & ~((1u << hk) - 1u);
              }
            }
            code[base + x] = static_cast<std::uint16_t>(j0 | (second ? 32u : 0u) | (hk << 6));
            w0[base + x] = wv;
          }
          // Block summaries of the row and the non-empty layers (from the codes just written).
          for (int b = 0; b < nb; ++b) {
            const int x0 = b * kBlock, n = std::min(w, x0 + kBlock) - x0;
            const std::size_t i = static_cast<std::size_t>(y) * nb + b;
            std::uint32_t cm[kBlock / 16], chk[kBlock / 16];
            kern::code_summary(code + base + x0, w0 + base + x0, al + x0, n, &bpres[i], &bhk[i], &ne, cm, chk);
            block_spans(cm, n, bspan + 16 * i);
            hole_spans(chk, n, bhk[i], bhole + 16 * i);
          }
        }
        if (ne) nonempty.fetch_or(ne, std::memory_order_relaxed);
        if (ho) holes.fetch_or(ho, std::memory_order_relaxed);
        if (bad) bail.store(true, std::memory_order_relaxed);
      },
      4);
  code_pass.reset();
  if (bail.load()) return false;
  const std::uint32_t ne = nonempty.load(), ho = holes.load();
  auto is_full = [&](int k) { return ((ne >> k) & 1u) != 0; };

  auto layer_gen = [&](int k, bool opaque) {
    FusedLayer L;
    L.color = &color;
    L.w0 = w0;
    L.code = code;
    L.w = w;
    L.h = h;
    L.k = k;
    L.fill = do_fill && is_full(k) && ((ho >> k) & 1u);
    L.opaque = opaque;
    L.under = fill_under;
    L.bpres = bpres;
    L.bhk = bhk;
    L.bspan = bspan;
    L.bhole = bhole;
    L.nb = nb;
    return L;
  };

  // The recursion of composite.cpp's Accumulator, as a list of composite jobs: each non-empty
  // layer is composited, then blurred by what plain applies at its next flush — the variance
  // of the steps up to the next non-empty layer of that side, summed in plain's order — so
  // the composite can be written straight at the resolution that blur runs at.
  struct Job {
    int k;
    bool back;
    double var;
  };
  std::vector<Job> jobs;
  auto add_side = [&](const std::vector<int>& order, bool back_side) {
    std::vector<double> var_after(K, 0.0);
    double pend = 0;
    int last = -1;
    for (int k : order) {
      if (is_full(k)) {
        if (last >= 0) var_after[last] = pend;
        pend = 0;
        last = k;
      }
      if (last >= 0) pend += plan.step_sigma[k] * plan.step_sigma[k];
    }
    if (last >= 0) var_after[last] = pend;
    for (int k : order)
      if (is_full(k)) jobs.push_back({k, back_side, var_after[k]});
  };
  std::vector<int> back_order, front_order;
  for (int k = K - 1; k > plan.focus; --k) back_order.push_back(k);
  for (int k = 0; k < plan.focus; ++k) front_order.push_back(k);
  add_side(back_order, true);
  const std::size_t n_back = jobs.size();
  add_side(front_order, false);
  const bool focus_full = is_full(plan.focus);

  // The layers in processing order (jobs, then the focus layer for the final pass). The
  // first back layer and, without back layers, the focus layer are filled opaque.
  std::vector<FusedLayer> units;
  for (std::size_t i = 0; i < jobs.size(); ++i) units.push_back(layer_gen(jobs[i].k, jobs[i].back && i == 0));
  if (focus_full) units.push_back(layer_gen(plan.focus, n_back == 0));
  // Two push-pull pyramids: layer i + 1's level 1 is pulled during layer i's composite pass.
  const Pyramid pyr[2] = {make_pyramid(ws, w, h, "layered.pp"), make_pyramid(ws, w, h, "layered.pq")};
  const bool pyramid = pyr[0].levels > 1;
  auto needs_pull = [&](std::size_t u) { return u < units.size() && units[u].fill && pyramid; };
  // Level 2 (if the pyramid has one) is pulled in the pass that pulls level 1.
  const bool has_l2 = pyr[0].levels > 2;
  auto finish_pull = [&](std::size_t u) {
    pull_push_upper(pyr[u % 2], has_l2 ? 3 : 2);
    units[u].l1 = pyr[u % 2].val[1];
  };
  if (needs_pull(0)) {
    core::PassScope pass("fill pull");
    pull_from_layer(units[0], *pyr[0].val[1], *pyr[0].wgt[1], has_l2 ? pyr[0].val[2] : nullptr,
                    has_l2 ? pyr[0].wgt[2] : nullptr);
    finish_pull(0);
  }

  struct Side {
    const Image* full = nullptr;
    const Image* half = nullptr;  // reduced by `factor`
    int factor = 2;
    bool has = false;
    int flip = 0, flip_q = 0;
    ZeroMap zero;  // where `half` is +0 (valid while `half` is)
  };
  // Zero maps of the two sides (one byte per coarse row and column block).
  const int nbz = (w + kBlock - 1) / kBlock;
  // One size for both reductions (the half-resolution row count), so no buffer is resized.
  auto zero_store = [&](const std::string& name) {
    return ws.plane<std::uint8_t>(name, static_cast<std::size_t>(nbz) * ((h + 1) / 2));
  };
  Side B, F;
  for (std::size_t i = 0; i < jobs.size(); ++i) {
    const Job& job = jobs[i];
    Side& s = job.back ? B : F;
    const std::string name = job.back ? "layered.fb" : "layered.ff";
    const FusedLayer& L = units[i];
    NextPull next;
    if (needs_pull(i + 1)) {
      const Pyramid& p = pyr[(i + 1) % 2];
      next = {&units[i + 1], p.val[1], p.wgt[1], has_l2 ? p.val[2] : nullptr, has_l2 ? p.wgt[2] : nullptr};
    }
    const AccRows A(s.has ? s.full : nullptr, s.has ? s.half : nullptr, s.factor, &s.zero);
    const double var = job.var;
    const double sigma = std::sqrt(var);
    if (var > 0 && half_res && quarter_res && sigma >= 8.0) {
      const int qw = (w + 3) / 4, qh = (h + 3) / 4;
      Image& dst = ws.image(name + ".quarter" + std::to_string(s.flip_q), qw, qh, 4);
      s.flip_q ^= 1;
      {
        core::PassScope pass("layer composite");
        composite_pass(L, A, job.back, nullptr, nullptr, &dst, next);
      }
      const double v = (sigma * sigma - 1.25 - 8.0 / 3.0) / 16.0;
      core::PassScope pass("layer blur");
      if (v > 0) core::gaussian_blur(dst, static_cast<float>(std::sqrt(v)));
      s.full = nullptr;
      s.half = &dst;
      s.factor = 4;
      s.zero = build_zero_map(dst, 4, w, zero_store(name + ".nz"));
    } else if (var > 0 && half_res && sigma >= 4.0) {
      const int hw = (w + 1) / 2, hh = (h + 1) / 2;
      Image& dst = ws.image(name + ".half" + std::to_string(s.flip), hw, hh, 4);
      s.flip ^= 1;
      {
        core::PassScope pass("layer composite");
        composite_pass(L, A, job.back, nullptr, &dst, nullptr, next);
      }
      const double v = (sigma * sigma - 0.25 - 2.0 / 3.0) / 4.0;
      core::PassScope pass("layer blur");
      if (v > 0) core::gaussian_blur(dst, static_cast<float>(std::sqrt(v)));
      s.full = nullptr;
      s.half = &dst;
      s.factor = 2;
      s.zero = build_zero_map(dst, 2, w, zero_store(name + ".nz"));
    } else {
      Image& dst = ws.image(name + ".full", w, h, 4);
      {
        core::PassScope pass("layer composite");
        composite_pass(L, A, job.back, &dst, nullptr, nullptr, next);
      }
      core::PassScope pass("layer blur");
      if (var > 0) core::gaussian_blur(dst, static_cast<float>(sigma));
      s.full = &dst;
      s.half = nullptr;
      s.zero = ZeroMap();
    }
    s.has = true;
    if (next.L) {
      core::PassScope pass("fill pull");
      finish_pull(i + 1);
    }
  }

  // I = F over L_focus over B (final_composite's arithmetic; the focus layer on the fly).
  const FusedLayer* Lf = focus_full ? &units.back() : nullptr;
  const AccRows BR(B.full, B.half, B.factor, &B.zero), FR(F.full, F.half, F.factor, &F.zero);
  out.resize(w, h, 4);
  core::PassScope final_pass("final composite");
  // Bands of 4 rows, column block by column block, so the horizontally up-sampled coarse
  // rows of B, F and the focus layer's fill are computed once per band (HCache), not twice
  // per fine row.
  struct FinalScratch {
    float fb[4][kBlock], bb[4][kBlock];
    float cur[4][kBlock];
  };
  // Caches per column block, kept across the bands of a task (as in composite_pass).
  const int nbf = (w + kBlock - 1) / kBlock;
  core::parallel_for((h + 3) / 4,
                     [&](int b0, int b1) {
                       std::unique_ptr<FinalScratch> sp(new FinalScratch);  // default-initialised, as above
                       std::unique_ptr<HCache[]> caches(new HCache[3 * nbf]);
                       auto& fb = sp->fb;
                       auto& bb = sp->bb;
                       auto& cur = sp->cur;
                       for (int b = b0; b < b1; ++b)
                         for (int x0 = 0; x0 < w; x0 += kBlock)
                           for (int y = 4 * b; y < std::min(h, 4 * b + 4); ++y) {
                             const int n = std::min(kBlock, w - x0);
                             if (Lf && (!Lf->fill || Lf->l1))
                               fused_row(*Lf, y, x0, n, caches[x0 / kBlock], 0, nullptr, nullptr, 2, true, cur);
                             else if (Lf)
                               Lf->get(y, x0, n, cur, &caches[x0 / kBlock]);
                             else
                               for (int c = 0; c < 4; ++c) std::fill(cur[c], cur[c] + n, 0.0f);
                             float* o[4];
                             for (int c = 0; c < 4; ++c) o[c] = out.row(c, y) + x0;
                             if (!BR.full && !FR.full) {
                               // cur over B, then F over that, with their up-sampling's vertical lerp in the same
                               // kernel (final_row_simd; rows of +0 where a zero map says so).
                               FinalRow fr;
                               fr.c = cur[0];  // cur, the caches' rows and kZeroRows: channels kRowStride apart
                               auto side = [&](const AccRows& R, HCache& cache, int& mode, const float*& top,
                                               const float*& bot, float& ty) {
                                 ty = 0.0f;
                                 mode = R.present() ? 1 : 0;
                                 const float* const* a = kZeroRows;
                                 const float* const* b = kZeroRows;
                                 if (R.present() && !R.zero(y, y, x0)) {
                                   if (cache.img != R.half || cache.x0 != x0) cache.reset(R.half, R.factor, x0, R.zm);
                                   cache.rows(y, n, a, b, ty);
                                   mode = 2;
                                 }
                                 top = a[0];
                                 bot = b[0];
                               };
                               side(BR, caches[nbf + x0 / kBlock], fr.bm, fr.bt, fr.bb, fr.bty);
                               side(FR, caches[2 * nbf + x0 / kBlock], fr.fm, fr.ft, fr.fb, fr.fty);
                               fr.exact = (fr.bm == 2 && BR.tiny(y, y, x0)) || (fr.fm == 2 && FR.tiny(y, y, x0));
                               final_row_simd(fr, n, o);
                               continue;
                             }
                             // cur over B, then F over that (rows of +0 where a zero map says so).
                             const float* back[4] = {kZeroRow, kZeroRow, kZeroRow, kZeroRow};
                             const float* front[4] = {kZeroRow, kZeroRow, kZeroRow, kZeroRow};
                             if (BR.present() && !BR.zero(y, y, x0))
                               BR.get(y, x0, n, bb, back, &caches[nbf + x0 / kBlock]);
                             if (FR.present() && !FR.zero(y, y, x0))
                               FR.get(y, x0, n, fb, front, &caches[2 * nbf + x0 / kBlock]);
                             float t[kBlock], u[kBlock];
                             kern::one_minus(cur[3], n, t);
                             if (FR.present()) kern::one_minus(front[3], n, u);
                             for (int c = 0; c < 4; ++c)
                               kern::final_channel(cur[c], t, BR.present() ? back[c] : nullptr, u,
                                                   FR.present() ? front[c] : nullptr, n, o[c]);
                           }
                     },
                     1);
  g_fused_renders.fetch_add(1);
  return true;
}

}  // namespace dofkit::detail::layered
