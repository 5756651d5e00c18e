// Highway kernels of the fused Gaussian stack (declared in fused_simd.hpp). Every lane
// computes the plain form's expression for its pixel, operation for operation (separate
// multiply and add: this file is built with -ffp-contract=off, CMakeLists.txt), so a pixel
// gets the same bits whichever target runs and wherever its vector starts. Segment tails
// narrower than a vector run the same vector code on copies padded to a full vector.
#include "methods/layered/fused_simd.hpp"

#include <cstddef>
#include <cstdint>

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "methods/layered/fused_simd.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace dofkit::detail::layered {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// a · b rounded like the float multiply (the same bits) but without its microcode assist on
// subnormal operands or results (Intel: ~20× a normal multiply): the product of two floats
// is exact in double, so demoting it rounds the exact product once, as the float multiply
// does, gradual underflow included. For rows of an accumulator with subnormal tails (the
// ZeroMap's tiny blocks, fast_rows.hpp); kExact false is the plain multiply.
template <bool kExact, class D, class V>
HWY_INLINE V MulX(D d, V a, V b) {
#if HWY_TARGET == HWY_SCALAR
  (void)d;
  return hn::Mul(a, b);
#else
  if constexpr (!kExact) {
    (void)d;
    return hn::Mul(a, b);
  } else {
    const hn::Half<D> dh;
    const hn::Rebind<double, decltype(dh)> dw;
    const auto lo = hn::Mul(hn::PromoteTo(dw, hn::LowerHalf(dh, a)), hn::PromoteTo(dw, hn::LowerHalf(dh, b)));
    const auto hi = hn::Mul(hn::PromoteTo(dw, hn::UpperHalf(dh, a)), hn::PromoteTo(dw, hn::UpperHalf(dh, b)));
    return hn::Combine(d, hn::DemoteTo(dh, hi), hn::DemoteTo(dh, lo));
  }
#endif
}

// The row pointers of one crow segment (the tail points them at padded copies): the colour
// rows, and one pointer per four-channel row group (ft, fb, at, ab, c), channel ch at
// + S·ch (S = kRowStride, or the tail copies' stride).
struct CrowPtrs {
  const std::uint16_t* code;
  const float* w0;
  const float* in[4];
  const float* ft;
  const float* fb;
  const float* at;
  const float* ab;
  float* c;
};

// CrowRow's scalars, copied out of it into a local: Highway's vector stores may alias
// anything, so read through the CrowRow the compiler reloaded them (and recomputed the
// vectors made from them) for every vector of the loop.
struct CrowScalars {
  int k;
  float fty, aty;
  bool opaque, under;
};

