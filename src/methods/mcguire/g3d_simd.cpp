// Highway kernels of the g3d dual blur (g3d.hpp; run-time dispatch: AVX-512 / AVX2 / SSE4 /
// scalar). Each output vector holds `lanes` adjacent outputs; the tap loop runs inside it,
// so the per-lane accumulation order is the plain pass's δ order (centre tap first here,
// and FMA: rounding differs from the plain pass by a few ulp per tap).
//
// Far weight in base 2: exp(−2δ²/(0.01 + |r_B|)²) = 2^(δ²·q_B) with the per-source
// q_B = −2·log2(e)/(0.01 + |r_B|)² (near sources store −1e30: weight 0 for every δ ≠ 0; the
// centre tap δ = 0 is added outside the loop with weight 1, which is what the plain pass's
// wn + (1 − wn)·nearness gives for δ = 0 on both a far and a near centre).
#include "methods/mcguire/g3d.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "methods/mcguire/g3d_simd.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace dofkit::detail::mcguire {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// 2^t for t <= 0; exactly 0 for t < kG3dExp2Min. t = n + x with n = round(t) (1.5·2^23
// added and subtracted rounds to an integer and leaves it in the low mantissa bits) and
// |x| <= 1/2; 2^x from a degree-5 minimax polynomial (fitted by Remez exchange on relative
// error: 7.5e-8, 2.3e-7 with float rounding) evaluated in Estrin's form — its dependency
// chain is three FMAs long instead of five, and the chain from the tap's q to its weight is
// what limits how many taps the core overlaps. 2^n is built in the exponent field. The
// cut-off keeps every weight >= 2^-100, far from the subnormal range where products with
// the colour would be slow, and is what lets whole taps be skipped.
template <class D, class V = hn::Vec<D>>
HWY_INLINE V Exp2Neg(D d, V t) {
  const hn::RebindToSigned<D> di;
  const auto magic = hn::Set(d, 12582912.0f);
  const auto r = hn::Add(t, magic);
  const auto x = hn::Sub(t, hn::Sub(r, magic));
  const auto x2 = hn::Mul(x, x);
  const auto p01 = hn::MulAdd(hn::Set(d, 0.6931469440460205f), x, hn::Set(d, 1.0000001192092896f));
  const auto p23 = hn::MulAdd(hn::Set(d, 0.05550713092088699f), x, hn::Set(d, 0.24022120237350464f));
  const auto p45 = hn::MulAdd(hn::Set(d, 0.0013276472454890609f), x, hn::Set(d, 0.009675540961325169f));
  const auto p = hn::MulAdd(x2, hn::MulAdd(x2, p45, p23), p01);
  // bits(r) = bits(magic) + n; the float 2^n has bits (n + 127) << 23.
  const auto e = hn::ShiftLeft<23>(hn::Sub(hn::BitCast(di, r), hn::Set(di, 0x4B400000 - 127)));
  return hn::IfThenZeroElse(hn::Lt(t, hn::Set(d, kG3dExp2Min)), hn::Mul(p, hn::BitCast(d, e)));
}

constexpr float kNearQ = -1e30f;  // q of a near-field source: 2^(δ²·q) = 0 for every δ ≠ 0
constexpr float kLog2e = 1.44269504088896340736f;

// Per-source far-weight data: q (see top), r px, 1/(0.01 + |r|), α = saturate(r/R_near)².
template <class D>
HWY_INLINE void SourceData(D d, const G3dParams& p, hn::Vec<D> s, hn::Vec<D>& q, hn::Vec<D>& r, hn::Vec<D>& ib,
                           hn::Vec<D>& alpha) {
  const auto zero = hn::Zero(d), one = hn::Set(d, 1.0f);
  r = hn::Mul(s, hn::Set(d, p.rmax));
  ib = hn::Div(one, hn::Add(hn::Set(d, 0.01f), hn::Abs(r)));
  q = hn::Mul(hn::Mul(ib, ib), hn::Set(d, -2.0f * kLog2e));
  q = hn::IfThenElse(hn::Gt(r, hn::Set(d, 0.25f)), hn::Set(d, kNearQ), q);  // in_near(r)
  const auto a = hn::Min(hn::Max(hn::Mul(r, hn::Set(d, p.inv_near)), zero), one);
  alpha = hn::Mul(a, a);
}

