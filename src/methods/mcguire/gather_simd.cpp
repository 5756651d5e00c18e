// Highway kernel of gather.hpp (run-time dispatch: AVX-512 / AVX2 / SSE4 / scalar).
//
// The table index must be exactly the scalar one, ⌊RN(5|δ| / den)⌋ clamped to 6: a weight
// step (e.g. 1 → 0.9) on one tap would move the result by far more than rounding does. So
// the kernel divides (IEEE division is correctly rounded in every lane) instead of
// multiplying by a reciprocal, and den is precomputed by scalar code. Accumulation uses FMA,
// which rounds differently from the plain pass's separate multiply and add (≈ 1 ulp per tap).
#include "methods/mcguire/gather.hpp"

#include "render/sanitize.hpp"

#include <algorithm>
#include <cstddef>
#include <cstring>
#include <limits>
#include <type_traits>

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "methods/mcguire/gather_simd.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/cache_control.h>
#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace dofkit::detail::mcguire {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// The table index without a division per tap (16-lane targets; the others divide: their
// divider keeps up — AVX2 issues a 256-bit division every ~5 cycles, AVX-512 a 512-bit one
// every ~10 — and the test below would cost them more than it saves). Per source the caller
// stores den and inv = RN(1/den). For x = d5/den (exact), q1 = RN(d5·inv) = x(1 + e) with
// |e| <= 2u + u² (u = 2^-24), and far_weight()'s q = RN(x) = x(1 + e'), |e'| <= u. ⌊q⌋ and
// ⌊q1⌋ differ only if an integer k lies between them, and then |q1 − k| <= |q1 − q| <=
// x·(3u + u²) <= 3.0001·u·k: within 4 steps of the float grid around k (its spacing is
// >= u·k below k). The integers 1 … 6 have the low 21 bits of their float encoding 0, so
// every q1 within 16 steps of one has (bits + 16) mod 2^21 < 32, and a vector with such a
// lane divides instead: the index is exactly the plain one. (A few other q1 share the
// pattern — near 1.25, 1.5, …, and 1 in ~65 000 of those below 1 — and divide for nothing.)
// Quotients above 6.5 all index 6, so q1 is clamped there (6.5's pattern is far from 0);
// then the truncation to int (an exact floor for q1 >= 0; on x86 one cvttps2dq, without
// Highway's out-of-range fix-up, which cannot occur here) is the index, 0 … 6.
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
  constexpr bool kRecip = hn::MaxLanes(decltype(df)()) == 16;
#if HWY_ARCH_X86 && HWY_TARGET <= HWY_AVX3
  constexpr int kPair = 2;
#else
  constexpr int kPair = 1;