template <bool M, bool H, bool FG, int AM, bool FRONT, int S>
HWY_INLINE void CrowVec(const CrowScalars& r, const CrowPtrs& p, std::size_t j) {
  const hn::ScalableTag<float> df;
  const hn::RebindToSigned<decltype(df)> di;
  const hn::Rebind<std::uint16_t, decltype(df)> dh;
  const auto zero = hn::Zero(df), one = hn::Set(df, 1.0f);
  auto m0 = zero, m1 = zero, m2 = zero, m3 = zero;
  decltype(hn::Zero(di)) cd;
  if constexpr (M || H)
    cd = hn::BitCast(di, hn::PromoteTo(hn::RebindToUnsigned<decltype(di)>(), hn::LoadU(dh, p.code + j)));
  if constexpr (M) {  // matting.cpp: 0 + (1 − 0)·w_k·I, w_k = w0 (j0 = k), 1 (second layer k), else 0
    const int k1 = r.k >= 1 ? ((r.k - 1) | 32) : 0xffff;
    const auto second =
        hn::IfThenElseZero(hn::RebindMask(df, hn::Eq(hn::And(cd, hn::Set(di, 63)), hn::Set(di, k1))), one);
    const auto wk = hn::IfThenElse(hn::RebindMask(df, hn::Eq(hn::And(cd, hn::Set(di, 31)), hn::Set(di, r.k))),
                                   hn::LoadU(df, p.w0 + j), second);
    m0 = hn::Add(zero, hn::Mul(wk, hn::LoadU(df, p.in[0] + j)));
    m1 = hn::Add(zero, hn::Mul(wk, hn::LoadU(df, p.in[1] + j)));
    m2 = hn::Add(zero, hn::Mul(wk, hn::LoadU(df, p.in[2] + j)));
    m3 = hn::Add(zero, hn::Mul(wk, hn::LoadU(df, p.in[3] + j)));
  }
  if constexpr (H) {  // inpaint.cpp at a hole (confidence 0): v = 0·v + 1·up, then its rules
    const auto hb = hn::RebindMask(df, hn::Gt(hn::Set(di, r.k + 1), hn::ShiftRight<6>(cd)));  // k >= hk
    const auto ty = hn::Set(df, r.fty);
    auto lerp = [&](int ch) {
      const auto t = hn::LoadU(df, p.ft + S * ch + j);
      return hn::Add(t, hn::Mul(hn::Sub(hn::LoadU(df, p.fb + S * ch + j), t), ty));
    };
    auto v0 = hn::Add(hn::Mul(zero, m0), lerp(0));
    auto v1 = hn::Add(hn::Mul(zero, m1), lerp(1));
    auto v2 = hn::Add(hn::Mul(zero, m2), lerp(2));
    auto v3 = hn::Add(hn::Mul(zero, m3), lerp(3));
    if constexpr (FG) {
      const auto norm =
          hn::And(hn::Gt(v3, hn::Set(df, 1e-6f)), r.opaque ? hn::FirstN(df, hn::Lanes(df)) : hn::FirstN(df, 0));
      const auto a = v3;
      v0 = hn::IfThenElse(norm, hn::Div(v0, a), v0);
      v1 = hn::IfThenElse(norm, hn::Div(v1, a), v1);
      v2 = hn::IfThenElse(norm, hn::Div(v2, a), v2);
      v3 = hn::IfThenElse(norm, one, v3);
      if (r.under) {
        const auto t = hn::Sub(one, m3);
        v0 = hn::Add(m0, hn::Mul(t, v0));
        v1 = hn::Add(m1, hn::Mul(t, v1));
        v2 = hn::Add(m2, hn::Mul(t, v2));
        v3 = hn::Add(m3, hn::Mul(t, v3));
      }
    }
    m0 = hn::IfThenElse(hb, v0, m0);
    m1 = hn::IfThenElse(hb, v1, m1);
    m2 = hn::IfThenElse(hb, v2, m2);
    m3 = hn::IfThenElse(hb, v3, m3);
  }
  if constexpr (AM == 0) {
    hn::StoreU(m0, df, p.c + j);
    hn::StoreU(m1, df, p.c + S + j);
    hn::StoreU(m2, df, p.c + 2 * S + j);
    hn::StoreU(m3, df, p.c + 3 * S + j);
  } else {
    auto a0 = zero, a1 = zero, a2 = zero, a3 = zero;
    if constexpr (AM == 2) {  // the accumulator's bilinear up-sampling, vertical lerp
      const auto ty = hn::Set(df, r.aty);
      auto lerp = [&](int ch) {
        const auto t = hn::LoadU(df, p.at + S * ch + j);
        return hn::Add(t, hn::Mul(hn::Sub(hn::LoadU(df, p.ab + S * ch + j), t), ty));
      };
      a0 = lerp(0);
      a1 = lerp(1);
      a2 = lerp(2);
      a3 = lerp(3);
    }
    if constexpr (FRONT) {  // composite.cpp over(): f + (1 − f.a)·b
      const auto t = hn::Sub(one, m3);
      hn::StoreU(hn::Add(m0, hn::Mul(t, a0)), df, p.c + j);
      hn::StoreU(hn::Add(m1, hn::Mul(t, a1)), df, p.c + S + j);
      hn::StoreU(hn::Add(m2, hn::Mul(t, a2)), df, p.c + 2 * S + j);
      hn::StoreU(hn::Add(m3, hn::Mul(t, a3)), df, p.c + 3 * S + j);
    } else {
      const auto t = hn::Sub(one, a3);
      hn::StoreU(hn::Add(a0, hn::Mul(t, m0)), df, p.c + j);
      hn::StoreU(hn::Add(a1, hn::Mul(t, m1)), df, p.c + S + j);
      hn::StoreU(hn::Add(a2, hn::Mul(t, m2)), df, p.c + 2 * S + j);
      hn::StoreU(hn::Add(a3, hn::Mul(t, m3)), df, p.c + 3 * S + j);
    }
  }
}

template <bool M, bool H, bool FG, int AM, bool FRONT>
HWY_INLINE void CrowLoop(const CrowRow& row, int s, int e, float (*c)[256]) {
  const hn::ScalableTag<float> df;
  const int n = static_cast<int>(hn::Lanes(df));
  const CrowScalars r{row.k, row.fty, row.aty, row.opaque, row.under};
  CrowPtrs p;
  p.code = row.code;
  p.w0 = row.w0;
  for (int ch = 0; ch < 4; ++ch) p.in[ch] = row.in[ch];
  p.ft = row.ft;
  p.fb = row.fb;
  p.at = row.at;
  p.ab = row.ab;
  p.c = c[0];
  int j = s;
  for (; j + n <= e; j += n) CrowVec<M, H, FG, AM, FRONT, kRowStride>(r, p, static_cast<std::size_t>(j));
  if (j >= e) return;
  // Tail: the same vector code on copies of the m = e − j remaining columns, padded (the
  // row groups with the copies' own channel stride L).
  const int m = e - j;
  constexpr int L = HWY_LANES(float);
  HWY_ALIGN float buf[5][L] = {};
  HWY_ALIGN float grp[5][4 * L] = {};
  HWY_ALIGN std::uint16_t cbuf[L] = {};
  CrowPtrs t;
  for (int i = 0; i < m; ++i) cbuf[i] = (M || H) ? row.code[j + i] : 0;
  auto copy = [&](const float* src, int slot) {
    for (int i = 0; i < m; ++i) buf[slot][i] = src[j + i];
    return buf[slot];
  };
  auto copy4 = [&](const float* src, int slot) {
    for (int ch = 0; ch < 4; ++ch)
      for (int i = 0; i < m; ++i) grp[slot][L * ch + i] = src[kRowStride * ch + j + i];
    return grp[slot];
  };
  t.code = cbuf;
  t.w0 = M ? copy(row.w0, 0) : buf[0];
  for (int ch = 0; ch < 4; ++ch) t.in[ch] = M ? copy(row.in[ch], 1 + ch) : buf[1 + ch];
  t.ft = H ? copy4(row.ft, 0) : grp[0];
  t.fb = H ? copy4(row.fb, 1) : grp[1];
  t.at = AM == 2 ? copy4(row.at, 2) : grp[2];
  t.ab = AM == 2 ? copy4(row.ab, 3) : grp[3];
  t.c = grp[4];
  CrowVec<M, H, FG, AM, FRONT, L>(r, t, 0);
  for (int ch = 0; ch < 4; ++ch)
    for (int i = 0; i < m; ++i) c[ch][j + i] = grp[4][L * ch + i];
}