// Both passes gather from a block of 12 equally spaced planes (stride ps elements):
//   0-3  colour R, G, B, A of the far/focus input   4  q   5  r (px)   6  1/(0.01 + |r|)
//   7-10 near input α·R, α·G, α·B, α·A              11 near input α
// laid out so that tap δ of the output vector's lane l is element off[δ] + l of each plane
// (relative to the vector's own base pointer).
enum Plane { kCol = 0, kQ = 4, kR = 5, kIb = 6, kNear = 7, kAlpha = 11, kPlanes = 12 };

// Far/focus sum of one output vector (taps δ = −R … R; off indexed by δ + R). kMode:
// 0 = every centre far/focus (nearness 0: w = wn; taps that are 0 in every lane skipped),
// 1 = mixed (w = lerp(wn, 1, nearness)), 2 = every centre near (nearness 1: w = 1, a box).
template <int kMode, bool kOcc, class D>
HWY_INLINE void FarSum(D d, int R, const float* d2, hn::Vec<D> ra, hn::Vec<D> n, const float* base, const int* off,
                       std::size_t ps, hn::Vec<D> out[4]) {
  const auto zero = hn::Zero(d), one = hn::Set(d, 1.0f);
  const float* c = base + off[R];
  auto a0 = hn::LoadU(d, c), a1 = hn::LoadU(d, c + ps), a2 = hn::LoadU(d, c + 2 * ps), a3 = hn::LoadU(d, c + 3 * ps);
  auto aw = one;
  const auto c1 = hn::Sub(one, ra), c2 = hn::Sub(hn::Set(d, 0.01f), ra);
  const auto tmin = hn::Set(d, kG3dExp2Min);
  for (int delta = -R; delta <= R; ++delta) {
    if (delta == 0) continue;
    const float* t0 = base + off[delta + R];
    if (kMode == 2) {
      a0 = hn::Add(a0, hn::LoadU(d, t0));
      a1 = hn::Add(a1, hn::LoadU(d, t0 + ps));
      a2 = hn::Add(a2, hn::LoadU(d, t0 + 2 * ps));
      a3 = hn::Add(a3, hn::LoadU(d, t0 + 3 * ps));
      continue;
    }
    const auto t = hn::Mul(hn::LoadU(d, t0 + kQ * ps), hn::Set(d, d2[delta + R]));
    if (kMode == 0 && hn::AllTrue(d, hn::Lt(t, tmin))) continue;
    auto w = Exp2Neg(d, t);
    if (kOcc) {
      auto occ = hn::Max(hn::Add(hn::LoadU(d, t0 + kR * ps), c1), hn::Mul(c2, hn::LoadU(d, t0 + kIb * ps)));
      // Far centres (r_A <= 0): (0.01 − r_A)·ib > 0, so only the upper clamp can act.
      occ = kMode == 0 ? hn::Min(occ, one) : hn::Min(hn::Max(occ, zero), one);
      w = hn::Mul(w, occ);
    }
    if (kMode == 1) w = hn::MulAdd(hn::Sub(one, w), n, w);
    a0 = hn::MulAdd(w, hn::LoadU(d, t0), a0);
    a1 = hn::MulAdd(w, hn::LoadU(d, t0 + ps), a1);
    a2 = hn::MulAdd(w, hn::LoadU(d, t0 + 2 * ps), a2);
    a3 = hn::MulAdd(w, hn::LoadU(d, t0 + 3 * ps), a3);
    aw = hn::Add(aw, w);
  }
  if (kMode == 2) aw = hn::Set(d, static_cast<float>(2 * R + 1));
  out[0] = hn::Div(a0, aw);
  out[1] = hn::Div(a1, aw);
  out[2] = hn::Div(a2, aw);
  out[3] = hn::Div(a3, aw);
}

