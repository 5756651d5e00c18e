// Highway kernel of gather.hpp (run-time dispatch: AVX-512 / AVX2 / SSE4 / scalar).
//
// The table index must be exactly the scalar one, ⌊RN(5|δ| / den)⌋ clamped to 6: a weight
// step (e.g. 1 → 0.9) on one tap would move the result by far more than rounding does. So
// the kernel divides (IEEE division is correctly rounded in every lane) instead of
// multiplying by a reciprocal, and den is precomputed by scalar code. Accumulation uses FMA,
// which rounds differently from the plain pass's separate multiply and add (≈ 1 ulp per tap).
#include "methods/mcguire/gather.hpp"

#include <algorithm>
#include <cstddef>

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "methods/mcguire/gather_simd.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace dofkit::detail::mcguire {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

void FarGather(const GatherJob& job) {
  const hn::ScalableTag<float> df;
  const hn::RebindToSigned<decltype(df)> di;
  const int lanes = static_cast<int>(hn::Lanes(df));
  const auto one = hn::Set(df, 1.0f), zero = hn::Zero(df), six = hn::Set(df, 6.0f), c15 = hn::Set(df, 1.5f);
  const bool permute = lanes >= 8 && lanes <= 16;
  const auto table = hn::LoadU(df, job.table);  // first `lanes` entries (16 are allocated)
  auto compute = [&](int o) {
    const auto n = hn::LoadU(df, job.nearness + o);
    const auto abs_a = hn::Abs(hn::LoadU(df, job.r_a + o));
    auto a0 = zero, a1 = zero, a2 = zero, a3 = zero, aw = zero;
    for (int t = 0; t < job.ntaps; ++t) {
      const GatherTap& tp = job.taps[t];
      const auto q = hn::Div(hn::Set(df, tp.d5), hn::LoadU(df, tp.den + o));
      const auto idx = hn::ConvertTo(di, hn::Min(q, six));
      auto wn = permute ? hn::TableLookupLanes(table, hn::IndicesFromVec(df, idx)) : hn::GatherIndex(df, job.table, idx);
      wn = hn::Mul(wn, hn::LoadU(df, tp.flag + o));
      if (job.occlusion) {
        const auto occ = hn::Add(hn::Sub(abs_a, hn::LoadU(df, tp.absb + o)), c15);
        wn = hn::Mul(wn, hn::Min(hn::Max(occ, zero), one));
      }
      const auto w = hn::MulAdd(hn::Sub(one, wn), n, wn);
      a0 = hn::MulAdd(w, hn::LoadU(df, tp.col[0] + o), a0);
      a1 = hn::MulAdd(w, hn::LoadU(df, tp.col[1] + o), a1);
      a2 = hn::MulAdd(w, hn::LoadU(df, tp.col[2] + o), a2);
      a3 = hn::MulAdd(w, hn::LoadU(df, tp.col[3] + o), a3);
      aw = hn::Add(aw, w);
    }
    hn::StoreU(hn::Div(a0, aw), df, job.out[0] + o);
    hn::StoreU(hn::Div(a1, aw), df, job.out[1] + o);
    hn::StoreU(hn::Div(a2, aw), df, job.out[2] + o);
    hn::StoreU(hn::Div(a3, aw), df, job.out[3] + o);
  };
  if (job.n >= lanes) {
    int o = 0;
    for (; o + lanes <= job.n; o += lanes) compute(o);
    // Tail: one more vector that ends at n (recomputes a few outputs with identical values).
    if (o < job.n) compute(job.n - lanes);
    return;
  }
  // Fewer outputs than lanes: scalar, same formula.
  for (int o = 0; o < job.n; ++o) {
    const float abs_a = job.r_a[o] < 0 ? -job.r_a[o] : job.r_a[o];
    float a[4] = {0, 0, 0, 0}, aw = 0;
    for (int t = 0; t < job.ntaps; ++t) {
      const GatherTap& tp = job.taps[t];
      const float q = tp.d5 / tp.den[o];
      float wn = job.table[q >= 6.0f ? 6 : static_cast<int>(q)] * tp.flag[o];
      if (job.occlusion) {
        const float occ = abs_a - tp.absb[o] + 1.5f;
        wn *= occ < 0 ? 0.0f : occ > 1 ? 1.0f : occ;
      }
      const float w = wn + (1.0f - wn) * job.nearness[o];
      for (int c = 0; c < 4; ++c) a[c] += w * tp.col[c][o];
      aw += w;
    }
    for (int c = 0; c < 4; ++c) job.out[c][o] = a[c] / aw;
  }
}

