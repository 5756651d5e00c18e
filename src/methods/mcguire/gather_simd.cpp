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
#include <limits>
#include <type_traits>

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "methods/mcguire/gather_simd.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace dofkit::detail::mcguire {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// The table index without a division per tap. Per source the caller stores den and
// inv = RN(1/den). For x = d5/den (exact), q1 = RN(d5·inv) = x(1 + e) with |e| <= 2u + u²
// (u = 2^-24), and far_weight()'s q = RN(x) = x(1 + e'), |e'| <= u. ⌊q⌋ and ⌊q1⌋ differ only
// if an integer k lies between them, and then |q1 − k| <= |q1 − q| <= x·(3u + u²) < 1.1e-6
// for x <= 6.0001 (larger quotients all index 6). So q1 is clamped to [0.5, 6.5] (index 0
// below, 6 above: the clamp keeps every index) and, in a vector where some lane lies within
// 2^-19 of an integer, q is recomputed by the division: the index is exactly the plain one.
//
// Index from the clamped q (16 lanes): its float bits >> 21 are the exponent and the two top
// mantissa bits, 504 … 518 over [0.5, 6.5]: [0.5, 1) → 504-507, [1, 2) → 508-511,
// [2, 2.5) [2.5, 3) → 512, 513, [3, 4) → 514, 515, [4, 5) → 516, [5, 6) → 517, [6, 6.5] → 518;
// minus 504 it indexes a 16-entry table with each weight repeated over its range, one
// shift and one subtraction instead of Floor and the bits of ⌊q⌋ + 2^23 (the rounding is
// the longest step on the per-tap chain that bounds the kernel). Other lane counts use ⌊q⌋.
//
// With job.frac false the lerp by nearness is skipped (w = wn): lanes with nearness 0 get
// w exactly as before (wn + (1 − wn)·0 = wn), the others are overwritten by the caller.
// Two output vectors share each tap's loads of pointer and d5 where there are registers for
// both accumulator sets (AVX-512: 32); each output's sum is in the same order as alone.
template <bool kOcclusion, bool kFrac>
void FarGatherT(const GatherJob& job) {
  const hn::ScalableTag<float> df;
  const hn::RebindToSigned<decltype(df)> di;
  using VF = hn::Vec<decltype(df)>;
  const int lanes = static_cast<int>(hn::Lanes(df));
  constexpr bool kShiftIndex = hn::MaxLanes(decltype(df)()) == 16;
#if HWY_ARCH_X86 && HWY_TARGET <= HWY_AVX3
  constexpr int kPair = 2;
#else
  constexpr int kPair = 1;
#endif
  const auto one = hn::Set(df, 1.0f), zero = hn::Zero(df), c15 = hn::Set(df, 1.5f);
  const auto half = hn::Set(df, 0.5f), c65 = hn::Set(df, 6.5f), eps = hn::Set(df, 1.0f / 524288.0f);  // 2^-19
  const auto magic = hn::Set(df, 8388608.0f);
  const auto magic_bits = hn::BitCast(di, magic), i504 = hn::Set(di, 504);
  const bool permute = lanes >= 8 && lanes <= 16;
  alignas(64) float rep[16];
  for (int i = 0; i < 16; ++i) rep[i] = job.table[i < 8 ? i / 4 : i < 12 ? 2 + (i - 8) / 2 : i < 15 ? i - 8 : 7];
  const auto table = hn::LoadU(df, kShiftIndex ? rep : job.table);  // first `lanes` entries (16 are allocated)
  const int off = job.tap_offset;
  const std::ptrdiff_t cs = job.col_stride, as = job.aux_stride;
  // Clamped quotient of one vector, exact where it matters (see above). Targets with fewer
  // lanes divide: their divider keeps up (AVX2: a 256-bit division every ~5 cycles against
  // ~10 for 512 bits), and the test would cost more instructions than it saves.
  auto quotient = [&](const VF d5, const float* aux) {
    if (!kShiftIndex) return hn::Min(hn::Max(hn::Div(d5, hn::LoadU(df, aux + as)), half), c65);
    auto q = hn::Min(hn::Max(hn::Mul(d5, hn::LoadU(df, aux)), half), c65);
    if (HWY_UNLIKELY(!hn::AllFalse(df, hn::Lt(hn::Abs(hn::Sub(q, hn::Round(q))), eps))))
      q = hn::Min(hn::Max(hn::Div(d5, hn::LoadU(df, aux + as)), half), c65);
    return q;
  };
  auto weight = [&](const VF q) {
    if (kShiftIndex) {
      const auto idx = hn::Sub(hn::ShiftRight<21>(hn::BitCast(di, q)), i504);
      return hn::TableLookupLanes(table, hn::IndicesFromVec(df, idx));
    }
    const auto idx = hn::Sub(hn::BitCast(di, hn::Add(hn::Floor(q), magic)), magic_bits);
    return permute ? hn::TableLookupLanes(table, hn::IndicesFromVec(df, idx)) : hn::GatherIndex(df, job.table, idx);
  };
  // kV output vectors from output o on (kV <= kPair).
  auto compute = [&](auto vc, int o) {
    constexpr int kV = decltype(vc)::value;
    VF n[kV], abs_a[kV], a0[kV], a1[kV], a2[kV], a3[kV], aw[kV];
    for (int v = 0; v < kV; ++v) {
      if (kFrac) n[v] = hn::LoadU(df, job.nearness + o + v * lanes);
      if (kOcclusion) abs_a[v] = hn::Abs(hn::LoadU(df, job.r_a + o + v * lanes));
      a0[v] = a1[v] = a2[v] = a3[v] = aw[v] = zero;
    }
    for (int t = 0; t < job.ntaps; ++t) {
      const GatherTap& tp = job.taps[t];
      const VF d5 = hn::Set(df, tp.d5);
      for (int v = 0; v < kV; ++v) {
        const float* col = tp.col + o + off + v * lanes;
        const float* aux = tp.aux + o + off + v * lanes;
        auto w = weight(quotient(d5, aux));
        if (kOcclusion) {
          const auto occ = hn::Add(hn::Sub(abs_a[v], hn::LoadU(df, aux + 2 * as)), c15);
          w = hn::Mul(w, hn::Min(hn::Max(occ, zero), one));
        }
        if (kFrac) w = hn::MulAdd(hn::Sub(one, w), n[v], w);
        a0[v] = hn::MulAdd(w, hn::LoadU(df, col), a0[v]);
        a1[v] = hn::MulAdd(w, hn::LoadU(df, col + cs), a1[v]);
        a2[v] = hn::MulAdd(w, hn::LoadU(df, col + 2 * cs), a2[v]);
        a3[v] = hn::MulAdd(w, hn::LoadU(df, col + 3 * cs), a3[v]);
        aw[v] = hn::Add(aw[v], w);
      }
    }
    for (int v = 0; v < kV; ++v) {
      const int ov = o + v * lanes;
      hn::StoreU(hn::Div(a0[v], aw[v]), df, job.out[0] + ov);
      hn::StoreU(hn::Div(a1[v], aw[v]), df, job.out[1] + ov);
      hn::StoreU(hn::Div(a2[v], aw[v]), df, job.out[2] + ov);
      hn::StoreU(hn::Div(a3[v], aw[v]), df, job.out[3] + ov);
    }
  };
  if (job.n >= lanes) {
    int o = 0;
    for (; o + kPair * lanes <= job.n; o += kPair * lanes) compute(std::integral_constant<int, kPair>{}, o);
    for (; o + lanes <= job.n; o += lanes) compute(std::integral_constant<int, 1>{}, o);
    // Tail: one more vector that ends at n (recomputes a few outputs with identical values).
    if (o < job.n) compute(std::integral_constant<int, 1>{}, job.n - lanes);
    return;
  }
  // Fewer outputs than lanes: scalar, with far_weight()'s division.
  for (int o = 0; o < job.n; ++o) {
    const float abs_a = job.r_a[o] < 0 ? -job.r_a[o] : job.r_a[o];
    float a[4] = {0, 0, 0, 0}, aw = 0;
    for (int t = 0; t < job.ntaps; ++t) {
      const GatherTap& tp = job.taps[t];
      const float* col = tp.col + o + off;
      const float* aux = tp.aux + o + off;
      const float q = tp.d5 / aux[as];
      float wn = job.table[q >= 6.0f ? 6 : static_cast<int>(q)];
      if (kOcclusion) {
        const float occ = abs_a - aux[2 * as] + 1.5f;
        wn *= occ < 0 ? 0.0f : occ > 1 ? 1.0f : occ;
      }
      const float w = kFrac ? wn + (1.0f - wn) * job.nearness[o] : wn;
      for (int c = 0; c < 4; ++c) a[c] += w * col[c * cs];
      aw += w;
    }
    for (int c = 0; c < 4; ++c) job.out[c][o] = a[c] / aw;
  }
}