template <class D>
HWY_INLINE void FarDispatch(D d, const G3dParams& p, const float* base, const int* off, std::size_t ps,
                            hn::Vec<D> out[4]) {
  const auto zero = hn::Zero(d), one = hn::Set(d, 1.0f);
  const auto ra = hn::LoadU(d, base + off[p.R] + kR * ps);
  const auto n = hn::Min(hn::Max(hn::Mul(hn::Set(d, 4.0f), ra), zero), one);  // nearness = saturate(4 r_A)
  const int R = p.R;
  if (hn::AllTrue(d, hn::Eq(n, zero))) {
    if (p.occlusion)
      FarSum<0, true>(d, R, p.d2_tab, ra, n, base, off, ps, out);
    else
      FarSum<0, false>(d, R, p.d2_tab, ra, n, base, off, ps, out);
  } else if (hn::AllTrue(d, hn::Eq(n, one))) {
    FarSum<2, false>(d, R, p.d2_tab, ra, n, base, off, ps, out);
  } else {
    if (p.occlusion)
      FarSum<1, true>(d, R, p.d2_tab, ra, n, base, off, ps, out);
    else
      FarSum<1, false>(d, R, p.d2_tab, ra, n, base, off, ps, out);
  }
}

// Near sum Σ_δ near_box(δ)·(α·RGBA, α) times the normaliser; taps whose α is 0 in every
// lane are exact zeros and skipped. Even and odd taps go to separate accumulators (two
// independent FMA chains), added at the end.
// Only taps k (= δ + R) in [k0, k1) are visited: the caller's bound on where α can be
// nonzero.
template <class D>
HWY_INLINE void NearSum(D d, const G3dParams& p, const float* base, const int* off, std::size_t ps, int k0, int k1,
                        hn::Vec<D> out[5]) {
  using V = hn::Vec<D>;
  const auto zero = hn::Zero(d);
  V acc[2][5];
  for (auto& set : acc)
    for (auto& v : set) v = zero;
  auto tap = [&](V* a, int k) {
    const float v = p.near_tab[k];
    if (v == 0.0f) return;
    const float* t0 = base + off[k] + kNear * ps;
    const auto al = hn::LoadU(d, t0 + 4 * ps);
    if (hn::AllTrue(d, hn::Eq(al, zero))) return;
    const auto vv = hn::Set(d, v);
    a[0] = hn::MulAdd(vv, hn::LoadU(d, t0), a[0]);
    a[1] = hn::MulAdd(vv, hn::LoadU(d, t0 + ps), a[1]);
    a[2] = hn::MulAdd(vv, hn::LoadU(d, t0 + 2 * ps), a[2]);
    a[3] = hn::MulAdd(vv, hn::LoadU(d, t0 + 3 * ps), a[3]);
    a[4] = hn::MulAdd(vv, al, a[4]);
  };
  int k = k0;
  for (; k + 1 < k1; k += 2) {
    tap(acc[0], k);
    tap(acc[1], k + 1);
  }
  if (k < k1) tap(acc[0], k);
  const auto inv = hn::Set(d, p.near_inv);
  for (int c = 0; c < 5; ++c) out[c] = hn::Mul(hn::Add(acc[0][c], acc[1][c]), inv);
}