template <bool M, bool H, bool FG>
HWY_INLINE void CrowSeg(const CrowRow& r, int s, int e, float (*c)[256]) {
  if (r.am == 0)
    CrowLoop<M, H, FG, 0, true>(r, s, e, c);
  else if (r.am == 1) {
    if (r.front)
      CrowLoop<M, H, FG, 1, true>(r, s, e, c);
    else
      CrowLoop<M, H, FG, 1, false>(r, s, e, c);
  } else {
    if (r.front)
      CrowLoop<M, H, FG, 2, true>(r, s, e, c);
    else
      CrowLoop<M, H, FG, 2, false>(r, s, e, c);
  }
}

void CrowRowImpl(const CrowRow& r, int n, int lo, int hi, int a0, int a1, float (*c)[256]) {
  if (hi <= lo) lo = hi = n;
  if (a1 <= a0) a0 = a1 = n;
  const bool fg = r.opaque || r.under;
  // The cuts in order: a sorting network of compare-exchanges on scalars (GCC vectorised the
  // insertion sort this replaced into stores and overlapping reloads of a stack array that
  // missed store forwarding: ~6 % of this kernel's samples).
  int q0 = lo, q1 = hi, q2 = a0, q3 = a1;
  auto cx = [](int& x, int& y) {
    const int t = x < y ? x : y;
    y = x < y ? y : x;
    x = t;
  };
  cx(q0, q1);
  cx(q2, q3);
  cx(q0, q2);
  cx(q1, q3);
  cx(q1, q2);
  auto seg = [&](int s, int e) {
    if (e <= s) return;
    const bool m = s >= lo && s < hi, h = s >= a0 && s < a1;
    if (m && h) {
      if (fg)
        CrowSeg<true, true, true>(r, s, e, c);
      else
        CrowSeg<true, true, false>(r, s, e, c);
    } else if (m) {
      CrowSeg<true, false, false>(r, s, e, c);
    } else if (h) {
      if (fg)
        CrowSeg<false, true, true>(r, s, e, c);
      else
        CrowSeg<false, true, false>(r, s, e, c);
    } else {
      CrowSeg<false, false, false>(r, s, e, c);
    }
  };
  seg(0, q0);
  seg(q0, q1);
  seg(q1, q2);
  seg(q2, q3);
  seg(q3, n);
}

// The pull's child at fine column j of row `row` (scalar form of PullChunk): *nz = 1 unless
// a hole, z = its matte, +0 at a hole.
HWY_INLINE void PullChild(const PullRows& r, int row, int j, float* z, float* nz) {
  const int cd = r.code[row][j];
  const int k1 = r.k >= 1 ? ((r.k - 1) | 32) : 0xffff;
  const float second = (cd & 63) == k1 ? 1.0f : 0.0f;
  const float wk = (cd & 31) == r.k ? r.w0[row][j] : second;
  const bool hole = r.k >= (cd >> 6);
  for (int c = 0; c < 4; ++c) z[c] = hole ? 0.0f : 0.0f + wk * r.in[row][c][j];
  *nz = hole ? 0.0f : 1.0f;
}

