// lens's row kernels (kernels.hpp), one copy per SIMD target (Highway, run-time dispatch).
#include "methods/lens/kernels.hpp"

#include "methods/lens/common.hpp"

#include <algorithm>
#include <cmath>

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "methods/lens/kernels.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace dofkit::detail::lens {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

template <class D, class V>
HWY_INLINE V Sat(D d, V v) {
  return hn::Min(hn::Max(v, hn::Zero(d)), hn::Set(d, 1.0f));
}

// The per-pair rule (add_source, common.hpp) for the receivers i … i + lanes − 1: a source of
// inverse depth su and sharpness ssharp reaching them with weights wt carries cv (rgba,
// weight).
template <class D, class V>
HWY_INLINE void AddRule(D d, const RowReceivers& r, int i, float su, float ssharp, bool hidden, V wt, const V* cv) {
  const V u = hn::LoadU(d, r.u + i), isu = hn::LoadU(d, r.isu + i), sp = hn::LoadU(d, r.sharp + i);
  const V zero = hn::Zero(d), one = hn::Set(d, 1.0f);
  const V rel = hn::Mul(hn::Sub(hn::Set(d, su), u), isu);
  const V front = Sat(d, rel), behind = Sat(d, hn::Neg(rel));
  const auto sharp_receiver = hn::Gt(sp, zero);
  if (hidden) {
    // show = sp > 0 ? behind · sat(2 (sp − ssharp) / sp) : 0
    const V safe = hn::IfThenElse(sharp_receiver, sp, one);
    const V show = hn::IfThenElseZero(
        sharp_receiver,
        hn::Mul(behind, Sat(d, hn::Div(hn::Mul(hn::Set(d, 2.0f), hn::Sub(sp, hn::Set(d, ssharp))), safe))));
    const V wf = hn::Mul(wt, front), wb = hn::Mul(wt, hn::Sub(hn::Sub(one, front), behind)), wh = hn::Mul(wt, show);
    for (int c = 0; c < 5; ++c) {
      hn::StoreU(hn::MulAdd(wf, cv[c], hn::LoadU(d, r.acc[c] + i)), d, r.acc[c] + i);
      hn::StoreU(hn::MulAdd(wb, cv[c], hn::LoadU(d, r.acc[5 + c] + i)), d, r.acc[5 + c] + i);
      hn::StoreU(hn::MulAdd(wh, cv[c], hn::LoadU(d, r.acc[10 + c] + i)), d, r.acc[10 + c] + i);
    }
    return;
  }
  // pass = ssharp > 0 ? min(sp / ssharp, 1) : (sp > 0 ? 1 : 0)
  const V pass =
      ssharp > 0.0f ? hn::Min(hn::Div(sp, hn::Set(d, ssharp)), one) : hn::IfThenElseZero(sharp_receiver, one);
  const V v = hn::Mul(wt, hn::NegMulAdd(behind, hn::Sub(one, pass), one));
  const V wf = hn::Mul(v, front), wb = hn::Mul(v, hn::Sub(one, front));
  for (int c = 0; c < 5; ++c) {
    hn::StoreU(hn::MulAdd(wf, cv[c], hn::LoadU(d, r.acc[c] + i)), d, r.acc[c] + i);
    hn::StoreU(hn::MulAdd(wb, cv[c], hn::LoadU(d, r.acc[5 + c] + i)), d, r.acc[5 + c] + i);
  }
}