// ---------------------------------------------------------------------------------------
// P2. The row is padded by R replicated edge pixels each side (padded x = packed x + R) and
// split by phase: element m of phase ph holds padded pixel f·m + ph, so output i's tap δ,
// padded x = ox + R + δ + f·i, is element u/f + i of phase u mod f with u = ox + R + δ —
// adjacent outputs read adjacent elements. Plane k, phase ph starts at k·ps + ph·Mp.
void HorizontalRow(const G3dParams& p, const G3dRowJob& job, std::vector<float>& scratch) {
  const hn::ScalableTag<float> d;
  const hn::CappedTag<float, 1> d1;
  const int lanes = static_cast<int>(hn::Lanes(d));
  const int R = p.R, f = p.f, W = job.W, wo = job.wo, ox = job.ox;
  // Elements per phase: every tap read, rounded up to whole vectors (the phase split below
  // stores whole vectors).
  const int Mp = ((ox + 2 * R) / f + wo + 1 + lanes - 1) / lanes * lanes;
  const std::size_t len = static_cast<std::size_t>(Mp) * f;  // padded length handled
  // Plane stride: one cache line more than a multiple of 16 floats, so that the planes do not
  // all start at the same offset modulo 4 KiB (same L1 sets; Mp is often a power of 2).
  const std::size_t ps = (len + 15) / 16 * 16 + 16;
  const std::size_t n_off = 2 * static_cast<std::size_t>(R) + 1;
  const int nin = f == 1 ? 0 : 5;  // padded input rows (f = 1: the planes themselves)
  scratch.resize((kPlanes + nin) * ps + n_off + static_cast<std::size_t>(f) * lanes);
  float* planes = scratch.data();
  float* pad = planes + kPlanes * ps;
  int* off = reinterpret_cast<int*>(pad + nin * ps);  // int and float have the same size and alignment
  static_assert(sizeof(int) == sizeof(float) && alignof(int) == alignof(float));
  for (int delta = -R; delta <= R; ++delta) {
    const int u = ox + R + delta;
    off[delta + R] = (u % f) * Mp + u / f;
  }

  // 1. Padded rows of colour and s (padded x = packed x + R, edge pixels replicated; len
  //    elements). f = 1: straight into the planes (s into the q plane).
  const int dst_plane[5] = {kCol, kCol + 1, kCol + 2, kCol + 3, kQ};
  for (int c = 0; c < 5; ++c) {
    float* row = f == 1 ? planes + dst_plane[c] * ps : pad + c * ps;
    const float* src = job.src[c];
    const std::size_t left = std::min<std::size_t>(R, len);
    std::fill_n(row, left, src[0]);
    const std::size_t mid = std::min<std::size_t>(W, len - left);
    std::copy_n(src, mid, row + left);
    std::fill_n(row + left + mid, len - left - mid, src[W - 1]);
  }
  // 2. Phase split: padded x = f·m + ph → element m of phase ph.
  if (f > 1)
    for (int c = 0; c < 5; ++c) {
      const float* in = pad + c * ps;
      float* o = planes + dst_plane[c] * ps;
      for (int m = 0; m < Mp; m += lanes) {
        hn::Vec<decltype(d)> v0, v1, v2, v3;
        if (f == 2) {
          hn::LoadInterleaved2(d, in + 2 * m, v0, v1);
          hn::StoreU(v0, d, o + m);
          hn::StoreU(v1, d, o + Mp + m);
        } else if (f == 3) {
          hn::LoadInterleaved3(d, in + 3 * m, v0, v1, v2);
          hn::StoreU(v0, d, o + m);
          hn::StoreU(v1, d, o + Mp + m);
          hn::StoreU(v2, d, o + 2 * Mp + m);
        } else {
          hn::LoadInterleaved4(d, in + 4 * m, v0, v1, v2, v3);
          hn::StoreU(v0, d, o + m);
          hn::StoreU(v1, d, o + Mp + m);
          hn::StoreU(v2, d, o + 2 * Mp + m);
          hn::StoreU(v3, d, o + 3 * Mp + m);
        }
      }
    }
  // 3. Per-source data in place of s (every element of every phase, contiguous).
  //    [alo, ahi]: a padded x range outside which α = 0 (α > 0 needs s > 0; found on the
  //    padded s row, so the edge padding is included).
  bool any_alpha = false;
  int alo = 0, ahi = -1;
  if (p.near_tab) {
    const float* srow = f == 1 ? planes + kQ * ps : pad + 4 * ps;
    const int P = static_cast<int>(std::min<std::size_t>(W + 2 * R, len));  // taps never read beyond len
    int first = P;
    for (int x = 0; x < P; ++x)
      if (srow[x] > 0.0f) {
        first = x;
        break;
      }
    if (first < P) {
      int last = P - 1;
      while (!(srow[last] > 0.0f)) --last;
      any_alpha = true;
      alo = first;
      ahi = last;
    }
  }
  for (std::size_t x = 0; x < len; x += lanes) {
    hn::Vec<decltype(d)> q, r, ib, al;
    SourceData(d, p, hn::LoadU(d, planes + kQ * ps + x), q, r, ib, al);
    hn::StoreU(q, d, planes + kQ * ps + x);
    hn::StoreU(r, d, planes + kR * ps + x);
    hn::StoreU(ib, d, planes + kIb * ps + x);
    if (any_alpha) {
      hn::StoreU(al, d, planes + kAlpha * ps + x);
      for (int c = 0; c < 4; ++c)
        hn::StoreU(hn::Mul(al, hn::LoadU(d, planes + (kCol + c) * ps + x)), d, planes + (kNear + c) * ps + x);
    }
  }

  auto block = [&](auto dd, int i0) {
    hn::Vec<decltype(dd)> out[5];
    FarDispatch(dd, p, planes + i0, off, ps, out);
    for (int c = 0; c < 4; ++c) hn::StoreU(out[c], dd, job.t_blur[c] + i0);
    if (any_alpha) {
      // Lane l of tap δ reads padded x = ox + R + δ + f·(i0 + l): only δ whose lanes meet
      // [alo, ahi] can be nonzero.
      const int x0 = ox + R + f * i0, span = f * (static_cast<int>(hn::Lanes(dd)) - 1);
      const int k0 = std::max(0, alo - span - x0 + R), k1 = std::min(2 * R + 1, ahi - x0 + R + 1);
      NearSum(dd, p, planes + i0, off, ps, k0, std::max(k0, k1), out);
      for (int c = 0; c < 5; ++c) hn::StoreU(out[c], dd, job.t_near[c] + i0);
    }
  };
  int i = 0;
  for (; i + lanes <= wo; i += lanes) block(d, i);
  for (; i < wo; ++i) block(d1, i);
  for (i = 0; i < wo; ++i) job.t_blur[4][i] = job.src[4][ox + f * i];
  if (!any_alpha)
    for (int c = 0; c < 5; ++c) std::fill_n(job.t_near[c], wo, 0.0f);
}