void PullPairsImpl(const PullRows& r, int m, int p0, int p1, float* const* cv, float* cw) {
  const int v0 = p1 > p0 ? p0 : m, v1 = p1 > p0 ? p1 : m;  // pairs whose values are computed
  int x = 0;
#if HWY_TARGET != HWY_SCALAR  // (the scalar target has no half vectors: all pixels below)
  const hn::ScalableTag<double> dd;
  const hn::Rebind<float, decltype(dd)> dh;  // as many floats as doubles (half a vector)
  const hn::Twice<decltype(dh)> df;          // the 2·Nd fine columns of Nd coarse pixels
  const hn::RebindToSigned<decltype(df)> di;
  const hn::Rebind<std::uint16_t, decltype(df)> du;
  const int nd = static_cast<int>(hn::Lanes(dd));
  const auto zero = hn::Zero(df), one = hn::Set(df, 1.0f);
  const int k1 = r.k >= 1 ? ((r.k - 1) | 32) : 0xffff;
  // Children of the coarse pixels [x, x + nd): even / odd fine columns of both rows.
  auto fine = [&](int row, int x, hn::Vec<decltype(dh)>* ze, hn::Vec<decltype(dh)>* zo, hn::Vec<decltype(dh)>& ne,
                  hn::Vec<decltype(dh)>& no, bool values) {
    const std::size_t j = static_cast<std::size_t>(2 * x);
    const auto cd =
        hn::BitCast(di, hn::PromoteTo(hn::RebindToUnsigned<decltype(di)>(), hn::LoadU(du, r.code[row] + j)));
    const auto hole = hn::RebindMask(df, hn::Gt(hn::Set(di, r.k + 1), hn::ShiftRight<6>(cd)));  // k >= hk
    const auto nz = hn::IfThenZeroElse(hole, one);
    ne = hn::LowerHalf(dh, hn::ConcatEven(df, nz, nz));
    no = hn::LowerHalf(dh, hn::ConcatOdd(df, nz, nz));
    if (!values) return;
    const auto second =
        hn::IfThenElseZero(hn::RebindMask(df, hn::Eq(hn::And(cd, hn::Set(di, 63)), hn::Set(di, k1))), one);
    const auto wk = hn::IfThenElse(hn::RebindMask(df, hn::Eq(hn::And(cd, hn::Set(di, 31)), hn::Set(di, r.k))),
                                   hn::LoadU(df, r.w0[row] + j), second);
    for (int c = 0; c < 4; ++c) {
      const auto z = hn::IfThenZeroElse(hole, hn::Add(zero, hn::Mul(wk, hn::LoadU(df, r.in[row][c] + j))));
      ze[c] = hn::LowerHalf(dh, hn::ConcatEven(df, z, z));
      zo[c] = hn::LowerHalf(dh, hn::ConcatOdd(df, z, z));
    }
  };
  for (; x + nd <= m; x += nd) {
    const bool values = x + nd > v0 && x < v1;
    hn::Vec<decltype(dh)> ze[2][4], zo[2][4], ne[2], no[2];
    fine(0, x, ze[0], zo[0], ne[0], no[0], values);
    fine(1, x, ze[1], zo[1], ne[1], no[1], values);
    // Σ w in pull_pairs' order (0 … 4: exact), confidence min(1, Σ w / 4) = Σ w · 0.25.
    const auto s = hn::Add(hn::Add(hn::Add(ne[0], no[0]), ne[1]), no[1]);
    hn::StoreU(hn::Mul(s, hn::Set(dh, 0.25f)), dh, cw + x);
    if (!values) {
      for (int c = 0; c < 4; ++c) hn::StoreU(hn::Zero(dh), dh, cv[c] + x);
      continue;
    }
    const auto sw = hn::PromoteTo(dd, s);
    const auto any = hn::Gt(sw, hn::Zero(dd));
    // Σ w is a count of children, 0 … 4. Where no lane has Σ w = 3, sv / Σ w is sv · r with
    // r = 1, 1/2, 1/4 for Σ w = 1, 2, 4 (and anything where Σ w = 0: masked): dividing by
    // 2^k and multiplying by 2^−k give the same double, as both round the same exact value
    // sv·2^−k, which is representable (sv, a sum of four floats, is 0 or at least 2^−149 in
    // magnitude: no underflow in double). The four double divisions of a vector (~16 cycles
    // each at 8 lanes on AVX-512, where the demote after them took a third of the samples)
    // become multiplies; boundary vectors with a 3 keep them.
    const bool pow2 = hn::AllFalse(dh, hn::Eq(s, hn::Set(dh, 3.0f)));
    const auto r = hn::PromoteTo(
        dd, hn::IfThenElse(hn::Eq(s, hn::Set(dh, 4.0f)), hn::Set(dh, 0.25f),
                           hn::IfThenElse(hn::Eq(s, hn::Set(dh, 2.0f)), hn::Set(dh, 0.5f), hn::Set(dh, 1.0f))));
    for (int c = 0; c < 4; ++c) {
      auto sv = hn::Zero(dd);
      sv = hn::Add(sv, hn::PromoteTo(dd, ze[0][c]));
      sv = hn::Add(sv, hn::PromoteTo(dd, zo[0][c]));
      sv = hn::Add(sv, hn::PromoteTo(dd, ze[1][c]));
      sv = hn::Add(sv, hn::PromoteTo(dd, zo[1][c]));
      const auto q = pow2 ? hn::Mul(sv, r) : hn::Div(sv, sw);
      hn::StoreU(hn::DemoteTo(dh, hn::IfThenElseZero(any, q)), dh, cv[c] + x);
    }
  }
#endif
  for (; x < m; ++x) {  // the rest, one pixel at a time (the same arithmetic)
    float z[4][4], nz[4];
    PullChild(r, 0, 2 * x, z[0], &nz[0]);
    PullChild(r, 0, 2 * x + 1, z[1], &nz[1]);
    PullChild(r, 1, 2 * x, z[2], &nz[2]);
    PullChild(r, 1, 2 * x + 1, z[3], &nz[3]);
    const float s = nz[0] + nz[1] + nz[2] + nz[3];
    cw[x] = s * 0.25f;
    const double sw = static_cast<double>(s);
    for (int c = 0; c < 4; ++c) {
      double sv = 0;
      for (int q = 0; q < 4; ++q) sv += static_cast<double>(z[q][c]);
      cv[c][x] = x >= v0 && x < v1 && sw > 0 ? static_cast<float>(sv / sw) : 0.0f;
    }
  }
}