// Horizontal read-back of a vertically interpolated cell row at the receivers i … i + lanes − 1
// (frame columns x0 + i + lane): each receiver's cells X0, X0 + 1 and weight ax, as
// Grid::locate. Needs >= 4 lanes (the receivers of one vector span at most lanes / 2 + 2
// cells at level >= 1); `row` is readable up to lanes floats past the last cell used.
template <class D>
HWY_INLINE void ReadBack(D d, const float* const* row, int x0, int i, int level, int margin, hn::Vec<D>* out) {
  const hn::RebindToSigned<D> di;
  const float s = 1.0f / static_cast<float>(1 << level);
  const auto x = hn::Add(hn::ConvertTo(d, hn::Add(hn::Iota(di, 0), hn::Set(di, x0 + i))), hn::Set(d, 0.5f));
  const auto fx = hn::Add(hn::Mul(x, hn::Set(d, s)), hn::Set(d, static_cast<float>(margin) - 0.5f));
  const auto X0 = hn::ConvertTo(di, fx);
  const auto ax = hn::Sub(fx, hn::ConvertTo(d, X0));
  const int base = hn::GetLane(X0);
  const auto idx = hn::Sub(X0, hn::Set(di, base));
  const auto i0 = hn::IndicesFromVec(d, idx), i1 = hn::IndicesFromVec(d, hn::Add(idx, hn::Set(di, 1)));
  for (int c = 0; c < 5; ++c) {
    const auto v = hn::LoadU(d, row[c] + base);
    const auto lo = hn::TableLookupLanes(v, i0), hi = hn::TableLookupLanes(v, i1);
    out[c] = hn::MulAdd(ax, hn::Sub(hi, lo), lo);
  }
}

// Scalar read-back (targets with fewer than 4 lanes).
inline void ReadBackScalar(const float* const* row, int x, int level, int margin, float* out) {
  const float s = 1.0f / static_cast<float>(1 << level);
  const float fx = (static_cast<float>(x) + 0.5f) * s + (static_cast<float>(margin) - 0.5f);
  const int X0 = static_cast<int>(fx);
  const float ax = fx - static_cast<float>(X0);
  for (int c = 0; c < 5; ++c) out[c] = row[c][X0] + ax * (row[c][X0 + 1] - row[c][X0]);
}

void FoldRowImpl(const FoldRow& f, const RowReceivers& r) {
  const hn::ScalableTag<float> d;
  const int lanes = static_cast<int>(hn::Lanes(d));
  using V = hn::Vec<decltype(d)>;
  const V norm = hn::Set(d, f.norm);
  if (lanes < 4) {
    const hn::CappedTag<float, 1> d1;
    for (int i = 0; i < r.n; ++i) {
      float v[5];
      ReadBackScalar(f.row, f.x0 + i, f.level, f.margin, v);
      hn::Vec<decltype(d1)> cv[5];
      for (int c = 0; c < 5; ++c) cv[c] = hn::Set(d1, v[c]);
      AddRule(d1, r, i, f.su, f.ssharp, f.hidden, hn::Set(d1, f.norm), cv);
    }
    return;
  }
  for (int i = 0; i < r.n; i += lanes) {
    V cv[5];
    ReadBack(d, f.row, f.x0, i, f.level, f.margin, cv);
    AddRule(d, r, i, f.su, f.ssharp, f.hidden, norm, cv);
  }
}

void EstRowImpl(const EstRow& e) {
  const hn::ScalableTag<float> d;
  const hn::RebindToSigned<decltype(d)> di;
  const int lanes = static_cast<int>(hn::Lanes(d));
  if (lanes < 4) {
    for (int i = 0; i < e.n; ++i) {
      if (!(e.sharp[i] > 0.0f)) continue;
      const float hw = e.slice[i] == e.j ? 1.0f - e.t[i] : (e.slice[i] + 1 == e.j ? e.t[i] : 0.0f);
      if (hw == 0.0f) continue;
      float v[5];
      ReadBackScalar(e.row, e.x0 + i, e.level, e.margin, v);
      for (int c = 0; c < 5; ++c) e.est[c][i] += hw * v[c];
    }
    return;
  }
  const auto zero = hn::Zero(d), one = hn::Set(d, 1.0f);
  for (int i = 0; i < e.n; i += lanes) {
    const auto sl = hn::LoadU(di, e.slice + i);
    const auto t = hn::LoadU(d, e.t + i);
    const auto own = hn::RebindMask(d, hn::Eq(sl, hn::Set(di, e.j)));
    const auto next = hn::RebindMask(d, hn::Eq(hn::Add(sl, hn::Set(di, 1)), hn::Set(di, e.j)));
    auto hw = hn::IfThenElse(own, hn::Sub(one, t), hn::IfThenElseZero(next, t));
    hw = hn::IfThenElseZero(hn::Gt(hn::LoadU(d, e.sharp + i), zero), hw);
    if (hn::AllTrue(d, hn::Eq(hw, zero))) continue;
    hn::Vec<decltype(d)> v[5];
    ReadBack(d, e.row, e.x0, i, e.level, e.margin, v);
    for (int c = 0; c < 5; ++c) hn::StoreU(hn::MulAdd(hw, v[c], hn::LoadU(d, e.est[c] + i)), d, e.est[c] + i);
  }
}