// ---------------------------------------------------------------------------------------
// P3, output rows [j0, j1) × columns [x_begin, x_end) (the caller passes blocks of about 64
// rows: fewer rows per block copy the 2R-row halo more often). Columns are taken in strips
// one vector wide. For each strip, the input rows the block reads (clamped to the image) are
// copied into a compact array (row r = input row lo + r: the 12 planes' values of the strip
// one after another), with q, r and 1/(0.01 + |r|) computed once per input pixel; the
// (2R + 1)-row tap windows of the outputs then read that small array in address order as δ
// grows (cache-, prefetch- and TLB-friendly) instead of ≈ 12·(2R + 1) image rows a page
// apart each.
void VerticalBlock(const G3dParams& p, const Image& tb, const Image& tn, int oy, int j0, int j1, int x_begin, int x_end,
                   Image& blur, Image& near, std::vector<float>& scratch) {
  const hn::ScalableTag<float> d;
  const hn::CappedTag<float, 1> d1;
  const int lanes = static_cast<int>(hn::Lanes(d));
  const int R = p.R, f = p.f, H = tb.height();
  const std::size_t n_off = 2 * static_cast<std::size_t>(R) + 1;
  const int lo = std::max(0, oy + f * j0 - R), hi = std::min(H - 1, oy + f * (j1 - 1) + R);
  const int nrows = hi - lo + 1;
  const int S = lanes;  // strip width: one vector
  const std::size_t ps = S, row_stride = kPlanes * ps;
  scratch.resize(row_stride * nrows + n_off);
  float* planes = scratch.data();
  int* off = reinterpret_cast<int*>(planes + row_stride * nrows);
  for (int x0 = x_begin; x0 < x_end; x0 += S) {
    const int sw = std::min(S, x_end - x0);
    bool any_alpha = false;
    for (int b = lo; b <= hi; ++b) {
      float* e = planes + static_cast<std::size_t>(b - lo) * row_stride;
      auto fill = [&](auto dd, int x) {
        for (int c = 0; c < 4; ++c) hn::StoreU(hn::LoadU(dd, tb.row(c, b) + x0 + x), dd, e + c * ps + x);
        hn::Vec<decltype(dd)> q, r, ib, al;
        SourceData(dd, p, hn::LoadU(dd, tb.row(4, b) + x0 + x), q, r, ib, al);
        hn::StoreU(q, dd, e + kQ * ps + x);
        hn::StoreU(r, dd, e + kR * ps + x);
        hn::StoreU(ib, dd, e + kIb * ps + x);
        if (p.near_tab) {
          for (int c = 0; c < 4; ++c) hn::StoreU(hn::LoadU(dd, tn.row(c, b) + x0 + x), dd, e + (kNear + c) * ps + x);
          const auto na = hn::LoadU(dd, tn.row(4, b) + x0 + x);
          hn::StoreU(na, dd, e + kAlpha * ps + x);
          any_alpha |= !hn::AllTrue(dd, hn::Eq(na, hn::Zero(dd)));
        }
      };
      if (sw == S)
        fill(d, 0);
      else
        for (int x = 0; x < sw; ++x) fill(d1, x);
    }
    for (int j = j0; j < j1; ++j) {
      const int a = oy + f * j;
      for (int delta = -R; delta <= R; ++delta)
        off[delta + R] = (std::clamp(a + delta, 0, H - 1) - lo) * static_cast<int>(row_stride);
      auto block = [&](auto dd, int i) {
        using DD = decltype(dd);
        hn::Vec<DD> out[5];
        FarDispatch(dd, p, planes + i, off, ps, out);
        for (int c = 0; c < 4; ++c) hn::StoreU(out[c], dd, blur.row(c, j) + x0 + i);
        if (!any_alpha) {
          for (int c = 0; c < 5; ++c) hn::StoreU(hn::Zero(dd), dd, near.row(c, j) + x0 + i);
          return;
        }
        NearSum(dd, p, planes + i, off, ps, 0, 2 * R + 1, out);
        // g3d coverage curve, exactly as g3d_coverage_curve() (blur_weights.hpp).
        const auto zero = hn::Zero(dd), one = hn::Set(dd, 1.0f);
        const auto al = out[4];
        const auto fa = hn::Mul(hn::Set(dd, p.fov_rad), al);
        const auto pos = hn::Gt(fa, zero);
        const auto t = hn::IfThenElseZero(
            pos, hn::Min(hn::Max(hn::Sub(one, hn::Div(hn::Set(dd, 0.025f), hn::IfThenElse(pos, fa, one))), zero), one));
        const auto a2 = hn::Min(hn::Mul(hn::Mul(t, t), hn::Sub(hn::Set(dd, 3.0f), hn::Mul(hn::Set(dd, 2.0f), t))), one);
        const auto apos = hn::Gt(al, zero);
        const auto g = hn::IfThenElseZero(apos, hn::Div(a2, hn::IfThenElse(apos, al, one)));
        for (int c = 0; c < 4; ++c) hn::StoreU(hn::Mul(out[c], g), dd, near.row(c, j) + x0 + i);
        hn::StoreU(a2, dd, near.row(4, j) + x0 + i);
      };
      int i = 0;
      for (; i + lanes <= sw; i += lanes) block(d, i);
      for (; i < sw; ++i) block(d1, i);
    }
  }
}

}  // namespace HWY_NAMESPACE
}  // namespace dofkit::detail::mcguire
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace dofkit::detail::mcguire {
HWY_EXPORT(HorizontalRow);
void g3d_horizontal_row(const G3dParams& p, const G3dRowJob& job, std::vector<float>& scratch) {
  HWY_DYNAMIC_DISPATCH(HorizontalRow)(p, job, scratch);
}
HWY_EXPORT(VerticalBlock);
void g3d_vertical_block(const G3dParams& p, const Image& t_blur, const Image& t_near, int oy, int j0, int j1, int x0,
                        int x1, Image& blur, Image& near, std::vector<float>& scratch) {
  HWY_DYNAMIC_DISPATCH(VerticalBlock)(p, t_blur, t_near, oy, j0, j1, x0, x1, blur, near, scratch);
}
}  // namespace dofkit::detail::mcguire
#endif  // HWY_ONCE