// One column of FinalRowImpl (T = float) or a vector of them (T = a Highway vector); the
// loads, arithmetic and stores come from the ops object. The row groups' channels lie
// kRowStride floats apart; bty, fty are FinalRow's, copied into locals (see CrowScalars).
template <int BM, int FM, class Ops>
HWY_INLINE void FinalAt(const FinalRow& r, float bty, float fty, const Ops& o, std::size_t j, float* const* out) {
  using T = decltype(o.load(r.c + j));
  const T one = o.set(1.0f);
  auto acc = [&](int mode, const float* top, const float* bot, float ty, int ch) {
    const std::size_t i = static_cast<std::size_t>(kRowStride) * ch + j;
    if (mode == 1) return o.load(top + i);
    const T t = o.load(top + i);
    return o.add(t, o.mul(o.sub(o.load(bot + i), t), o.set(ty)));  // lerp_rows
  };
  const T c3 = o.load(r.c + 3 * kRowStride + j);
  const T t = o.sub(one, c3);  // one_minus
  T f3 = one, u = one;
  if constexpr (FM != 0) {
    f3 = acc(FM, r.ft, r.fb, fty, 3);
    u = o.sub(one, f3);
  }
  for (int ch = 0; ch < 4; ++ch) {  // final_channel
    T v = ch == 3 ? c3 : o.load(r.c + kRowStride * ch + j);
    if constexpr (BM != 0) v = o.add(v, o.mul(t, acc(BM, r.bt, r.bb, bty, ch)));
    if constexpr (FM != 0) v = o.add(ch == 3 ? f3 : acc(FM, r.ft, r.fb, fty, ch), o.mul(u, v));
    o.store(v, out[ch] + j);
  }
}

struct ScalarOps {
  float load(const float* p) const { return *p; }
  void store(float v, float* p) const { *p = v; }
  float set(float v) const { return v; }
  float add(float a, float b) const { return a + b; }
  float sub(float a, float b) const { return a - b; }
  float mul(float a, float b) const { return a * b; }
};
template <bool kExact>
struct VecOps {
  hn::ScalableTag<float> d;
  auto load(const float* p) const { return hn::LoadU(d, p); }
  template <class V>
  void store(V v, float* p) const {
    hn::StoreU(v, d, p);
  }
  auto set(float v) const { return hn::Set(d, v); }
  template <class V>
  V add(V a, V b) const {
    return hn::Add(a, b);
  }
  template <class V>
  V sub(V a, V b) const {
    return hn::Sub(a, b);
  }
  template <class V>
  V mul(V a, V b) const {
    return MulX<kExact>(d, a, b);
  }
};

template <int BM, int FM, bool kExact>
HWY_INLINE void FinalLoop(const FinalRow& row, int n, float* const* out_rows) {
  const VecOps<kExact> vo;
  const int lanes = static_cast<int>(hn::Lanes(vo.d));
  // Locals (see CrowScalars): the row pointers and weights are not re-read after each store.
  const FinalRow r = row;
  float* const out[4] = {out_rows[0], out_rows[1], out_rows[2], out_rows[3]};
  const float bty = r.bty, fty = r.fty;
  int j = 0;
  for (; j + lanes <= n; j += lanes) FinalAt<BM, FM>(r, bty, fty, vo, static_cast<std::size_t>(j), out);
  for (; j < n; ++j) FinalAt<BM, FM>(r, bty, fty, ScalarOps(), static_cast<std::size_t>(j), out);
}

template <bool kExact>
HWY_INLINE void FinalRowT(const FinalRow& r, int n, float* const* out) {
  switch (3 * r.bm + r.fm) {
    case 0:
      FinalLoop<0, 0, kExact>(r, n, out);
      break;
    case 1:
      FinalLoop<0, 1, kExact>(r, n, out);
      break;
    case 2:
      FinalLoop<0, 2, kExact>(r, n, out);
      break;
    case 3:
      FinalLoop<1, 0, kExact>(r, n, out);
      break;
    case 4:
      FinalLoop<1, 1, kExact>(r, n, out);
      break;
    case 5:
      FinalLoop<1, 2, kExact>(r, n, out);
      break;
    case 6:
      FinalLoop<2, 0, kExact>(r, n, out);
      break;
    case 7:
      FinalLoop<2, 1, kExact>(r, n, out);
      break;
    default:
      FinalLoop<2, 2, kExact>(r, n, out);
      break;
  }
}

void FinalRowImpl(const FinalRow& r, int n, float* const* out) {
  if (r.exact)
    FinalRowT<true>(r, n, out);
  else
    FinalRowT<false>(r, n, out);
}