void FarGather(const GatherJob& job) {
  if (job.occlusion) {
    if (job.frac) FarGatherT<true, true>(job);
    else FarGatherT<true, false>(job);
  } else {
    if (job.frac) FarGatherT<false, true>(job);
    else FarGatherT<false, false>(job);
  }
}

void CompositeRow(const CompositeRowJob& job) {
  const hn::ScalableTag<float> df;
  const int lanes = static_cast<int>(hn::Lanes(df));
  const int w = job.w;
  const auto zero = hn::Zero(df), one = hn::Set(df, 1.0f), m1 = hn::Set(df, -1.0f);
  const auto wy = hn::Set(df, job.wy), rescale = hn::Set(df, job.far_rescale), boost = hn::Set(df, job.coverage_boost);
  const auto focus = hn::Set(df, job.focus_px), inv_rmax = hn::Set(df, job.inv_rmax);
  const auto two = hn::Set(df, 2.0f), c01 = hn::Set(df, 0.1f), c15 = hn::Set(df, 1.5f), m12 = hn::Set(df, -12.0f);
  const bool do_boost = job.coverage_boost != 1.0f;
  auto compute = [&](int x) {
    auto L = [&](int c) {
      const auto t = hn::LoadU(df, job.top + static_cast<std::size_t>(c) * w + x);
      return hn::Add(t, hn::Mul(hn::Sub(hn::LoadU(df, job.bot + static_cast<std::size_t>(c) * w + x), t), wy));
    };
    auto n0 = L(0), n1 = L(1), n2 = L(2), n3 = L(3), n4 = L(4);
    // s exactly as pack_coc: 0 in the focus field, else clamp(r / R_max, −1, 1).
    const auto r = hn::LoadU(df, job.coc + x);
    auto s = hn::IfThenZeroElse(hn::Le(hn::Abs(r), focus), hn::Min(hn::Max(hn::Mul(r, inv_rmax), m1), one));
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
    // Every load before the first store: the input and output planes of a frame whose
    // plane size is a multiple of 4 KiB share their addresses' low 12 bits, and a load
    // issued after a store to such an address waits on it (4K aliasing).
    hn::Vec<decltype(df)> v[4];
    for (int c = 0; c < 4; ++c) {
      const auto sharp = hn::LoadU(df, job.col[c] + x);
      v[c] = hn::Add(sharp, hn::Mul(hn::Sub(L(5 + c), sharp), ba));
    }
    for (int c = 0; c < 4; ++c) {
      if (job.g3d) v[c] = hn::Max(v[c], zero);
      hn::StoreU(hn::Add(hn::Mul(v[c], keep), nn[c]), df, job.out[c] + x);
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
      alignas(64) float top[9 * 64] = {}, bot[9 * 64] = {}, col[4][64] = {}, coc[64] = {}, out[4][64] = {};
      for (int c = 0; c < 9; ++c) {
        std::copy_n(job.top + static_cast<std::size_t>(c) * w, w, top + c * lanes);
        std::copy_n(job.bot + static_cast<std::size_t>(c) * w, w, bot + c * lanes);
      }
      for (int c = 0; c < 4; ++c) std::copy_n(job.col[c], w, col[c]);
      std::copy_n(job.coc, w, coc);
      CompositeRowJob p = job;
      p.top = top;
      p.bot = bot;
      p.w = lanes;
      for (int c = 0; c < 4; ++c) {
        p.col[c] = col[c];
        p.out[c] = out[c];
      }
      p.coc = coc;
      CompositeRow(p);
      for (int c = 0; c < 4; ++c) std::copy_n(out[c], w, job.out[c]);
    }
  }
}

