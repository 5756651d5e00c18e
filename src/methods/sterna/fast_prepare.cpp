// Fast P1 + P2 (+ padding) and P3–P6. Same arithmetic as coc.cpp, downsample.cpp and
// near_coc_dilate.cpp; see fast.hpp for what is reorganised.
//
// P1 is never stored at full resolution: the downsample needs far at the four quad pixels
// and near at the top-left one, the composite needs far per pixel, and both recompute them
// from the CoC row (BlendRow) with the expression of coc.cpp.
//
// P2 writes colour_h, colourFar_h and far_h straight into planes padded by `pad` texels on
// every side, then replicates the edges into the border: the gather's taps are then plain
// unclamped loads (a clamp-to-edge bilinear lookup inside the image is the same lookup on the
// padded plane).
//
// P3/P4 (separable max): rows use the van Herk / Gil–Werman line max of near_coc_dilate.cpp;
// the column max runs the same block prefix/suffix recurrence along y with whole rows as
// the vectors (contiguous loads instead of a stride-w walk). Max of non-negative finite
// numbers is exact in any order, so the result equals the plain one.
#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstdint>
#include <variant>

#include "core/filters.hpp"
#include "core/parallel.hpp"
#include "methods/sterna/fast.hpp"
#include "methods/sterna/v8.hpp"
#include "render/sanitize.hpp"