void DownQuadsImpl(const float* r0, const float* r1, const float* r2, const float* r3, int m, float* d) {
  int x = 0;
#if HWY_TARGET != HWY_SCALAR
  const hn::ScalableTag<float> df;
  const int n = static_cast<int>(hn::Lanes(df));
  const float* rows[4] = {r0, r1, r2, r3};
  for (; x + n <= m; x += n) {
    auto s = hn::Zero(df);
    for (int dy = 0; dy < 4; ++dy) {
      // The 4n taps of the row, de-interleaved into q_dx = taps 4x + dx of the n outputs.
      const float* p = rows[dy] + 4 * static_cast<std::size_t>(x);
      const auto v0 = hn::LoadU(df, p), v1 = hn::LoadU(df, p + n), v2 = hn::LoadU(df, p + 2 * n),
                 v3 = hn::LoadU(df, p + 3 * n);
      const auto e01 = hn::ConcatEven(df, v1, v0), o01 = hn::ConcatOdd(df, v1, v0);
      const auto e23 = hn::ConcatEven(df, v3, v2), o23 = hn::ConcatOdd(df, v3, v2);
      s = hn::Add(s, hn::ConcatEven(df, e23, e01));  // 4x
      s = hn::Add(s, hn::ConcatEven(df, o23, o01));  // 4x + 1
      s = hn::Add(s, hn::ConcatOdd(df, e23, e01));   // 4x + 2
      s = hn::Add(s, hn::ConcatOdd(df, o23, o01));   // 4x + 3
    }
    hn::StoreU(hn::Mul(hn::Set(df, 0.0625f), s), df, d + x);
  }
#endif
  for (; x < m; ++x) {
    float s = 0.0f;
    for (const float* r : {r0, r1, r2, r3})
      for (int dx = 0; dx < 4; ++dx) s += r[4 * x + dx];
    d[x] = 0.0625f * s;
  }
}

// The fused row v = t + (b − t)·ty (lerp_rows) at p + i.
template <bool kExact = false, class D>
HWY_INLINE hn::Vec<D> LerpAt(D d, const float* t, const float* b, hn::Vec<D> ty, std::size_t i) {
  const auto tv = hn::LoadU(d, t + i);
  return hn::Add(tv, MulX<kExact>(d, hn::Sub(hn::LoadU(d, b + i), tv), ty));
}

template <bool kExact>
HWY_INLINE void LerpQuadsAccT(const float* top, const float* bot, float ty, int m, bool first, float* acc) {
  constexpr int kAcc = kRowStride / 4;  // acc's channel stride
  for (int ch = 0; ch < 4; ++ch) {
    const float* t = top + kRowStride * ch;
    const float* b = bot + kRowStride * ch;
    float* a = acc + kAcc * ch;
    int x = 0;
#if HWY_TARGET != HWY_SCALAR
    const hn::ScalableTag<float> df;
    const int n = static_cast<int>(hn::Lanes(df));
    const auto tyv = hn::Set(df, ty);
    for (; x + n <= m; x += n) {  // DownQuadsImpl's de-interleave of one row, on the lerps
      const std::size_t i = 4 * static_cast<std::size_t>(x);
      const auto v0 = LerpAt<kExact>(df, t, b, tyv, i), v1 = LerpAt<kExact>(df, t, b, tyv, i + n),
                 v2 = LerpAt<kExact>(df, t, b, tyv, i + 2 * n), v3 = LerpAt<kExact>(df, t, b, tyv, i + 3 * n);
      const auto e01 = hn::ConcatEven(df, v1, v0), o01 = hn::ConcatOdd(df, v1, v0);
      const auto e23 = hn::ConcatEven(df, v3, v2), o23 = hn::ConcatOdd(df, v3, v2);
      auto sv = first ? hn::Zero(df) : hn::LoadU(df, a + x);
      sv = hn::Add(sv, hn::ConcatEven(df, e23, e01));  // 4x
      sv = hn::Add(sv, hn::ConcatEven(df, o23, o01));  // 4x + 1
      sv = hn::Add(sv, hn::ConcatOdd(df, e23, e01));   // 4x + 2
      sv = hn::Add(sv, hn::ConcatOdd(df, o23, o01));   // 4x + 3
      hn::StoreU(sv, df, a + x);
    }
#endif
    for (; x < m; ++x) {
      float sv = first ? 0.0f : a[x];
      for (int dx = 0; dx < 4; ++dx) {
        const int i = 4 * x + dx;
        sv += t[i] + (b[i] - t[i]) * ty;
      }
      a[x] = sv;
    }
  }
}

void LerpQuadsAccImpl(const float* top, const float* bot, float ty, int m, bool first, bool exact, float* acc) {
  if (exact)
    LerpQuadsAccT<true>(top, bot, ty, m, first, acc);
  else
    LerpQuadsAccT<false>(top, bot, ty, m, first, acc);
}