void InterpRow(const InterpRowJob& job) {
  const hn::ScalableTag<float> df;
  const hn::RebindToSigned<decltype(df)> di;
  const int lanes = static_cast<int>(hn::Lanes(df));
  const int w = job.w;
  int x = 0;
  if (job.f_pattern >= 2 && lanes % job.f_pattern == 0) {  // f = 1: l / f + 1 would leave the vector
    // i0[x] = x / f, i1 = i0 + 1: the lanes of output x0 (a multiple of f) read texels
    // x0/f + l/f and x0/f + l/f + 1, a permutation of one unaligned load, while the
    // load and i1 stay inside the row (the remaining outputs take the gather path).
    const int f = job.f_pattern;
    alignas(64) int32_t lane0[64], lane1[64];
    for (int l = 0; l < lanes; ++l) {
      lane0[l] = l / f;
      lane1[l] = l / f + 1;
    }
    const auto idx0 = hn::SetTableIndices(df, lane0), idx1 = hn::SetTableIndices(df, lane1);
    for (; x + lanes <= w && x / f + lanes <= job.n_low; x += lanes) {
      const auto w1 = hn::LoadU(df, job.w1 + x);
      for (int c = 0; c < job.nc; ++c) {
        const auto v = hn::LoadU(df, job.src[c] + x / f);
        const auto a = hn::TableLookupLanes(v, idx0), b = hn::TableLookupLanes(v, idx1);
        hn::StoreU(hn::Add(a, hn::Mul(hn::Sub(b, a), w1)), df, job.dst + static_cast<std::size_t>(c) * w + x);
      }
    }
  }
  for (; x + lanes <= w; x += lanes) {
    const auto i0 = hn::LoadU(di, job.i0 + x), i1 = hn::LoadU(di, job.i1 + x);
    const auto w1 = hn::LoadU(df, job.w1 + x);
    for (int c = 0; c < job.nc; ++c) {
      const auto a = hn::GatherIndex(df, job.src[c], i0);
      const auto b = hn::GatherIndex(df, job.src[c], i1);
      hn::StoreU(hn::Add(a, hn::Mul(hn::Sub(b, a), w1)), df, job.dst + static_cast<std::size_t>(c) * w + x);
    }
  }
  for (; x < w; ++x)
    for (int c = 0; c < job.nc; ++c) {
      const float a = job.src[c][job.i0[x]], b = job.src[c][job.i1[x]];
      job.dst[static_cast<std::size_t>(c) * w + x] = a + (b - a) * job.w1[x];
    }
}