namespace dofkit::detail::sterna::fast {

namespace {

// NaN-safe (NaN → 0), same as coc.cpp.
inline float saturate(float v) { return v > 0.0f ? (v < 1.0f ? v : 1.0f) : 0.0f; }
inline float saturate(double v) { return v > 0.0 ? static_cast<float>(v < 1.0 ? v : 1.0) : 0.0f; }

STERNA_SIMD void blend_from_coc(const float* __restrict r, float* __restrict near, float* __restrict far, int n,
                                float ramp) {
  if (near)
    for (int x = 0; x < n; ++x) near[x] = saturate((r[x] - 0.5f) / ramp);
  for (int x = 0; x < n; ++x) far[x] = saturate((-r[x] - 0.5f) / ramp);
}

// The planes in double, as in coc.cpp (planes equal in float would give 0/0).
STERNA_SIMD void blend_from_z(const float* __restrict z, float* __restrict near, float* __restrict far, int n,
                              double nb, double ne, double fb, double fe) {
  for (int x = 0; x < n; ++x) {
    const float nv = saturate((z[x] - ne) / (nb - ne));
    const float fv = std::isinf(z[x]) ? 1.0f : saturate((z[x] - fb) / (fe - fb));
    far[x] = (nv > 0.0f && fv > 0.0f) ? 0.0f : fv;  // overlapping planes: near wins
    if (near) near[x] = nv;
  }
}

struct QuadOut {
  float* col[4];
  float* colf[4];
  float* farh;
  float* nearh;
};

// The gather's opaque-frame tests (fast_gather.cpp), gathered while the row's texels are made:
// the least and largest colour_h alpha (all equal ⟺ least == largest, as ==), and whether some
// colourFar_h alpha differs from far_h in its bits.
struct AlphaStats {
  float lo = 0, hi = 0;
  bool far_differs = false;
  bool any = false;
  void add(float a, float af, float f) {
    lo = any ? std::min(lo, a) : a;
    hi = any ? std::max(hi, a) : a;
    any = true;
    far_differs = far_differs || std::bit_cast<std::uint32_t>(af) != std::bit_cast<std::uint32_t>(f);
  }
};

// One half-res texel from its quad (k = 0 TL, 1 TR, 2 BL, 3 BR): the expressions and the
// order of downsample.cpp.
template <bool kKaris>
inline void quad(const float (&c)[4][4], const float (&far)[4], float near_tl, const QuadOut& o, int i,
                 AlphaStats& st) {
  float wk[4];
  for (int k = 0; k < 4; ++k) wk[k] = kKaris ? 1.0f / (1.0f + std::max(0.0f, luma(c[k][0], c[k][1], c[k][2]))) : 1.0f;
  float wsum = 0.0f, acc[4] = {0, 0, 0, 0};
  for (int k = 0; k < 4; ++k) {
    wsum += wk[k];
    for (int ch = 0; ch < 4; ++ch) acc[ch] += wk[k] * c[k][ch];
  }
  for (int ch = 0; ch < 4; ++ch) o.col[ch][i] = acc[ch] / wsum;
  float bsum = 0.0f, bacc[4] = {0, 0, 0, 0};
  for (int k = 0; k < 4; ++k) {
    const float wb = (k == 0 ? 1000.0f : 1.0f / (std::abs(far[k] - far[0]) + 0.001f)) * wk[k];
    bsum += wb;
    for (int ch = 0; ch < 4; ++ch) bacc[ch] += wb * c[k][ch];
  }
  for (int ch = 0; ch < 4; ++ch) o.colf[ch][i] = bacc[ch] / bsum * far[0];
  o.farh[i] = far[0];
  o.nearh[i] = near_tl;
  st.add(o.col[3][i], o.colf[3][i], far[0]);
}

// Even (x0 = 2i) and odd (x1 = 2i + 1) columns of the 16 values at p.
__attribute__((always_inline)) inline void deinterleave(const float* p, V8& even, V8& odd) {
  const V8 a = load8(p), b = load8(p + 8);
  even = __builtin_shufflevector(a, b, 0, 2, 4, 6, 8, 10, 12, 14);  // GCC >= 12 and clang
  odd = __builtin_shufflevector(a, b, 1, 3, 5, 7, 9, 11, 13, 15);
}

// quad() for 8 texels at once, lane by lane the same operations in the same order (the
// divisions, 11 per texel, are what made the scalar loop slow).
// The vector form of AlphaStats: lane-wise least / largest alpha and the or of the bit
// differences.
struct AlphaStats8 {
  V8 lo, hi;
  I8 diff = splat_i(0);
  bool any = false;
  __attribute__((always_inline)) void add(V8 a, V8 af, V8 f) {
    lo = any ? (a < lo ? a : lo) : a;
    hi = any ? (hi < a ? a : hi) : a;
    any = true;
    diff |= reinterpret_cast<I8>(af) ^ reinterpret_cast<I8>(f);
  }
  void into(AlphaStats& st) const {
    if (!any) return;
    for (int k = 0; k < 8; ++k) {
      st.lo = st.any ? std::min(st.lo, lo[k]) : lo[k];
      st.hi = st.any ? std::max(st.hi, hi[k]) : hi[k];
      st.any = true;
      st.far_differs = st.far_differs || diff[k] != 0;
    }
  }
};

template <bool kKaris>
__attribute__((always_inline)) inline void quad8(const V8 (&c)[4][4], const V8 (&far)[4], V8 near_tl, const QuadOut& o,
                                                 int i, AlphaStats8& st) {
  const V8 zero = splat(0.0f), one = splat(1.0f);
  V8 wk[4];
  for (int k = 0; k < 4; ++k) {
    if (kKaris) {
      const V8 l = splat(0.2126f) * c[k][0] + splat(0.7152f) * c[k][1] + splat(0.0722f) * c[k][2];
      wk[k] = one / (one + (zero < l ? l : zero));  // std::max(0, l): NaN → 0
    } else {
      wk[k] = one;
    }
  }
  V8 wsum = zero, acc[4] = {zero, zero, zero, zero};
  for (int k = 0; k < 4; ++k) {
    wsum += wk[k];
    for (int ch = 0; ch < 4; ++ch) acc[ch] += wk[k] * c[k][ch];
  }
  // Without Karis wsum is 4 exactly, and x/4 = x·¼ exactly (both are the rounded x/4).
  V8 col[4];
  for (int ch = 0; ch < 4; ++ch) {
    col[ch] = kKaris ? acc[ch] / wsum : acc[ch] * splat(0.25f);
    store8(o.col[ch] + i, col[ch]);
  }
  V8 bsum = zero, bacc[4] = {zero, zero, zero, zero};
  // 1/(|Δfar| + 0.001) is 1/0.001f where Δfar = 0 (flat far field, or in focus): the same
  // rounded quotient, so the division is skipped for vectors with Δfar = 0 in every lane.
  const V8 flat = splat(1.0f / 0.001f);
  for (int k = 0; k < 4; ++k) {
    V8 wraw = splat(1000.0f);
    if (k > 0) {
      const V8 d = vabs(far[k] - far[0]);
      wraw = any(d != zero) ? one / (d + splat(0.001f)) : flat;
    }
    const V8 wb = wraw * wk[k];
    bsum += wb;
    for (int ch = 0; ch < 4; ++ch) bacc[ch] += wb * c[k][ch];
  }
  V8 colf3 = zero;
  for (int ch = 0; ch < 4; ++ch) {
    const V8 v = bacc[ch] / bsum * far[0];
    store8(o.colf[ch] + i, v);
    if (ch == 3) colf3 = v;
  }
  store8(o.farh + i, far[0]);
  store8(o.nearh + i, near_tl);
  st.add(col[3], colf3, far[0]);
}

// The sanitation test of render/sanitize.hpp (sample_is_sanitary) for 8 samples at a time,
// as integer maxima and minima of the bit patterns b accumulated over a row (4 vector ops per
// vector of samples, against 7 for the float comparisons; exact, and in any order).
// Non-negative floats order like their bit patterns as signed ints, and
//  * colour: with k = b & 0x7fffffff (the bits of |v|), v passes iff k = 0 or
//    bits(FLT_MIN) = 0x800000 <= k <= bits(kMaxColorValue). The upper bound (which also catches
//    inf and NaN, whose k exceed inf's 0x7f800000) is a signed max of k. The lower one is an
//    unsigned min of k − 1: k = 0 wraps to 0xffffffff and never lowers the min, denormals
//    (1 <= k < 0x800000) give values below 0x7fffff, normal numbers give >= 0x7fffff;
//  * alpha: v passes iff b = 0 (+0), b = 0x80000000 (−0) or 0x800000 <= b <= bits(1). A signed
//    max of b catches b > bits(1) with the sign clear (+inf, +NaN, > 1); the unsigned min of
//    b − 1 catches positive denormals as above (negative b give >= 0x7fffffff); a signed min
//    of b − 1 catches every negative b but −0: b − 1 is then in [INT_MIN, −2], while +0 gives −1
//    and −0 wraps to INT_MAX.
struct SampleCheck8 {
  typedef unsigned U8 __attribute__((vector_size(32)));
  static constexpr int kMaxColourBits = std::bit_cast<int>(kMaxColorValue);
  static constexpr int kOneBits = std::bit_cast<int>(1.0f);
  I8 colour_max = splat_i(0), alpha_max = splat_i(0), signed_min = splat_i(0);
  U8 unsigned_min = reinterpret_cast<U8>(splat_i(-1));