template <bool kExact>
HWY_INLINE void LerpPairsBoxT(const float* ta, const float* ba, float tya, const float* tb, const float* bb, float tyb,
                              int m, float* const* d) {
  for (int ch = 0; ch < 4; ++ch) {
    const float* t0 = ta + kRowStride * ch;
    const float* b0 = ba + kRowStride * ch;
    const float* t1 = tb + kRowStride * ch;
    const float* b1 = bb + kRowStride * ch;
    float* o = d[ch];
    int x = 0;
#if HWY_TARGET != HWY_SCALAR
    const hn::ScalableTag<float> df;
    const int n = static_cast<int>(hn::Lanes(df));
    const auto ty0 = hn::Set(df, tya), ty1 = hn::Set(df, tyb), q = hn::Set(df, 0.25f);
    for (; x + n <= m; x += n) {
      const std::size_t i = 2 * static_cast<std::size_t>(x);
      const auto a0 = LerpAt<kExact>(df, t0, b0, ty0, i), a1 = LerpAt<kExact>(df, t0, b0, ty0, i + n);
      const auto c0 = LerpAt<kExact>(df, t1, b1, ty1, i), c1 = LerpAt<kExact>(df, t1, b1, ty1, i + n);
      // down_pairs: 0.25 · (((a[2x] + a[2x + 1]) + b[2x]) + b[2x + 1])
      auto sv = hn::Add(hn::ConcatEven(df, a1, a0), hn::ConcatOdd(df, a1, a0));
      sv = hn::Add(sv, hn::ConcatEven(df, c1, c0));
      sv = hn::Add(sv, hn::ConcatOdd(df, c1, c0));
      hn::StoreU(MulX<kExact>(df, q, sv), df, o + x);
    }
#endif
    for (; x < m; ++x) {
      const int i = 2 * x;
      const float a0 = t0[i] + (b0[i] - t0[i]) * tya, a1 = t0[i + 1] + (b0[i + 1] - t0[i + 1]) * tya;
      const float c0 = t1[i] + (b1[i] - t1[i]) * tyb, c1 = t1[i + 1] + (b1[i + 1] - t1[i + 1]) * tyb;
      o[x] = 0.25f * (a0 + a1 + c0 + c1);
    }
  }
}

void LerpPairsBoxImpl(const float* ta, const float* ba, float tya, const float* tb, const float* bb, float tyb, int m,
                      bool exact, float* const* d) {
  if (exact)
    LerpPairsBoxT<true>(ta, ba, tya, tb, bb, tyb, m, d);
  else
    LerpPairsBoxT<false>(ta, ba, tya, tb, bb, tyb, m, d);
}

// fast_kernels.cpp's kern::up_pairs / kern::up_quads (the same expressions in the same order) with
// MulX<true>: for coarse rows with tiny samples.
void UpPairsExactImpl(const float* src, int i0, int i1, float* dst) {
  const float* s = src + i0;
  const int m = i1 - i0;
  int i = 0;
#if HWY_TARGET != HWY_SCALAR
  const hn::ScalableTag<float> df;
  const int n = static_cast<int>(hn::Lanes(df));
  const auto w0 = hn::Set(df, 0.75f), w1 = hn::Set(df, 0.25f);
  for (; i + n <= m; i += n) {
    const auto lo = hn::LoadU(df, s + i - 1), mid = hn::LoadU(df, s + i), hi = hn::LoadU(df, s + i + 1);
    const auto e = hn::Add(lo, MulX<true>(df, hn::Sub(mid, lo), w0));
    const auto o = hn::Add(mid, MulX<true>(df, hn::Sub(hi, mid), w1));
    hn::StoreInterleaved2(e, o, df, dst + 2 * static_cast<std::size_t>(i));
  }
#endif
  for (; i < m; ++i) {
    const float lo = s[i - 1], mid = s[i], hi = s[i + 1];
    dst[2 * i] = lo + (mid - lo) * 0.75f;
    dst[2 * i + 1] = mid + (hi - mid) * 0.25f;
  }
}

void UpQuadsExactImpl(const float* src, int i0, int i1, float* dst) {
  const float* s = src + i0;
  const int m = i1 - i0;
  int i = 0;
#if HWY_TARGET != HWY_SCALAR
  const hn::ScalableTag<float> df;
  const int n = static_cast<int>(hn::Lanes(df));
  const auto w0 = hn::Set(df, 0.625f), w1 = hn::Set(df, 0.875f), w2 = hn::Set(df, 0.125f), w3 = hn::Set(df, 0.375f);
  for (; i + n <= m; i += n) {
    const auto lo = hn::LoadU(df, s + i - 1), mid = hn::LoadU(df, s + i), hi = hn::LoadU(df, s + i + 1);
    const auto dl = hn::Sub(mid, lo), dh = hn::Sub(hi, mid);
    hn::StoreInterleaved4(hn::Add(lo, MulX<true>(df, dl, w0)), hn::Add(lo, MulX<true>(df, dl, w1)),
                          hn::Add(mid, MulX<true>(df, dh, w2)), hn::Add(mid, MulX<true>(df, dh, w3)), df,
                          dst + 4 * static_cast<std::size_t>(i));
  }
#endif
  for (; i < m; ++i) {
    const float lo = s[i - 1], mid = s[i], hi = s[i + 1];
    dst[4 * i] = lo + (mid - lo) * 0.625f;
    dst[4 * i + 1] = lo + (mid - lo) * 0.875f;
    dst[4 * i + 2] = mid + (hi - mid) * 0.125f;
    dst[4 * i + 3] = mid + (hi - mid) * 0.375f;
  }
}