void DirectRowImpl(const DirectRow& s, const RowReceivers& r) {
  const hn::ScalableTag<float> d;
  const int lanes = static_cast<int>(hn::Lanes(d));
  using V = hn::Vec<decltype(d)>;
  V cv[5];
  for (int c = 0; c < 5; ++c) cv[c] = hn::Set(d, s.c[c]);
  const V dy2 = hn::Set(d, s.dy * s.dy), lim = hn::Set(d, s.rho + 0.5f), ws = hn::Set(d, s.ws);
  const V step = hn::Iota(d, 0.0f);
  for (int i = 0; i < r.n; i += lanes) {
    const V dx = hn::Add(step, hn::Set(d, s.dx0 + static_cast<float>(i)));
    const V cov = Sat(d, hn::Sub(lim, hn::Sqrt(hn::MulAdd(dx, dx, dy2))));
    AddRule(d, r, i, s.su, s.ssharp, s.hidden, hn::Mul(cov, ws), cv);
  }
}

// Receivers px0 … px1 of tile row `row`.
inline RowReceivers SpanOf(const TileReceivers& r, int row, int px0, int px1) {
  const std::size_t o = static_cast<std::size_t>(row) * r.stride + px0;
  RowReceivers rr;
  rr.n = px1 - px0 + 1;
  rr.u = r.u + o;
  rr.isu = r.isu + o;
  rr.sharp = r.sharp + o;
  for (int c = 0; c < 15; ++c) rr.acc[c] = r.acc[c] + o;
  return rr;
}

// Spans of up to 8 receivers (most footprint rows of small sources) take 8-lane vectors.
template <class D>
HWY_INLINE void DirectSpan(D d, const DirectSource& s, const TileReceivers& r, int row, int px0, int px1, float dy) {
  using V = hn::Vec<D>;
  const int lanes = static_cast<int>(hn::Lanes(d));
  V cv[5];
  for (int c = 0; c < 5; ++c) cv[c] = hn::Set(d, s.c[c]);
  const V dy2 = hn::Set(d, dy * dy), lim = hn::Set(d, s.rho + 0.5f), ws = hn::Set(d, s.ws);
  const V step = hn::Iota(d, 0.0f);
  const RowReceivers rr = SpanOf(r, row, px0, px1);
  const float dx0 = static_cast<float>(px0 - s.qx);
  for (int i = 0; i < rr.n; i += lanes) {
    const V dx = hn::Add(step, hn::Set(d, dx0 + static_cast<float>(i)));
    const V cov = Sat(d, hn::Sub(lim, hn::Sqrt(hn::MulAdd(dx, dx, dy2))));
    AddRule(d, rr, i, s.su, s.ssharp, s.hidden, hn::Mul(cov, ws), cv);
  }
}