void CompositeRow(const CompositeRowJob& job) {
  const hn::ScalableTag<float> df;
  const int lanes = static_cast<int>(hn::Lanes(df));
  const int w = job.w;
  const auto zero = hn::Zero(df), one = hn::Set(df, 1.0f), m1 = hn::Set(df, -1.0f);
  const auto wy = hn::Set(df, job.wy), rescale = hn::Set(df, job.far_rescale), boost = hn::Set(df, job.coverage_boost);
  const auto two = hn::Set(df, 2.0f), c01 = hn::Set(df, 0.1f), c15 = hn::Set(df, 1.5f), m12 = hn::Set(df, -12.0f);
  const bool do_boost = job.coverage_boost != 1.0f;
  auto compute = [&](int x) {
    auto L = [&](int c) {
      const auto t = hn::LoadU(df, job.top + static_cast<std::size_t>(c) * w + x);
      return hn::Add(t, hn::Mul(hn::Sub(hn::LoadU(df, job.bot + static_cast<std::size_t>(c) * w + x), t), wy));
    };
    auto n0 = L(0), n1 = L(1), n2 = L(2), n3 = L(3), n4 = L(4);
    auto s = hn::LoadU(df, job.s + x);
    s = hn::IfThenElse(hn::Lt(s, zero), hn::Max(hn::Mul(s, rescale), m1), s);
    hn::Vec<decltype(df)> ba;
    if (job.g3d) {
      ba = hn::Min(hn::Max(hn::Mul(m12, s), zero), one);
    } else {
      if (job.double_coc) s = hn::Min(hn::Max(hn::Mul(two, s), m1), one);
      if (do_boost) {
        const auto a = hn::Min(hn::Max(hn::Mul(boost, n4), zero), one);
        const auto g = hn::IfThenElseZero(hn::Gt(n4, zero), hn::Div(a, n4));
        n0 = hn::Mul(n0, g);
        n1 = hn::Mul(n1, g);
        n2 = hn::Mul(n2, g);
        n3 = hn::Mul(n3, g);
        n4 = a;
      }
      s = hn::IfThenElse(hn::Gt(s, c01), hn::Min(hn::Mul(c15, s), one), s);
      ba = hn::Abs(s);
    }
    const auto keep = hn::Sub(one, n4);
    const hn::Vec<decltype(df)> nn[4] = {n0, n1, n2, n3};
    for (int c = 0; c < 4; ++c) {
      const auto sharp = hn::LoadU(df, job.col[c] + x);
      auto v = hn::Add(sharp, hn::Mul(hn::Sub(L(5 + c), sharp), ba));
      if (job.g3d) v = hn::Max(v, zero);
      hn::StoreU(hn::Add(hn::Mul(v, keep), nn[c]), df, job.out[c] + x);
    }
  };
  int x = 0;
  for (; x + lanes <= w; x += lanes) compute(x);
  if (x < w) {
    if (w >= lanes) {
      compute(w - lanes);
    } else {
      // Narrower than one vector: pad through a small stack copy.
      // Pad to one vector through stack copies (lanes <= 16).
      alignas(64) float top[9 * 64] = {}, bot[9 * 64] = {}, col[4][64] = {}, s[64] = {}, out[4][64] = {};
      for (int c = 0; c < 9; ++c) {
        std::copy_n(job.top + static_cast<std::size_t>(c) * w, w, top + c * lanes);
        std::copy_n(job.bot + static_cast<std::size_t>(c) * w, w, bot + c * lanes);
      }
      for (int c = 0; c < 4; ++c) std::copy_n(job.col[c], w, col[c]);
      std::copy_n(job.s, w, s);
      CompositeRowJob p = job;
      p.top = top;
      p.bot = bot;
      p.w = lanes;
      for (int c = 0; c < 4; ++c) {
        p.col[c] = col[c];
        p.out[c] = out[c];
      }
      p.s = s;
      CompositeRow(p);
      for (int c = 0; c < 4; ++c) std::copy_n(out[c], w, job.out[c]);
    }
  }
}

}  // namespace HWY_NAMESPACE
}  // namespace dofkit::detail::mcguire
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace dofkit::detail::mcguire {
HWY_EXPORT(FarGather);
void far_gather_simd(const GatherJob& job) { HWY_DYNAMIC_DISPATCH(FarGather)(job); }
HWY_EXPORT(CompositeRow);
void composite_row_simd(const CompositeRowJob& job) { HWY_DYNAMIC_DISPATCH(CompositeRow)(job); }
}  // namespace dofkit::detail::mcguire
#endif  // HWY_ONCE