#endif
  const auto one = hn::Set(df, 1.0f), zero = hn::Zero(df), c15 = hn::Set(df, 1.5f), c65 = hn::Set(df, 6.5f);
  const auto magic = hn::Set(df, 8388608.0f);
  const auto magic_bits = hn::BitCast(di, magic);
  const auto i16 = hn::Set(di, 16), near_int = hn::Set(di, 0x1FFFE0), izero = hn::Zero(di);
  const bool permute = lanes >= 8 && lanes <= 16;
  const auto table = hn::LoadU(df, job.table);  // first `lanes` entries (16 are allocated)
  const int off = job.tap_offset;
  const std::ptrdiff_t cs = job.col_stride, as = job.aux_stride;
  auto trunc = [&](const VF q) {
#if HWY_ARCH_X86 && HWY_TARGET <= HWY_AVX3
    return hn::VFromD<decltype(di)>{_mm512_cvttps_epi32(q.raw)};
#else
    return hn::ConvertTo(di, q);
#endif
  };
  // min(table index, 6) of one vector, exactly as far_weight() (see above).
  auto index = [&](const VF d5, const float* aux) {
    if (!kRecip) {
      const auto q = hn::Min(hn::Div(d5, hn::LoadU(df, aux + as)), c65);
      return hn::Sub(hn::BitCast(di, hn::Add(hn::Floor(q), magic)), magic_bits);
    }
    auto q = hn::Min(hn::Mul(d5, hn::LoadU(df, aux)), c65);
    const auto pattern = hn::And(hn::Add(hn::BitCast(di, q), i16), near_int);
    if (HWY_UNLIKELY(!hn::AllFalse(di, hn::Eq(pattern, izero)))) q = hn::Min(hn::Div(d5, hn::LoadU(df, aux + as)), c65);
    return trunc(q);
  };
  auto weight = [&](const VF d5, const float* aux) {
    const auto idx = index(d5, aux);
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
        auto w = weight(d5, aux);
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
    if (job.frac)
      FarGatherT<true, true>(job);
    else
      FarGatherT<true, false>(job);
  } else {
    if (job.frac)
      FarGatherT<false, true>(job);
    else
      FarGatherT<false, false>(job);
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
  auto compute = [&](int x, auto stream) {
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
      const auto o = hn::Add(hn::Mul(v[c], keep), nn[c]);
      if constexpr (decltype(stream)::value)
        hn::Stream(o, df, job.out[c] + x);
      else
        hn::StoreU(o, df, job.out[c] + x);
    }
  };
  using NoStream = std::false_type;
  int x = 0;
  // The output is written once and not read again by the pass: where the four output rows
  // share their alignment, the vectors from the first aligned x on are non-temporal stores
  // (no read of each line into the cache first). The first vector is stored normally; the
  // aligned loop may recompute a few of its outputs (the same values). The caller orders
  // the streams with composite_flush_streams() before its task ends.
  const std::uintptr_t vb = static_cast<std::uintptr_t>(lanes) * sizeof(float);
  const std::uintptr_t mis = reinterpret_cast<std::uintptr_t>(job.out[0]) % vb;
  bool stream = job.stream && w >= 2 * lanes && mis % sizeof(float) == 0;
  for (int c = 1; c < 4 && stream; ++c) stream = reinterpret_cast<std::uintptr_t>(job.out[c]) % vb == mis;
  // The sharp colour and the CoC come from memory: prefetched 128 floats (8 lines per
  // plane) ahead (P4 on one thread measured ≈ 0.75 of its time once the stores stream; with
  // cached stores it gives nothing; prefetching the L2-resident interpolated rows too was
  // slower; docs/performance_mcguire.md).
  constexpr int kAhead = 128;
  auto prefetch = [&](int at) {
    for (int c = 0; c < 4; ++c) hwy::Prefetch(job.col[c] + at + kAhead);
    hwy::Prefetch(job.coc + at + kAhead);
  };
  if (stream) {
    compute(0, NoStream());
    x = mis == 0 ? lanes : static_cast<int>((vb - mis) / sizeof(float));
    for (; x + lanes <= w; x += lanes) {
      prefetch(x);
      compute(x, std::true_type());
    }
  } else {
    for (; x + lanes <= w; x += lanes) {
      prefetch(x);
      compute(x, NoStream());
    }
  }
  if (x < w) {
    if (w >= lanes) {
      compute(w - lanes, NoStream());
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

// Loads f·lanes consecutive floats as the f phase vectors v[p] = src[f·l + p].
template <int F, class D, class V>
HWY_INLINE void LoadPhases(D d, const float* src, V* v) {
  if (F == 1) v[0] = hn::LoadU(d, src);
  if (F == 2) hn::LoadInterleaved2(d, src, v[0], v[1]);
  if (F == 3) hn::LoadInterleaved3(d, src, v[0], v[1], v[2]);
  if (F == 4) hn::LoadInterleaved4(d, src, v[0], v[1], v[2], v[3]);
}

template <int F>
void PrepRowF(PrepRowJob& job, int m0, int m1) {
  const hn::ScalableTag<float> df;
  const hn::RebindToSigned<decltype(df)> di;
  using VF = hn::Vec<decltype(df)>;
  using VI = hn::Vec<decltype(di)>;
  const int lanes = static_cast<int>(hn::Lanes(df));
  const int W = job.W, R = job.R, M = job.M, P = W + 2 * R;
  const std::size_t plane = static_cast<std::size_t>(F) * M;
  const auto one = hn::Set(df, 1.0f), m1f = hn::Set(df, -1.0f), zero = hn::Zero(df), four = hn::Set(df, 4.0f);
  const auto focus = hn::Set(df, job.focus_px), inv_rmax = hn::Set(df, job.inv_rmax), rmax = hn::Set(df, job.rmax);
  const auto c0001 = hn::Set(df, 0.001f), dc = hn::Set(df, job.dc), c12 = hn::Set(df, 1.2f), q = hn::Set(df, 0.25f);
  const auto inf = hn::Set(df, std::numeric_limits<float>::infinity());
  const auto inv_near = hn::Set(df, job.inv_near);
  const VI ione = hn::Set(di, 1), izero = hn::Zero(di), hbox = hn::Set(di, job.hbox), im1 = hn::Set(di, -1);
  const VI ibig = hn::Set(di, 1 << 30);
  float* const inv_pl = job.ph + 4 * plane;
  float* const den_pl = job.ph + 5 * plane;
  float* const abs_pl = job.ph + 6 * plane;
  float* const a_pl = job.ph + 7 * plane;
  int32_t* const h_pl = reinterpret_cast<int32_t*>(job.ph + 8 * plane);
  // Edge vectors (a padded x outside the row): the clamped sources, through a stack copy.
  constexpr std::size_t kMax = 4 * hn::MaxLanes(decltype(df)());
  alignas(64) float tmp[5][kMax];
  VI hmin = ibig, hmax = im1;
  bool any = false;
  const auto min_normal = hn::Set(df, std::numeric_limits<float>::min()), max_colour = hn::Set(df, kMaxColorValue);
  auto bad = hn::Not(hn::Eq(zero, zero));  // all false
  for (int m = m0; m < m1; m += lanes) {
    const int s0 = F * m - R;  // source x of padded x = F·m
    const float* in[5];
    if (s0 >= 0 && s0 + F * lanes <= W) {
      for (int c = 0; c < 5; ++c) in[c] = job.src[c] + s0;
    } else {
      for (int c = 0; c < 5; ++c) {
        for (int t = 0; t < F * lanes; ++t) tmp[c][t] = job.src[c][std::clamp(s0 + t, 0, W - 1)];
        in[c] = tmp[c];
      }
    }
    VF v[F];
    for (int c = 0; c < 4; ++c) {
      LoadPhases<F>(df, in[c], v);
      for (int p = 0; p < F; ++p) hn::StoreU(v[p], df, job.ph + c * plane + static_cast<std::size_t>(p) * M + m);
      if (job.check_colour)
        for (int p = 0; p < F; ++p) {
          // sample_is_sanitary: ±0, or a normal number of magnitude <= kMaxColorValue
          // (colour) / in [FLT_MIN, 1] (alpha); NaN fails every comparison.
          const auto x = c < 3 ? hn::Abs(v[p]) : v[p];
          const auto ok =
              hn::Or(hn::Eq(v[p], zero), hn::And(hn::Ge(x, min_normal), hn::Le(x, c < 3 ? max_colour : one)));
          bad = hn::Or(bad, hn::Not(ok));
        }
    }
    LoadPhases<F>(df, in[4], v);
    VI reach = izero;
    for (int p = 0; p < F; ++p) {
      const std::size_t at = static_cast<std::size_t>(p) * M + m;
      const VF r = v[p];
      // s exactly as pack_coc, r_B = s·R_max; den as far_weight() (no contraction).
      const auto s = hn::IfThenZeroElse(hn::Le(hn::Abs(r), focus), hn::Min(hn::Max(hn::Mul(r, inv_rmax), m1f), one));
      const auto rb = hn::Mul(s, rmax);
      const auto ab = hn::Abs(rb);
      const auto den = hn::Add(c0001, Opaque(hn::Mul(dc, ab)));
      const auto near = hn::Gt(rb, q);
      hn::StoreU(hn::IfThenElse(near, inf, hn::Div(one, den)), df, inv_pl + at);
      hn::StoreU(hn::IfThenZeroElse(near, den), df, den_pl + at);
      if (job.abs_r) hn::StoreU(ab, df, abs_pl + at);
      const VI rp = hn::Add(hn::ConvertTo(di, hn::Mul(c12, den)), ione);
      reach = hn::Max(reach, hn::IfThenZeroElse(hn::RebindMask(di, near), rp));
      if (p == job.p0) {
        hn::StoreU(rb, df, job.rc + m);
        hn::StoreU(s, df, job.sc + m);
        hn::StoreU(hn::Min(hn::Max(hn::Mul(four, rb), zero), one), df, job.nc + m);
      }
      // Statistics over the groups [m0, m1) with x = F·m' + p < P.
      const int valid = std::min((P - p + F - 1) / F, m1) - m;
      const auto pos = hn::Gt(rb, zero);
      const auto in_range =
          valid >= lanes ? pos : hn::And(pos, hn::FirstN(df, static_cast<std::size_t>(std::max(valid, 0))));
      if (hn::AllFalse(df, in_range) && !job.near) continue;
      any = any || !hn::AllFalse(df, in_range);
      if (!job.near) continue;
      // α as near_alpha_horizontal (d = 0): code a = saturate((4·r)·inv_near), prose
      // a = min(1, r·inv_near); then (a²)². Only multiplies: nothing to contract.
      auto a = job.alpha_code ? hn::Min(hn::Max(hn::Mul(hn::Mul(four, rb), inv_near), zero), one)
                              : hn::Min(one, hn::Mul(rb, inv_near));
      a = hn::Mul(a, a);
      a = hn::Mul(a, a);
      hn::StoreU(hn::IfThenElseZero(pos, a), df, a_pl + at);
      // r_B > 0: truncation = floor; r_B <= 0 lanes are replaced by −1.
      const auto h = hn::Min(hn::ConvertTo(di, hn::IfThenElseZero(pos, rb)), hbox);
      hn::StoreU(hn::IfThenElse(hn::RebindMask(di, pos), h, im1), di, h_pl + at);
      if (!hn::AllFalse(df, in_range)) {
        const auto mi = hn::RebindMask(di, in_range);
        hmin = hn::Min(hmin, hn::IfThenElse(mi, h, ibig));
        hmax = hn::Max(hmax, hn::IfThenElse(mi, h, im1));
        job.near_count += static_cast<int>(hn::CountTrue(df, in_range));
        if (job.first_m < 0 || m < job.first_m) job.first_m = m;
        job.last_m = std::max(job.last_m, std::min(m + lanes, m1) - 1);
      }
    }
    hn::StoreU(reach, di, job.reach + m);
  }
  job.any_near = job.any_near || any;
  if (job.check_colour && !hn::AllFalse(df, bad)) job.dirty = true;
  if (job.near) {
    job.near_hmin = std::min(job.near_hmin, static_cast<int>(hn::GetLane(hn::MinOfLanes(di, hmin))));
    job.near_hmax = std::max(job.near_hmax, static_cast<int>(hn::GetLane(hn::MaxOfLanes(di, hmax))));
  }
}

void PrepRow(PrepRowJob& job, int m0, int m1) {
  switch (job.f) {
    case 1:
      PrepRowF<1>(job, m0, m1);
      break;
    case 2:
      PrepRowF<2>(job, m0, m1);
      break;
    case 3:
      PrepRowF<3>(job, m0, m1);
      break;
    default:
      PrepRowF<4>(job, m0, m1);
      break;
  }
}

void AuxRow(const AuxRowJob& job) {
  const hn::ScalableTag<float> df;
  const hn::RebindToSigned<decltype(df)> di;
  const int lanes = static_cast<int>(hn::Lanes(df));
  const auto rmax = hn::Set(df, job.rmax), c0001 = hn::Set(df, 0.001f), dc = hn::Set(df, job.dc);
  const auto c12 = hn::Set(df, 1.2f), q = hn::Set(df, 0.25f), one = hn::Set(df, 1.0f);
  const auto inf = hn::Set(df, std::numeric_limits<float>::infinity());
  const auto ione = hn::Set(di, 1);
  constexpr std::size_t kMax = hn::MaxLanes(decltype(df)());
  alignas(64) float tail[kMax] = {};
  for (int b0 = 0; b0 < job.w; b0 += job.block) {
    auto mx = hn::Zero(di);
    for (int i = b0; i < std::min(job.w, b0 + job.block); i += lanes) {
      const int n = std::min(lanes, job.w - i);
      const float* src = job.s + i;
      if (n < lanes) {  // the row may end at its image's end: no load past w
        std::copy_n(src, n, tail);
        src = tail;
      }
      const auto r = hn::Mul(hn::LoadU(df, src), rmax);
      const auto ab = hn::Abs(r);
      const auto den = hn::Add(c0001, Opaque(hn::Mul(dc, ab)));
      const auto near = hn::Gt(r, q);
      hn::StoreU(hn::IfThenElse(near, inf, hn::Div(one, den)), df, job.inv + i);
      hn::StoreU(hn::IfThenZeroElse(near, den), df, job.den + i);
      hn::StoreU(ab, df, job.absr + i);
      const auto far = n < lanes ? hn::AndNot(near, hn::FirstN(df, static_cast<std::size_t>(n))) : hn::Not(near);
      const auto reach = hn::Add(hn::ConvertTo(di, hn::Mul(c12, den)), ione);
      mx = hn::Max(mx, hn::IfThenElseZero(hn::RebindMask(di, far), reach));
    }
    job.blk_reach[b0 / job.block] = static_cast<float>(hn::GetLane(hn::MaxOfLanes(di, mx)));
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
  // Source x0 + F·j + t lies in phase (x0 + t) mod F at group (x0 + t) / F + j: per t one
  // contiguous run over j in each plane.
  const std::size_t plane = static_cast<std::size_t>(F) * job.M;
  const float* pc[4][F];
  const float* pa[F];
  const int32_t* ph[F];
  for (int t = 0; t < F; ++t) {
    const int x = job.x0 + t;
    const std::size_t off = static_cast<std::size_t>(x % F) * job.M + x / F;
    for (int c = 0; c < 4; ++c) pc[c][t] = job.ph + c * plane + off;
    pa[t] = job.ph + 7 * plane + off;
    ph[t] = reinterpret_cast<const int32_t*>(job.ph + 8 * plane) + off;
  }
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
    VF av[F];
    for (int t = 0; t < F; ++t)
      av[t] = hn::IfThenElseZero(hn::RebindMask(df, hn::Eq(hn::LoadU(di, ph[t] + j), level)), hn::LoadU(df, pa[t] + j));
    for (int c = 0; c < 5; ++c) {
      VF v[F];
      for (int t = 0; t < F; ++t) v[t] = c < 4 ? hn::Mul(av[t], hn::LoadU(df, pc[c][t] + j)) : av[t];
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
      if (ph[t][j] == job.level) {
        const float a = pa[t][j];
        for (int c = 0; c < 4; ++c) g[c] += static_cast<double>(a * pc[c][t][j]);
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
  if (job.f == 4)
    LevelBlocksF<4>(job);
  else
    LevelBlocksF<2>(job);
}

void ScanBlock(ScanBlockJob& job) {
  const hn::ScalableTag<float> df;
  const hn::RebindToSigned<decltype(df)> di;
  const int lanes = static_cast<int>(hn::Lanes(df));
  const auto one = hn::Set(df, 1.0f), zero = hn::Zero(df);
  auto far = hn::FirstN(df, 0), frac = far;
  int first = -1, last = -1;
  for (int i = 0; i < job.n; i += lanes) {
    const auto valid = hn::FirstN(df, static_cast<std::size_t>(std::min(lanes, job.n - i)));
    const auto v = hn::LoadU(df, job.nearness + i);
    const auto is_one = hn::Eq(v, one);
    // As the scalar n == 1 ? box : n > 0 ? fractional : far (a NaN counts as far).
    const auto not_one = hn::AndNot(is_one, valid);
    far = hn::Or(far, not_one);
    frac = hn::Or(frac, hn::And(not_one, hn::Gt(v, zero)));
    const auto box = hn::And(is_one, valid);
    if (hn::AllFalse(df, box)) continue;
    if (first < 0) first = i + static_cast<int>(hn::FindFirstTrue(df, box));
    uint8_t bits[8] = {};
    hn::StoreMaskBits(df, box, bits);
    uint64_t b = 0;
    std::memcpy(&b, bits, sizeof b);
    last = i + 63 - static_cast<int>(hwy::Num0BitsAboveMS1Bit_Nonzero64(b));
  }
  job.first_one = first;
  job.last_one = last;
  job.any_far = !hn::AllFalse(df, far);
  job.any_frac = !hn::AllFalse(df, frac);
  job.max_reach = 0;
  if (job.reach != nullptr && job.g1 >= job.g0) {
    auto m = hn::Zero(di);
    for (int g = job.g0; g <= job.g1; g += lanes) {
      const auto valid = hn::FirstN(di, static_cast<std::size_t>(std::min(lanes, job.g1 - g + 1)));
      m = hn::Max(m, hn::IfThenElseZero(valid, hn::LoadU(di, job.reach + g)));
    }
    job.max_reach = hn::GetLane(hn::MaxOfLanes(di, m));
  }
}

void BoxOut(const BoxOutJob& job) {
  const hn::ScalableTag<double> dd;
  const hn::Rebind<float, decltype(dd)> df;
  const int lanes = static_cast<int>(hn::Lanes(dd));
  const auto one = hn::Set(df, 1.0f), w = hn::Set(df, job.w);
  int i = 0;
  for (; i + lanes <= job.n; i += lanes) {
    const auto box = hn::Eq(hn::LoadU(df, job.nearness + i), one);
    if (hn::AllFalse(df, box)) continue;
    for (int c = 0; c < job.nc; ++c) {
      auto v = hn::LoadU(dd, job.a[c] + i);
      if (job.b[c] != nullptr) v = hn::Sub(v, hn::LoadU(dd, job.b[c] + i));
      if (job.c[c] != nullptr) v = hn::Add(v, hn::LoadU(dd, job.c[c] + i));
      // Double → float rounds to nearest as static_cast<float> does; then the same division.
      hn::BlendedStore(hn::Div(hn::DemoteTo(df, v), w), box, df, job.out[c] + i);
    }
  }
  for (; i < job.n; ++i) {
    if (job.nearness[i] != 1.0f) continue;
    for (int c = 0; c < job.nc; ++c) {
      double v = job.a[c][i];
      if (job.b[c] != nullptr) v -= job.b[c][i];
      if (job.c[c] != nullptr) v += job.c[c][i];
      job.out[c][i] = static_cast<float>(v) / job.w;
    }
  }
}

void WindowAdd(double* dst, const double* a, const double* b, const double* c, int n) {
  const hn::ScalableTag<double> dd;
  const int lanes = static_cast<int>(hn::Lanes(dd));
  int i = 0;
  for (; i + lanes <= n; i += lanes) {
    const auto v = hn::Add(hn::Sub(hn::LoadU(dd, a + i), hn::LoadU(dd, b + i)), hn::LoadU(dd, c + i));
    hn::StoreU(hn::Add(hn::LoadU(dd, dst + i), v), dd, dst + i);
  }
  for (; i < n; ++i) dst[i] += a[i] - b[i] + c[i];
}

void WindowScale(float* dst, const double* a, const double* b, const double* c, float k, int n) {
  const hn::ScalableTag<double> dd;
  const hn::Rebind<float, decltype(dd)> df;
  const int lanes = static_cast<int>(hn::Lanes(dd));
  const auto kv = hn::Set(df, k);
  int i = 0;
  for (; i + lanes <= n; i += lanes) {
    const auto v = hn::Add(hn::Sub(hn::LoadU(dd, a + i), hn::LoadU(dd, b + i)), hn::LoadU(dd, c + i));
    hn::StoreU(hn::Mul(hn::DemoteTo(df, v), kv), df, dst + i);
  }
  for (; i < n; ++i) dst[i] = static_cast<float>(a[i] - b[i] + c[i]) * k;
}

void ScaleRow(float* dst, const double* src, float k, int n) {
  const hn::ScalableTag<double> dd;
  const hn::Rebind<float, decltype(dd)> df;
  const int lanes = static_cast<int>(hn::Lanes(dd));
  const auto kv = hn::Set(df, k);
  int i = 0;
  for (; i + lanes <= n; i += lanes) hn::StoreU(hn::Mul(hn::DemoteTo(df, hn::LoadU(dd, src + i)), kv), df, dst + i);
  for (; i < n; ++i) dst[i] = static_cast<float>(src[i]) * k;
}

void MaxRows(float* dst, const float* base, std::ptrdiff_t stride, int y0, int y1, int n) {
  const hn::ScalableTag<float> df;
  const int lanes = static_cast<int>(hn::Lanes(df));
  for (int j = 0; j < n; j += lanes) {
    auto m = hn::LoadU(df, base + y0 * stride + j);
    for (int y = y0 + 1; y <= y1; ++y) m = hn::Max(m, hn::LoadU(df, base + y * stride + j));
    hn::StoreU(m, df, dst + j);
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
void composite_flush_streams() { hwy::FlushStream(); }
HWY_EXPORT(InterpRow);
void interp_row_simd(const InterpRowJob& job) { HWY_DYNAMIC_DISPATCH(InterpRow)(job); }
HWY_EXPORT(AuxRow);
void aux_row_simd(const AuxRowJob& job) { HWY_DYNAMIC_DISPATCH(AuxRow)(job); }
HWY_EXPORT(SlideRows);
void slide_rows_simd(const SlideRowsJob& job) { HWY_DYNAMIC_DISPATCH(SlideRows)(job); }
HWY_EXPORT(PrepRow);
void prep_row_simd(PrepRowJob& job, int m0, int m1) { HWY_DYNAMIC_DISPATCH(PrepRow)(job, m0, m1); }
void finish_near_stats(PrepRowJob& job) {
  if (!job.near || job.near_count == 0) return;
  const int f = job.f, P = job.W + 2 * job.R;
  const int32_t* h = reinterpret_cast<const int32_t*>(job.ph + 8 * static_cast<std::size_t>(f) * job.M);
  auto at = [&](int x) { return h[static_cast<std::size_t>(x % f) * job.M + x / f]; };
  int x = f * job.first_m;
  while (at(x) < 0) ++x;
  job.near_first = x;
  x = std::min(f * (job.last_m + 1), P) - 1;
  while (at(x) < 0) --x;
  job.near_last = x;
}
HWY_EXPORT(BlockSums);
void block_sums_simd(const BlockSumsJob& job) { HWY_DYNAMIC_DISPATCH(BlockSums)(job); }
HWY_EXPORT(LevelBlocks);
void level_blocks_simd(const LevelBlocksJob& job) { HWY_DYNAMIC_DISPATCH(LevelBlocks)(job); }
HWY_EXPORT(ScanBlock);
void scan_block_simd(ScanBlockJob& job) { HWY_DYNAMIC_DISPATCH(ScanBlock)(job); }
HWY_EXPORT(BoxOut);
void box_out_simd(const BoxOutJob& job) { HWY_DYNAMIC_DISPATCH(BoxOut)(job); }
HWY_EXPORT(WindowAdd);
void window_add_simd(double* dst, const double* a, const double* b, const double* c, int n) {
  HWY_DYNAMIC_DISPATCH(WindowAdd)(dst, a, b, c, n);
}
HWY_EXPORT(WindowScale);
void window_scale_simd(float* dst, const double* a, const double* b, const double* c, float k, int n) {
  HWY_DYNAMIC_DISPATCH(WindowScale)(dst, a, b, c, k, n);
}
HWY_EXPORT(ScaleRow);
void scale_row_simd(float* dst, const double* src, float k, int n) { HWY_DYNAMIC_DISPATCH(ScaleRow)(dst, src, k, n); }
HWY_EXPORT(MaxRows);
void max_rows_simd(float* dst, const float* base, std::ptrdiff_t stride, int y0, int y1, int n) {
  HWY_DYNAMIC_DISPATCH(MaxRows)(dst, base, stride, y0, y1, n);
}
}  // namespace dofkit::detail::mcguire
#endif  // HWY_ONCE