// Keeps the compiler from fusing the multiply that produced v into a following add: den
// must round exactly as the scalar 0.001 + c·|r| of far_weight() (a contracted FMA would
// move the table index at its steps).
template <class V>
HWY_INLINE V Opaque(V v) {
#if HWY_ARCH_X86 && HWY_TARGET != HWY_SCALAR && HWY_TARGET != HWY_EMU128
  asm("" : "+v"(v.raw));
#endif
  return v;
}

// Phase split of one padded plane: dst[p·M + m] = src[f·m + p] for m < mcount (+ up to one
// vector more, inside the slack).
template <class D>
HWY_INLINE void SplitPhases(D d, int f, int M, int mcount, const float* src, float* dst) {
  const int lanes = static_cast<int>(hn::Lanes(d));
  hn::Vec<D> v0, v1, v2, v3;
  for (int m = 0; m < mcount; m += lanes) {
    const float* p = src + static_cast<std::size_t>(f) * m;
    switch (f) {
      case 1:
        hn::StoreU(hn::LoadU(d, p), d, dst + m);
        break;
      case 2:
        hn::LoadInterleaved2(d, p, v0, v1);
        hn::StoreU(v0, d, dst + m);
        hn::StoreU(v1, d, dst + M + m);
        break;
      case 3:
        hn::LoadInterleaved3(d, p, v0, v1, v2);
        hn::StoreU(v0, d, dst + m);
        hn::StoreU(v1, d, dst + M + m);
        hn::StoreU(v2, d, dst + 2 * M + m);
        break;
      default:
        hn::LoadInterleaved4(d, p, v0, v1, v2, v3);
        hn::StoreU(v0, d, dst + m);
        hn::StoreU(v1, d, dst + M + m);
        hn::StoreU(v2, d, dst + 2 * M + m);
        hn::StoreU(v3, d, dst + 3 * M + m);
        break;
    }
  }
}