// fast_push_pull.cpp's push at a pyramid level (pull_push_upper) for the four channels of one block
// (see push_rows4_simd): per vector of pixels, nothing where every w >= 1 (the push keeps v
// there), else the same expression as the scalar form below, lane by lane.
void PushRows4Impl(const float* wr, const float* top, const float* bot, float t, int n, float* v, std::size_t ps) {
  int j = 0;
#if HWY_TARGET != HWY_SCALAR
  const hn::ScalableTag<float> df;
  const int L = static_cast<int>(hn::Lanes(df));
  const auto one = hn::Set(df, 1.0f), zero = hn::Zero(df), vt = hn::Set(df, t);
  for (; j + L <= n; j += L) {
    const auto wt = hn::LoadU(df, wr + j);
    const auto keep = hn::Ge(wt, one);
    if (hn::AllTrue(df, keep)) continue;
    const auto pos = hn::Gt(wt, zero);
    const auto omw = hn::Sub(one, wt);
    for (int ch = 0; ch < 4; ++ch) {
      const float* tp = top + ch * kRowStride + j;
      const float* bp = bot + ch * kRowStride + j;
      float* vp = v + ch * ps + j;
      const auto a = hn::LoadU(df, tp), b = hn::LoadU(df, bp), x = hn::LoadU(df, vp);
      const auto up = hn::Add(a, hn::Mul(hn::Sub(b, a), vt));
      const auto p = hn::IfThenElse(pos, hn::Add(hn::Mul(wt, x), hn::Mul(omw, up)), hn::Add(zero, up));
      hn::StoreU(hn::IfThenElse(keep, x, p), df, vp);
    }
  }
#endif
  for (int ch = 0; ch < 4; ++ch)
    for (int i = j; i < n; ++i) {
      const float wt = wr[i];
      const float up = top[ch * kRowStride + i] + (bot[ch * kRowStride + i] - top[ch * kRowStride + i]) * t;
      float& x = v[ch * ps + i];
      const float p = wt > 0.0f ? wt * x + (1.0f - wt) * up : 0.0f + up;
      x = wt >= 1.0f ? x : p;
    }
}

}  // namespace HWY_NAMESPACE
}  // namespace dofkit::detail::layered
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace dofkit::detail::layered {

HWY_EXPORT(CrowRowImpl);
HWY_EXPORT(PullPairsImpl);
HWY_EXPORT(FinalRowImpl);
HWY_EXPORT(DownQuadsImpl);
HWY_EXPORT(LerpQuadsAccImpl);
HWY_EXPORT(LerpPairsBoxImpl);
HWY_EXPORT(UpPairsExactImpl);
HWY_EXPORT(UpQuadsExactImpl);
HWY_EXPORT(PushRows4Impl);

void push_rows4_simd(const float* wr, const float* top, const float* bot, float t, int n, float* v, std::size_t ps) {
  HWY_DYNAMIC_DISPATCH(PushRows4Impl)(wr, top, bot, t, n, v, ps);
}

void up_pairs_exact_simd(const float* src, int i0, int i1, float* dst) {
  HWY_DYNAMIC_DISPATCH(UpPairsExactImpl)(src, i0, i1, dst);
}
void up_quads_exact_simd(const float* src, int i0, int i1, float* dst) {
  HWY_DYNAMIC_DISPATCH(UpQuadsExactImpl)(src, i0, i1, dst);
}

void lerp_quads_acc_simd(const float* top, const float* bot, float ty, int m, bool first, float* acc, bool exact) {
  HWY_DYNAMIC_DISPATCH(LerpQuadsAccImpl)(top, bot, ty, m, first, exact, acc);
}

void lerp_pairs_box_simd(const float* ta, const float* ba, float tya, const float* tb, const float* bb, float tyb,
                         int m, float* const* d, bool exact) {
  HWY_DYNAMIC_DISPATCH(LerpPairsBoxImpl)(ta, ba, tya, tb, bb, tyb, m, exact, d);
}

void down_quads_simd(const float* r0, const float* r1, const float* r2, const float* r3, int m, float* d) {
  HWY_DYNAMIC_DISPATCH(DownQuadsImpl)(r0, r1, r2, r3, m, d);
}

void final_row_simd(const FinalRow& r, int n, float* const* out) { HWY_DYNAMIC_DISPATCH(FinalRowImpl)(r, n, out); }

void pull_pairs_simd(const PullRows& r, int m, int p0, int p1, float* const* cv, float* cw) {
  HWY_DYNAMIC_DISPATCH(PullPairsImpl)(r, m, p0, p1, cv, cw);
}

void crow_row_simd(const CrowRow& r, int n, int lo, int hi, int a0, int a1, float (*c)[256]) {
  HWY_DYNAMIC_DISPATCH(CrowRowImpl)(r, n, lo, hi, a0, a1, c);
}

}  // namespace dofkit::detail::layered
#endif  // HWY_ONCE