  __attribute__((always_inline)) void colour(V8 v) {
    const I8 k = reinterpret_cast<I8>(v) & splat_i(0x7fffffff);
    const U8 km1 = reinterpret_cast<U8>(k) - 1u;
    colour_max = k > colour_max ? k : colour_max;
    unsigned_min = km1 < unsigned_min ? km1 : unsigned_min;
  }
  __attribute__((always_inline)) void alpha(V8 v) {
    const I8 b = reinterpret_cast<I8>(v);
    const U8 bm1 = reinterpret_cast<U8>(b) - 1u;
    const I8 sbm1 = reinterpret_cast<I8>(bm1);
    alpha_max = b > alpha_max ? b : alpha_max;
    unsigned_min = bm1 < unsigned_min ? bm1 : unsigned_min;
    signed_min = sbm1 < signed_min ? sbm1 : signed_min;
  }
  __attribute__((always_inline)) bool clean() const {
    const U8 min_normal_m1 = reinterpret_cast<U8>(splat_i(0x7fffff));
    return !any((colour_max > splat_i(kMaxColourBits)) | (alpha_max > splat_i(kOneBits)) |
                reinterpret_cast<I8>(unsigned_min < min_normal_m1) | (signed_min < splat_i(-1)));
  }
};

// kCheck: the downsample is the first pass that reads the colour, and it reads every sample
// (see prepare), so it also makes render()'s sanitation test when render() left that to the
// method. Returns false if some sample read fails it (always true without kCheck). The test
// only accumulates: nothing the row computes or reads depends on it.
template <bool kKaris, bool kCheck>
STERNA_SIMD bool downsample_row(const float* const* r0, const float* const* r1, const float* __restrict f0,
                                const float* __restrict f1, const float* __restrict n0, const QuadOut& o, int W, int w,
                                AlphaStats& alpha) {
  SampleCheck8 check;
  AlphaStats8 alpha8;
  int i = 0;
  // Whole quads (2i + 1 < W), 8 texels = 16 full-res columns at a time.
  for (; i + 8 <= W / 2; i += 8) {
    const int x = 2 * i;
    V8 c[4][4], far[4], nodd, ntl;
    for (int ch = 0; ch < 4; ++ch) {
      deinterleave(r0[ch] + x, c[0][ch], c[1][ch]);
      deinterleave(r1[ch] + x, c[2][ch], c[3][ch]);
    }
    if (kCheck)
      for (int k = 0; k < 4; ++k) {
        for (int ch = 0; ch < 3; ++ch) check.colour(c[k][ch]);
        check.alpha(c[k][3]);
      }
    deinterleave(f0 + x, far[0], far[1]);
    deinterleave(f1 + x, far[2], far[3]);
    deinterleave(n0 + x, ntl, nodd);
    quad8<kKaris>(c, far, ntl, o, i, alpha8);
  }
  bool clean = !kCheck || check.clean();
  alpha8.into(alpha);
  for (; i < w; ++i) {
    // With an odd width the last quad repeats the edge column (x1 = x0 = W - 1): the edge
    // column is still read (and checked), twice.
    const int x0 = 2 * i, x1 = std::min(2 * i + 1, W - 1);
    float c[4][4], far[4];
    for (int ch = 0; ch < 4; ++ch) {
      c[0][ch] = r0[ch][x0];
      c[1][ch] = r0[ch][x1];
      c[2][ch] = r1[ch][x0];
      c[3][ch] = r1[ch][x1];
    }
    if (kCheck)
      for (int k = 0; k < 4; ++k)
        for (int ch = 0; ch < 4; ++ch) clean &= sample_is_sanitary(c[k][ch], ch == 3);
    far[0] = f0[x0];
    far[1] = f0[x1];
    far[2] = f1[x0];
    far[3] = f1[x1];
    quad<kKaris>(c, far, n0[x0], o, i, alpha);
  }
  return clean;
}

// v = 0 where v < 1e-6 (the box sums' residue of a zero neighbourhood), as a select.
STERNA_SIMD void flush_residue(float* __restrict v, int n) {
  for (int x = 0; x < n; ++x) v[x] = v[x] < 1e-6f ? 0.0f : v[x];
}

// Thread-local scratch rows (grown once, reused every frame).
std::vector<float>& scratch(int slot, std::size_t n) {
  thread_local std::vector<float> bufs[4];
  if (bufs[slot].size() < n) bufs[slot].resize(n);
  return bufs[slot];
}

// Van Herk block prefix (pre) and suffix (suf) maxima of one block of k rows along y.
STERNA_SIMD void max_rows(float* __restrict dst, const float* __restrict a, const float* __restrict b, int n) {
  for (int x = 0; x < n; ++x) dst[x] = std::max(a[x], b[x]);
}

// Plain row max of near_coc_dilate.cpp (stride 1).
void max_line(const float* in, float* out, int n, int r, std::vector<float>& buf) {
  const int k = 2 * r + 1;
  const int len = n + 2 * r;
  const int blocks = (len + k - 1) / k;
  const int padded = blocks * k;
  if (buf.size() < static_cast<std::size_t>(3) * padded) buf.resize(static_cast<std::size_t>(3) * padded);
  float* a = buf.data();
  float* pre = a + padded;
  float* suf = pre + padded;
  std::fill(a, a + r, 0.0f);
  std::copy(in, in + n, a + r);
  std::fill(a + r + n, a + padded, 0.0f);
  for (int b = 0; b < padded; b += k) {
    pre[b] = a[b];
    for (int i = b + 1; i < b + k; ++i) pre[i] = std::max(pre[i - 1], a[i]);
    suf[b + k - 1] = a[b + k - 1];
    for (int i = b + k - 2; i >= b; --i) suf[i] = std::max(suf[i + 1], a[i]);
  }
  for (int x = 0; x < n; ++x) out[x] = std::max(suf[x], pre[x + 2 * r]);
}

// The same row max by a sparse table: with p the largest power of two ≤ k = 2r + 1, the max
// over a window of k equals the max of the two length-p blocks at its two ends, and length-p
// block maxima take log2(p) passes of pairwise maxima (each pass doubles the block). Every
// pass is an element-wise loop (vectorised), against the three dependent scans of max_line.
// Max of non-negative finite values (near factors, +0 never −0) is exact in any order, so the
// result equals max_line's.
STERNA_SIMD void max_pass(float* __restrict dst, const float* __restrict src, int s, int n) {
  for (int i = 0; i < n; ++i) dst[i] = std::max(src[i], src[i + s]);
}

void max_line_blocks(const float* in, float* out, int n, int r, std::vector<float>& buf) {
  const int k = 2 * r + 1;
  int p = 1;
  while (2 * p <= k) p *= 2;
  const int len = n + 2 * r;  // padded row: r zeros, the row, r zeros
  const std::size_t stride = static_cast<std::size_t>(len) + p;
  if (buf.size() < 2 * stride) buf.resize(2 * stride);
  float* cur = buf.data();
  float* nxt = cur + stride;
  std::fill(cur, cur + r, 0.0f);
  std::copy(in, in + n, cur + r);
  std::fill(cur + r + n, cur + stride, 0.0f);
  std::fill(nxt + len, nxt + stride, 0.0f);
  for (int s = 1; s < p; s *= 2) {  // cur[i] = max over [i, i + s) → nxt[i] = max over [i, i + 2s)
    max_pass(nxt, cur, s, len);
    std::swap(cur, nxt);
  }
  max_pass(out, cur, k - p, n);  // window [x, x + k) of the padded row = [x − r, x + r]
}

}  // namespace

void BlendRow::init(const MethodContext& c, const Settings& s) {
  ctx = &c;
  const NearFarBlend* m = std::get_if<NearFarBlend>(&c.camera.model);
  nfb = m != nullptr;
  nb = m ? m->near_begin_m : 0.0;
  ne = m ? m->near_end_m : 0.0;
  fb = m ? m->far_begin_m : 0.0;
  fe = m ? m->far_end_m : 0.0;
  ramp = std::max(s.blend_radius_px - 0.5f, 1e-3f);
}

void BlendRow::operator()(int y, float* near, float* far) const {
  const int W = ctx->frame.width();
  if (nfb)
    blend_from_z(ctx->frame.depth.row(0, y), near, far, W, nb, ne, fb, fe);
  else
    blend_from_coc(ctx->coc.row(0, y), near, far, W, ramp);
}

bool prepare(const MethodContext& ctx, const Settings& s, Buffers& b) {
  const Image& color = ctx.frame.color;
  const int W = b.W, H = b.H, w = b.w, h = b.h, pad = b.pad;
  BlendRow blend;
  blend.init(ctx, s);
  // Every colour sample is read here: row j reads full-res rows 2j and min(2j + 1, H − 1),
  // so rows 0 … H − 1 over j < h = ⌈H/2⌉; downsample_row reads columns 2i and
  // min(2i + 1, W − 1) for i < w = ⌈W/2⌉ (vector quads then the scalar tail), so columns
  // 0 … W − 1. The sanitation check rides on it (check_colour); each chunk clears the shared
  // flag, so the answer does not depend on the split.
  const bool check_colour = ctx.colour_dirty != nullptr;
  std::atomic<bool> sanitary{true};
  core::parallel_for(
      h,
      [&](int j0, int j1) {
        float* n0 = scratch(0, W).data();
        float* f0 = scratch(1, W).data();
        float* f1 = scratch(2, W).data();
        bool clean = true;
        for (int j = j0; j < j1; ++j) {
          const int y0 = 2 * j, y1 = clampi(2 * j + 1, 0, H - 1);
          blend(y0, n0, f0);
          blend(y1, nullptr, f1);
          const float* r0[4];
          const float* r1[4];
          QuadOut o;
          for (int ch = 0; ch < 4; ++ch) {
            r0[ch] = color.row(ch, y0);
            r1[ch] = color.row(ch, y1);
            o.col[ch] = b.src_row(*b.near_src, ch, j);
            o.colf[ch] = b.src_row(*b.far_src, ch, j);
          }
          o.farh = b.src_row(*b.far_src, 4, j);
          o.nearh = b.near_h->row(0, j);
          AlphaStats alpha;
          if (check_colour)
            clean &= s.karis ? downsample_row<true, true>(r0, r1, f0, f1, n0, o, W, w, alpha)
                             : downsample_row<false, true>(r0, r1, f0, f1, n0, o, W, w, alpha);
          else if (s.karis)
            downsample_row<true, false>(r0, r1, f0, f1, n0, o, W, w, alpha);
          else
            downsample_row<false, false>(r0, r1, f0, f1, n0, o, W, w, alpha);
          (*b.alpha_rows)[j] = {alpha.lo, alpha.hi, alpha.far_differs};
        }
        if (!clean) sanitary.store(false, std::memory_order_relaxed);
      },
      4);
  if (!sanitary.load()) return false;  // the caller renders again from sanitised colour
  // Edge replication into the border (rows first read their finished interior row).
  const int pw = w + 2 * pad, ph = h + 2 * pad;
  core::parallel_for(
      ph,
      [&](int p0, int p1) {
        for (int py = p0; py < p1; ++py) {
          const int y = clampi(py - pad, 0, h - 1);
          for (Image* img : {b.near_src, b.far_src})
            for (int c = 0; c < img->channels(); ++c) {
              float* d = img->row(c, py);
              const float* srow = img->row(c, y + pad);
              if (py != y + pad) std::copy(srow + pad, srow + pad + w, d + pad);
              std::fill(d, d + pad, srow[pad]);
              std::fill(d + pad + w, d + pw, srow[pad + w - 1]);
            }
        }
      },
      16);
  return true;
}

void dilate(const Settings& s, Buffers& b) {
  const int w = b.w, h = b.h, r = s.dilate_radius;
  float* nb = b.near_blur->plane(0);
  if (r <= 0) {
    std::copy(b.near_h->plane(0), b.near_h->plane(0) + b.near_h->plane_size(), nb);
    return;
  }
  // P3: max along x, per row.
  core::parallel_for(
      h,
      [&](int y0, int y1) {
        std::vector<float>& buf = scratch(3, 0);
        for (int y = y0; y < y1; ++y) max_line_blocks(b.near_h->row(0, y), b.tmp->row(0, y), w, r, buf);
      },
      8);
  // P4: max along y. Padded row index p in [0, P) holds row p - r (zero outside the image);
  // each block of k rows gets its prefix maxima (pre) and suffix maxima (suf), and row y is
  // max(suf[y], pre[y + 2r]). The gather has not run yet, so the two field planes (4·h rows
  // each) serve as pre and suf; a kernel too large for them (P > 4h) walks columns instead.
  const int k = 2 * r + 1;
  const int len = h + 2 * r;
  const int blocks = (len + k - 1) / k;
  const int P = blocks * k;
  Image& pre = *b.dof_near;
  Image& suf = *b.dof_far;
  auto row_of = [&](Image& img, int p) { return img.plane(0) + static_cast<std::size_t>(p) * w; };
  if (P <= 4 * h) {
    std::vector<float>& zrow = scratch(3, static_cast<std::size_t>(w));
    std::fill(zrow.begin(), zrow.begin() + w, 0.0f);
    auto a_row = [&](int p) -> const float* {
      const int y = p - r;
      return (y >= 0 && y < h) ? b.tmp->row(0, y) : zrow.data();
    };
    core::parallel_for(blocks, [&](int b0, int b1) {
      for (int bl = b0; bl < b1; ++bl) {
        const int s0 = bl * k;
        std::copy(a_row(s0), a_row(s0) + w, row_of(pre, s0));
        for (int p = s0 + 1; p < s0 + k; ++p) max_rows(row_of(pre, p), row_of(pre, p - 1), a_row(p), w);
        std::copy(a_row(s0 + k - 1), a_row(s0 + k - 1) + w, row_of(suf, s0 + k - 1));
        for (int p = s0 + k - 2; p >= s0; --p) max_rows(row_of(suf, p), row_of(suf, p + 1), a_row(p), w);
      }
    });
    core::parallel_for(
        h,
        [&](int y0, int y1) {
          for (int y = y0; y < y1; ++y)
            max_rows(nb + static_cast<std::size_t>(y) * w, row_of(suf, y), row_of(pre, y + 2 * r), w);
        },
        8);
  } else {
    core::parallel_for(
        w,
        [&](int x0, int x1) {
          std::vector<float>& buf = scratch(3, 0);
          std::vector<float>& col = scratch(2, 2 * static_cast<std::size_t>(h));
          for (int x = x0; x < x1; ++x) {
            for (int y = 0; y < h; ++y) col[y] = b.tmp->row(0, y)[x];
            max_line(col.data(), col.data() + h, h, r, buf);
            for (int y = 0; y < h; ++y) nb[static_cast<std::size_t>(y) * w + x] = col[h + y];
          }
        },
        16);
  }
  // P5/P6: box mean over the same window, then flush the running-sum residue (as plain), row
  // by row in parallel (as one serial loop over the plane it took 0.24 ms of a 1080p frame on
  // either thread count).
  core::box_blur_plane(nb, nb, w, h, r, r);
  core::parallel_for(
      h,
      [&](int y0, int y1) {
        for (int y = y0; y < y1; ++y) flush_residue(nb + static_cast<std::size_t>(y) * w, w);
      },
      16);
}

}  // namespace dofkit::detail::sterna::fast