void PrepRow(PrepRowJob& job) {
  const hn::ScalableTag<float> df;
  const hn::RebindToSigned<decltype(df)> di;
  const int lanes = static_cast<int>(hn::Lanes(df));
  const auto one = hn::Set(df, 1.0f), m1 = hn::Set(df, -1.0f), zero = hn::Zero(df);
  const auto focus = hn::Set(df, job.focus_px), inv_rmax = hn::Set(df, job.inv_rmax), rmax = hn::Set(df, job.rmax);
  const auto c0001 = hn::Set(df, 0.001f), dc = hn::Set(df, job.dc), c12 = hn::Set(df, 1.2f), q = hn::Set(df, 0.25f);
  const auto ione = hn::Set(di, 1);
  auto any = hn::Zero(df);
  // Contiguous: s, r_B, reach. Runs 64 floats past P (inside the slack) so that the phase
  // split of r_B below, which reads up to f·lanes − 1 floats past P, reads computed values.
  for (int x = 0; x < job.P + 64; x += lanes) {
    const auto r = hn::LoadU(df, job.pad[4] + x);
    const auto s = hn::IfThenZeroElse(hn::Le(hn::Abs(r), focus), hn::Min(hn::Max(hn::Mul(r, inv_rmax), m1), one));
    const auto rb = hn::Mul(s, rmax);
    if (x < job.P) any = hn::Max(any, rb);  // lanes past P replicate the last pixel
    hn::StoreU(s, df, job.s_pad + x);
    hn::StoreU(rb, df, job.rb_pad + x);
    const auto den = hn::Add(c0001, Opaque(hn::Mul(dc, hn::Abs(rb))));
    const auto reach = hn::Add(hn::ConvertTo(di, hn::Mul(c12, den)), ione);
    hn::StoreU(hn::IfThenElseZero(hn::RebindMask(di, hn::Le(rb, q)), reach), di, job.reach + x);
  }
  job.any_near = !hn::AllTrue(df, hn::Le(any, zero));
  if (job.near_h != nullptr && job.any_near) {
    // α as near_alpha_horizontal (d = 0): code a = saturate((4·r)·inv_near), prose
    // a = min(1, r·inv_near); then (a²)². Only multiplies: nothing to contract.
    const auto inv_near = hn::Set(df, job.inv_near), four = hn::Set(df, 4.0f);
    const auto hbox = hn::Set(di, job.hbox), im1 = hn::Set(di, -1), ibig = hn::Set(di, 1 << 30);
    auto hmin = ibig, hmax = im1;
    int count = 0, first_x = -1, last_x = -1;
    // Up to 16 floats past P (inside the slack) so that block sums that run a few sources
    // past the last output's reach read defined values.
    for (int x = 0; x < job.P + 16; x += lanes) {
      const auto rb = hn::LoadU(df, job.rb_pad + x);
      const auto pos = hn::Gt(rb, zero);
      auto a = job.alpha_code ? hn::Min(hn::Max(hn::Mul(hn::Mul(four, rb), inv_near), zero), one)
                              : hn::Min(one, hn::Mul(rb, inv_near));
      a = hn::Mul(a, a);
      a = hn::Mul(a, a);
      hn::StoreU(hn::IfThenElseZero(pos, a), df, job.near_a + x);
      // r_B > 0: truncation = floor; r_B <= 0 lanes are replaced by −1 (their conversion
      // result is not used).
      const auto h = hn::Min(hn::ConvertTo(di, hn::IfThenElseZero(pos, rb)), hbox);
      hn::StoreU(hn::IfThenElse(hn::RebindMask(di, pos), h, im1), di, job.near_h + x);
      // Statistics over x < P only (the last vector may run past P into the slack).
      if (x >= job.P) continue;
      const auto in = x + lanes <= job.P ? pos : hn::And(pos, hn::FirstN(df, static_cast<std::size_t>(job.P - x)));
      if (!hn::AllFalse(df, in)) {
        const auto mi = hn::RebindMask(di, in);
        hmin = hn::Min(hmin, hn::IfThenElse(mi, h, ibig));
        hmax = hn::Max(hmax, hn::IfThenElse(mi, h, im1));
        count += static_cast<int>(hn::CountTrue(df, in));
        if (first_x < 0) first_x = x;
        last_x = x;
      }
    }
    job.near_count = count;
    if (count > 0) {
      alignas(64) int32_t lo[64], hi[64];
      hn::Store(hmin, di, lo);
      hn::Store(hmax, di, hi);
      job.near_hmin = *std::min_element(lo, lo + lanes);
      job.near_hmax = *std::max_element(hi, hi + lanes);
      while (job.near_h[first_x] < 0) ++first_x;
      last_x = std::min(last_x + lanes, job.P) - 1;
      while (job.near_h[last_x] < 0) --last_x;
      job.near_first = first_x;
      job.near_last = last_x;
    }
  }
  const int f = job.f, M = job.M, mcount = (job.P + f - 1) / f;
  const std::size_t plane = static_cast<std::size_t>(f) * M;
  for (int c = 0; c < 4; ++c) SplitPhases(df, f, M, mcount, job.pad[c], job.ph + c * plane);
  float* inv_pl = job.ph + 4 * plane;
  float* den_pl = job.ph + 5 * plane;
  float* abs_pl = job.ph + 6 * plane;
  SplitPhases(df, f, M, mcount, job.rb_pad, abs_pl);  // r_B, made |r_B| below
  const auto inf = hn::Set(df, std::numeric_limits<float>::infinity());
  for (int p = 0; p < f; ++p)
    for (int m = 0; m < mcount; m += lanes) {
      const std::size_t at = static_cast<std::size_t>(p) * M + m;
      const auto rb = hn::LoadU(df, abs_pl + at);
      const auto ab = hn::Abs(rb);
      const auto near = hn::Gt(rb, q);
      const auto den = hn::Add(c0001, Opaque(hn::Mul(dc, ab)));
      hn::StoreU(hn::IfThenElse(near, inf, hn::Div(one, den)), df, inv_pl + at);
      hn::StoreU(hn::IfThenZeroElse(near, den), df, den_pl + at);
      hn::StoreU(ab, df, abs_pl + at);
    }
}