// An analytic aperture's span: coverage sat(lim − T) from the gauge row (see DirectSource).
template <class D>
HWY_INLINE void GaugeSpan(D d, const DirectSource& s, const TileReceivers& r, int row, int px0, int px1,
                          const float* trow) {
  using V = hn::Vec<D>;
  const int lanes = static_cast<int>(hn::Lanes(d));
  V cv[5];
  for (int c = 0; c < 5; ++c) cv[c] = hn::Set(d, s.c[c]);
  const V lim = hn::Set(d, s.lim), ws = hn::Set(d, s.ws);
  const RowReceivers rr = SpanOf(r, row, px0, px1);
  const float* t = trow + (px0 - s.qx);
  for (int i = 0; i < rr.n; i += lanes) {
    const V cov = Sat(d, hn::Sub(lim, hn::LoadU(d, t + i)));
    AddRule(d, rr, i, s.su, s.ssharp, s.hidden, hn::Mul(cov, ws), cv);
  }
}

void DirectSourceImpl(const DirectSource& s, const TileReceivers& r) {
  const hn::ScalableTag<float> d;
  const hn::CappedTag<float, 8> d8;
  if (s.gauge) {
    // Non-zero coverage needs |p| <= T < lim, and |dx|, |dy| <= reach.
    const int e = s.reach;
    for (int py = std::max(0, s.qy - e); py <= std::min(r.rows - 1, s.qy + e); ++py) {
      const float dy = static_cast<float>(py - s.qy);
      const int hw = std::min(e, static_cast<int>(std::sqrt(std::max(0.0f, s.lim * s.lim - dy * dy))));
      const int px0 = std::max(0, s.qx - hw), px1 = std::min(r.cols - 1, s.qx + hw);
      if (px0 > px1) continue;
      const float* trow = s.gauge + (py - s.qy) * s.pitch;
      if (px1 - px0 < 8)
        GaugeSpan(d8, s, r, py, px0, px1, trow);
      else
        GaugeSpan(d, s, r, py, px0, px1, trow);
    }
    return;
  }
  const int e = static_cast<int>(std::ceil(s.rho + 0.5f)) - 1;
  const float lim = s.rho + 0.5f;
  for (int py = std::max(0, s.qy - e); py <= std::min(r.rows - 1, s.qy + e); ++py) {
    const float dy = static_cast<float>(py - s.qy);
    const int hw = static_cast<int>(std::sqrt(std::max(0.0f, lim * lim - dy * dy)));
    const int px0 = std::max(0, s.qx - hw), px1 = std::min(r.cols - 1, s.qx + hw);
    if (px0 > px1) continue;
    if (px1 - px0 < 8)
      DirectSpan(d8, s, r, py, px0, px1, dy);
    else
      DirectSpan(d, s, r, py, px0, px1, dy);
  }
}