void SlideRows(const SlideRowsJob& job) {
  const hn::ScalableTag<double> dd;
  const hn::Rebind<float, decltype(dd)> df;
  const int lanes = static_cast<int>(hn::Lanes(dd));
  int i = 0;
  for (; i + lanes <= job.n; i += lanes) {
    auto acc = hn::LoadU(dd, job.dst + i);
    for (int k = 0; k < job.nplus; ++k) acc = hn::Add(acc, hn::PromoteTo(dd, hn::LoadU(df, job.plus[k] + i)));
    for (int k = 0; k < job.nminus; ++k) acc = hn::Sub(acc, hn::PromoteTo(dd, hn::LoadU(df, job.minus[k] + i)));
    hn::StoreU(acc, dd, job.dst + i);
  }
  for (; i < job.n; ++i) {
    double acc = job.dst[i];
    for (int k = 0; k < job.nplus; ++k) acc += static_cast<double>(job.plus[k][i]);
    for (int k = 0; k < job.nminus; ++k) acc -= static_cast<double>(job.minus[k][i]);
    job.dst[i] = acc;
  }
}

void BlockSums(const BlockSumsJob& job) {
  const hn::ScalableTag<double> dd;
  const hn::Rebind<float, decltype(dd)> df;
  const int lanes = static_cast<int>(hn::Lanes(dd));
  const float* ph[4];
  for (int t = 0; t < job.f; ++t) {
    const int x = job.x0 + t;
    ph[t] = job.ph_plane + static_cast<std::size_t>(x % job.f) * job.M + x / job.f;
  }
  int j = 0;
  for (; j + lanes <= job.nb; j += lanes) {
    auto g = hn::Zero(dd), part = hn::Zero(dd);
    for (int t = 0; t < job.f; ++t) {
      g = hn::Add(g, hn::PromoteTo(dd, hn::LoadU(df, ph[t] + j)));
      if (t + 1 == job.rem) part = g;
    }
    hn::StoreU(g, dd, job.G + j);
    hn::StoreU(part, dd, job.Rm + j);
  }
  for (; j < job.nb; ++j) {
    double g = 0, part = 0;
    for (int t = 0; t < job.f; ++t) {
      g += static_cast<double>(ph[t][j]);
      if (t + 1 == job.rem) part = g;
    }
    job.G[j] = g;
    job.Rm[j] = part;
  }
}

template <int F>
void LevelBlocksF(const LevelBlocksJob& job) {
  int j = 0;
#if HWY_TARGET != HWY_SCALAR
  const hn::ScalableTag<float> df;
  const hn::RebindToSigned<decltype(df)> di;
  const hn::Repartition<double, decltype(df)> dd;  // half as many lanes
  const hn::Half<decltype(df)> dh;
  const int N = static_cast<int>(hn::Lanes(df)), Nd = static_cast<int>(hn::Lanes(dd));
  const auto level = hn::Set(di, job.level);
  using VF = hn::Vec<decltype(df)>;
  for (; j + N <= job.nb; j += N) {
    const std::size_t x = static_cast<std::size_t>(job.x0) + static_cast<std::size_t>(F) * j;
    VF av[4], hv[4];
    if (F == 4) {
      hn::LoadInterleaved4(df, job.a + x, av[0], av[1], av[2], av[3]);
      hn::LoadInterleaved4(df, reinterpret_cast<const float*>(job.h) + x, hv[0], hv[1], hv[2], hv[3]);
    } else {
      hn::LoadInterleaved2(df, job.a + x, av[0], av[1]);
      hn::LoadInterleaved2(df, reinterpret_cast<const float*>(job.h) + x, hv[0], hv[1]);
    }
    for (int t = 0; t < F; ++t) av[t] = hn::IfThenElseZero(hn::RebindMask(df, hn::Eq(hn::BitCast(di, hv[t]), level)), av[t]);
    for (int c = 0; c < 5; ++c) {
      VF v[4];
      if (c < 4) {
        if (F == 4) hn::LoadInterleaved4(df, job.col[c] + x, v[0], v[1], v[2], v[3]);
        else hn::LoadInterleaved2(df, job.col[c] + x, v[0], v[1]);
        for (int t = 0; t < F; ++t) v[t] = hn::Mul(av[t], v[t]);
      } else {
        for (int t = 0; t < F; ++t) v[t] = av[t];
      }
      auto glo = hn::Zero(dd), ghi = hn::Zero(dd), plo = glo, phi = glo;
      for (int t = 0; t < F; ++t) {
        glo = hn::Add(glo, hn::PromoteTo(dd, hn::LowerHalf(dh, v[t])));
        ghi = hn::Add(ghi, hn::PromoteTo(dd, hn::UpperHalf(dh, v[t])));
        if (t + 1 == job.rem) {
          plo = glo;
          phi = ghi;
        }
      }
      hn::StoreU(glo, dd, job.G[c] + j);
      hn::StoreU(ghi, dd, job.G[c] + j + Nd);
      hn::StoreU(plo, dd, job.Rm[c] + j);
      hn::StoreU(phi, dd, job.Rm[c] + j + Nd);
    }
  }
#endif
  for (; j < job.nb; ++j) {
    double g[5] = {0, 0, 0, 0, 0}, part[5] = {0, 0, 0, 0, 0};
    for (int t = 0; t < F; ++t) {
      const int x = job.x0 + F * j + t;
      if (job.h[x] == job.level) {
        const float a = job.a[x];
        for (int c = 0; c < 4; ++c) g[c] += static_cast<double>(a * job.col[c][x]);
        g[4] += a;
      }
      if (t + 1 == job.rem)
        for (int c = 0; c < 5; ++c) part[c] = g[c];
    }
    for (int c = 0; c < 5; ++c) {
      job.G[c][j] = g[c];
      job.Rm[c][j] = part[c];
    }
  }
}

void LevelBlocks(const LevelBlocksJob& job) {
  if (job.f == 4) LevelBlocksF<4>(job);
  else LevelBlocksF<2>(job);
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
HWY_EXPORT(InterpRow);
void interp_row_simd(const InterpRowJob& job) { HWY_DYNAMIC_DISPATCH(InterpRow)(job); }
HWY_EXPORT(SlideRows);
void slide_rows_simd(const SlideRowsJob& job) { HWY_DYNAMIC_DISPATCH(SlideRows)(job); }
HWY_EXPORT(PrepRow);
void prep_row_simd(PrepRowJob& job) { HWY_DYNAMIC_DISPATCH(PrepRow)(job); }
HWY_EXPORT(BlockSums);
void block_sums_simd(const BlockSumsJob& job) { HWY_DYNAMIC_DISPATCH(BlockSums)(job); }
HWY_EXPORT(LevelBlocks);
void level_blocks_simd(const LevelBlocksJob& job) { HWY_DYNAMIC_DISPATCH(LevelBlocks)(job); }
}  // namespace dofkit::detail::mcguire
#endif  // HWY_ONCE