void CompositeRowImpl(const CompositeRow& c) {
  const hn::ScalableTag<float> d;
  const int lanes = static_cast<int>(hn::Lanes(d));
  using V = hn::Vec<decltype(d)>;
  const V zero = hn::Zero(d), one = hn::Set(d, 1.0f);
  // Whole vectors here (src and out are the frame's rows); the last n % lanes receivers with
  // the scalar composite (common.hpp).
  const int full = c.n - c.n % lanes;
  for (int i = full; i < c.n; ++i) {
    float a[15], e[5], o[4];
    for (int k = 0; k < 10; ++k) a[k] = c.acc[k][i];
    for (int k = 10; k < 15; ++k) a[k] = c.hidden ? c.acc[k][i] : 0.0f;
    for (int k = 0; k < 5; ++k) e[k] = c.est[k][i];
    const float m = composite(a, e, a + 10, c.src[0][i], c.src[1][i], c.src[2][i], c.src[3][i], o);
    for (int k = 0; k < 4; ++k) c.out[k][i] = o[k];
    if (c.cover[0]) {
      c.cover[0][i] = a[4];
      c.cover[1][i] = a[9];
      c.cover[2][i] = m;
    }
  }
  for (int i = 0; i < full; i += lanes) {
    const V fw = hn::LoadU(d, c.acc[4] + i), bw = hn::LoadU(d, c.acc[9] + i);
    const V hw = c.hidden ? hn::LoadU(d, c.acc[14] + i) : zero, ew = hn::LoadU(d, c.est[4] + i);
    const auto has_est = hn::Gt(ew, hn::Set(d, 1e-6f)), has_hid = hn::Gt(hw, zero);
    const V missing = hn::IfThenElseZero(hn::Or(has_est, has_hid), hn::Max(zero, hn::Sub(hn::Sub(one, fw), bw)));
    // Fill: the hidden fragments where they cover, the estimate for the rest.
    const V rest = hn::IfThenElseZero(has_est, hn::Max(zero, hn::Sub(one, hw)));
    const V den = hn::Add(hw, rest);
    const auto fill_on = hn::Gt(missing, zero);
    const V inv = hn::IfThenElseZero(fill_on, hn::Div(one, hn::IfThenElse(fill_on, den, one)));
    const V est_scale = hn::IfThenElseZero(has_est, hn::Div(rest, hn::IfThenElse(has_est, ew, one)));
    const V fs = hn::IfThenElse(hn::Gt(fw, one), hn::Div(one, fw), one);
    const V keep = hn::Sub(one, hn::Min(fw, one));
    const V bm = hn::Add(bw, missing);
    const auto back_on = hn::Gt(bm, zero), front_only = hn::Gt(fw, zero);
    const V inv_bm = hn::Div(one, hn::IfThenElse(back_on, bm, one));
    const V inv_fw = hn::Div(one, hn::IfThenElse(front_only, fw, one));
    for (int ch = 0; ch < 4; ++ch) {
      const V f = hn::LoadU(d, c.acc[ch] + i), b = hn::LoadU(d, c.acc[5 + ch] + i);
      const V hid = c.hidden ? hn::LoadU(d, c.acc[10 + ch] + i) : zero;
      const V fill = hn::Mul(hn::MulAdd(est_scale, hn::LoadU(d, c.est[ch] + i), hid), inv);
      const V back = hn::Mul(hn::MulAdd(missing, fill, b), inv_bm);
      const V with_back = hn::MulAdd(keep, back, hn::Mul(f, fs));
      const V v = hn::IfThenElse(back_on, with_back,
                                 hn::IfThenElse(front_only, hn::Mul(f, inv_fw), hn::LoadU(d, c.src[ch] + i)));
      hn::StoreU(v, d, c.out[ch] + i);
    }
    if (c.cover[0]) {
      hn::StoreU(fw, d, c.cover[0] + i);
      hn::StoreU(bw, d, c.cover[1] + i);
      hn::StoreU(missing, d, c.cover[2] + i);
    }
  }
}

}  // namespace HWY_NAMESPACE
}  // namespace dofkit::detail::lens
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace dofkit::detail::lens {

HWY_EXPORT(FoldRowImpl);
HWY_EXPORT(EstRowImpl);
HWY_EXPORT(DirectRowImpl);
HWY_EXPORT(CompositeRowImpl);
HWY_EXPORT(DirectSourceImpl);

void fold_row(const FoldRow& f, const RowReceivers& r) { HWY_DYNAMIC_DISPATCH(FoldRowImpl)(f, r); }
void est_row(const EstRow& e) { HWY_DYNAMIC_DISPATCH(EstRowImpl)(e); }
void direct_row(const DirectRow& d, const RowReceivers& r) { HWY_DYNAMIC_DISPATCH(DirectRowImpl)(d, r); }
void composite_row(const CompositeRow& c) { HWY_DYNAMIC_DISPATCH(CompositeRowImpl)(c); }
void direct_source(const DirectSource& d, const TileReceivers& r) { HWY_DYNAMIC_DISPATCH(DirectSourceImpl)(d, r); }

}  // namespace dofkit::detail::lens
#endif  // HWY_ONCE
