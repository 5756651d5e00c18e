// Highway kernels of the final pass (declared in final_simd.hpp). The arithmetic is the
// plain pass's, operation for operation (same association of the sums, separate multiply
// and add), so the scalar edges and tails in final.cpp produce the same values.
#include "methods/starcraft/final_simd.hpp"
#include "render/sanitize.hpp"

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <limits>

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "methods/starcraft/final_simd.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/cache_control.h>
#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace dofkit::detail::starcraft {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

int FinalWeights(const WeightRow& r, int x0, int x1, bool& any) {
  const hn::ScalableTag<float> d;
  const int n = static_cast<int>(hn::Lanes(d));
  const auto zero = hn::Zero(d), one = hn::Set(d, 1.0f);
  const auto tie = hn::Set(d, 1.0f + 1e-5f);
  const auto k2 = hn::Set(d, 2.0f), k3 = hn::Set(d, 3.0f), k4 = hn::Set(d, 4.0f);
  const auto k16_17 = hn::Set(d, 16.0f / 17.0f);
  // Row pointers as locals (the stores could otherwise alias the struct).
  const float* const cown_row = r.cown;
  const float* const z_row = r.z;
  const float* const inv_blur_row = r.inv_blur;
  const float* const cb_row = r.cb;
  float* const ws_row = r.ws;
  float* const wm_row = r.wm;
  float* const wl_row = r.wl;
  float* const wsrc_row = r.wsrc;
  const bool keep_own_blur = r.keep_own_blur;
  float* const alpha_out = r.alpha_out;
  // The mix's alpha on an opaque frame: small = (16 ones)·(1/17), medium = w / w = 1, large =
  // num / cb = 1 (its alpha plane is its weight plane), source 1 (see final.cpp).
  const auto small_one = hn::Mul(hn::Set(d, 16.0f), hn::Set(d, 1.0f / 17.0f));
  const bool stream = alpha_out && reinterpret_cast<std::uintptr_t>(alpha_out + x0) % (n * sizeof(float)) == 0;
  auto alpha_max = zero;  // alpha >= 0, so "some alpha != 0" is "max alpha > 0"
  int x = x0;
  for (; x + n <= x1; x += n) {
    const auto cown = hn::LoadU(d, cown_row + x);
    const auto inv_own = hn::Div(one, hn::LoadU(d, z_row + x));
    // Rule 3: the blurred neighbourhood lies behind (or level with) the pixel → own level.
    const auto behind = hn::Le(hn::LoadU(d, inv_blur_row + x), hn::Mul(inv_own, tie));
    auto c = hn::IfThenElse(behind, cown, hn::LoadU(d, cb_row + x));
    if (keep_own_blur) c = hn::Max(c, cown);
    // level_weights with d0 = 0.5, d1 = d2 = 0.25: the divisions by powers of two are the
    // exact multiplications by 2 and 4 used here.
    auto sat = [&](auto v) { return hn::Min(hn::Max(v, zero), one); };
    const auto c2 = hn::Mul(c, k2), c4 = hn::Mul(c, k4);
    const auto xw = sat(hn::Sub(one, c2));
    const auto yw = sat(hn::Sub(k3, c4));
    const auto zw = sat(hn::Sub(k4, c4));
    const auto ww = sat(hn::Add(hn::Neg(k3), c4));
    const auto ys = hn::Min(yw, hn::Sub(one, xw));
    const auto zs = hn::Min(zw, hn::Sub(one, yw));
    const auto alpha = hn::Add(hn::Add(hn::Mul(k16_17, ys), zs), ww);
    hn::StoreU(ys, d, ws_row + x);
    hn::StoreU(zs, d, wm_row + x);
    hn::StoreU(ww, d, wl_row + x);
    const auto wsrc = hn::Sub(one, alpha);
    hn::StoreU(wsrc, d, wsrc_row + x);
    alpha_max = hn::Max(alpha_max, alpha);
    if (alpha_out) {
      const auto mixed = hn::Add(hn::Add(hn::Add(hn::Mul(ys, small_one), zs), ww), wsrc);
      const auto a = hn::IfThenElse(hn::Eq(wsrc, one), one, mixed);
      if (stream)
        hn::Stream(a, d, alpha_out + x);
      else
        hn::StoreU(a, d, alpha_out + x);
    }
  }
  if (!hn::AllTrue(d, hn::Eq(alpha_max, zero))) any = true;
  return x;
}

int FinalMix(const MixRow& r, int x0, int x1) {
  const hn::ScalableTag<float> d;
  const int n = static_cast<int>(hn::Lanes(d));
  const auto one = hn::Set(d, 1.0f), tiny = hn::Set(d, 1e-6f), k17 = hn::Set(d, 1.0f / 17.0f);
  const float* const b0 = r.blocks[0];
  const float* const b1 = r.blocks[1];
  const float* const b2 = r.blocks[2];
  const float* const b3 = r.blocks[3];
  // The row pointers as locals: the stores to `out` could otherwise alias the struct and
  // force a reload of every pointer per vector.
  const float* const src = r.src;
  const float* const wsrc_row = r.wsrc;
  const float* const med_row = r.med;
  const float* const mwt_row = r.mwt;
  const float* const cb_row = r.cb;
  const float* const num_row = r.num;
  const float* const ws_row = r.ws;
  const float* const wm_row = r.wm;
  const float* const wl_row = r.wl;
  float* const out = r.out;
  // The output is written once and not read again by the pass: where the row segment starts
  // on a vector boundary (the caller arranges it), non-temporal stores send it to memory
  // without first reading each line into the cache.
  const bool stream = reinterpret_cast<std::uintptr_t>(out + x0) % (n * sizeof(float)) == 0;
  auto store = [&](auto v, int at) {
    if (stream)
      hn::Stream(v, d, out + at);
    else
      hn::StoreU(v, d, out + at);
  };
  int x = x0;
  for (; x + n <= x1; x += n) {
    const auto s = hn::LoadU(d, src + x);
    const auto wsrc = hn::LoadU(d, wsrc_row + x);
    const auto focus = hn::Eq(wsrc, one);
    if (hn::AllTrue(d, focus)) {  // every lane in focus: the source, bit for bit
      store(s, x);
      continue;
    }
    auto L = [&](const float* p, int o) { return hn::LoadU(d, p + x + o); };
    // The four 2×2 blocks of the pinwheel, each summed left to right as in the plain pass
    // (by block_sums, once per row pair).
    const auto t0 = L(b0, 0);
    const auto t1 = L(b1, -2);
    const auto t2 = L(b2, -1);
    const auto t3 = L(b3, 1);
    const auto small = hn::Mul(hn::Add(hn::Add(hn::Add(t0, t1), t2), t3), k17);
    auto med = hn::LoadU(d, med_row + x);
    if (mwt_row) {  // normalise: med / weight where some tap carried weight, else the source
      const auto mw = hn::LoadU(d, mwt_row + x);
      const auto ok = hn::Gt(mw, tiny);
      med = hn::IfThenElse(ok, hn::Div(med, hn::IfThenElse(ok, mw, one)), s);
    }
    const auto cb = hn::LoadU(d, cb_row + x);
    const auto has_large = hn::Gt(cb, tiny);
    const auto q = hn::Div(hn::LoadU(d, num_row + x), hn::IfThenElse(has_large, cb, one));
    const auto lg = hn::IfThenElse(has_large, q, med);
    const auto mixed =
        hn::Add(hn::Add(hn::Add(hn::Mul(hn::LoadU(d, ws_row + x), small), hn::Mul(hn::LoadU(d, wm_row + x), med)),
                        hn::Mul(hn::LoadU(d, wl_row + x), lg)),
                hn::Mul(wsrc, s));
    store(hn::IfThenElse(focus, s, mixed), x);
  }
  // (The caller orders the non-temporal stores, with flush_streams(), before its task ends:
  // a fence here, per row and channel, waited for the write-combining buffers every time.)
  return x;
}

int FinalHlerp(const float* v, float* out, int i0, int i1) {
  const hn::ScalableTag<float> d;
  const int n = static_cast<int>(hn::Lanes(d));
  const auto t0 = hn::Set(d, 0.625f), t1 = hn::Set(d, 0.875f), t2 = hn::Set(d, 0.125f), t3 = hn::Set(d, 0.375f);
  int i = i0;
  for (; i + n <= i1; i += n) {
    const auto vl = hn::LoadU(d, v + i - 1), vc = hn::LoadU(d, v + i), vr = hn::LoadU(d, v + i + 1);
    const auto dl = hn::Sub(vc, vl), dr = hn::Sub(vr, vc);
    hn::StoreInterleaved4(hn::Add(vl, hn::Mul(dl, t0)), hn::Add(vl, hn::Mul(dl, t1)), hn::Add(vc, hn::Mul(dr, t2)),
                          hn::Add(vc, hn::Mul(dr, t3)), d, out + 4 * static_cast<std::ptrdiff_t>(i));
  }
  return i;
}

int FinalBilerp(const float* a, const float* b, float* out, int i0, int i1, float ty) {
  const hn::ScalableTag<float> d;
  const int n = static_cast<int>(hn::Lanes(d));
  // Column 4i + k sits at tx = 5/8, 7/8 (cells i − 1, i) or 1/8, 3/8 (cells i, i + 1) and every
  // row at ty in {1/8, 3/8, 5/8, 7/8}: the weights, formed as quarter_bilerp forms them, are
  // products of eighths, exact in float.
  constexpr float kTx[4] = {0.625f, 0.875f, 0.125f, 0.375f};
  hn::Vec<decltype(d)> w00[4], w01[4], w10[4], w11[4];
  for (int k = 0; k < 4; ++k) {
    const float tx = kTx[k];
    w00[k] = hn::Set(d, (1 - tx) * (1 - ty));
    w01[k] = hn::Set(d, tx * (1 - ty));
    w10[k] = hn::Set(d, (1 - tx) * ty);
    w11[k] = hn::Set(d, tx * ty);
  }
  auto bil = [&](int k, auto al, auto ar, auto bl, auto br) {
    return hn::Add(hn::Add(hn::Add(hn::Mul(w00[k], al), hn::Mul(w01[k], ar)), hn::Mul(w10[k], bl)),
                   hn::Mul(w11[k], br));
  };
  int i = i0;
  for (; i + n <= i1; i += n) {
    const auto al = hn::LoadU(d, a + i - 1), ac = hn::LoadU(d, a + i), ar = hn::LoadU(d, a + i + 1);
    const auto bl = hn::LoadU(d, b + i - 1), bc = hn::LoadU(d, b + i), br = hn::LoadU(d, b + i + 1);
    hn::StoreInterleaved4(bil(0, al, ac, bl, bc), bil(1, al, ac, bl, bc), bil(2, ac, ar, bc, br),
                          bil(3, ac, ar, bc, br), d, out + 4 * static_cast<std::ptrdiff_t>(i));
  }
  return i;
}

int LevelsRow(const float* r, float* c, int x0, int x1, float vs, float vm, float vl) {
  const hn::ScalableTag<float> d;
  const int n = static_cast<int>(hn::Lanes(d));
  const auto zero = hn::Zero(d), one = hn::Set(d, 1.0f), q = hn::Set(d, 0.25f), h = hn::Set(d, 0.5f);
  const auto k75 = hn::Set(d, 0.75f);
  const auto vsv = hn::Set(d, vs), vmv = hn::Set(d, vm), vlv = hn::Set(d, vl);
  const auto ds = hn::Set(d, vm - vs), dl = hn::Set(d, vl - vm);
  int x = x0;
  for (; x + n <= x1; x += n) {
    const auto rv = hn::LoadU(d, r + x);
    const auto v = hn::Max(zero, hn::Sub(hn::Mul(rv, rv), q));
    // Each segment is base + num / den: (0.5·v) / vs, 0.5 + (0.25·(v − vs)) / (vm − vs),
    // 0.75 + (0.25·(v − vm)) / (vl − vm), and 1 + 0 / 1 beyond vl (0 + t = t and 1 + 0 = 1
    // exactly). The segment's operands are selected first, so one division per pixel gives
    // what computing all three and selecting gave, bit for bit.
    const auto in_s = hn::Le(v, vsv), in_m = hn::Le(v, vmv), in_l = hn::Le(v, vlv);
    const auto num = hn::IfThenElse(
        in_s, hn::Mul(h, v),
        hn::IfThenElse(in_m, hn::Mul(q, hn::Sub(v, vsv)), hn::IfThenElseZero(in_l, hn::Mul(q, hn::Sub(v, vmv)))));
    const auto den = hn::IfThenElse(in_s, vsv, hn::IfThenElse(in_m, ds, hn::IfThenElse(in_l, dl, one)));
    const auto base = hn::IfThenElseZero(hn::Not(in_s), hn::IfThenElse(in_m, h, hn::IfThenElse(in_l, k75, one)));
    hn::StoreU(hn::Add(base, hn::Div(num, den)), d, c + x);
  }
  return x;
}

// The 4×4 reduction walks one source row at a time over a chunk of up to 512 blocks (a whole
// 1080p row), keeping the blocks' partial sums in a 20 KiB buffer: 5 row streams in flight
// (the row's 4 colour planes and its level) instead of 20 (4 rows × 5 planes, 128 bytes
// each before switching), which the memory system served at about half the rate even with
// software prefetches. With the long runs the hardware prefetchers do better than the
// prefetches did. Measured (1080p bench frame, the large level incl. its quarter-res blur):
// 5.0 → 3.4 ms on one thread, 2.6 → 1.9 ms on two. Each partial sum is the per-row term of
// the former loop, added in the same row order onto the same zero start, so the sums are the
// same bit for bit.
template <bool kCheck>
int LargeReduceT(const float* const rows[4][5], bool reduce_max, float* const out[5], int i0, int i1, bool& alpha_one,
                 bool& sanitary) {
  constexpr int kChunk = 512;  // blocks per chunk (a multiple of every target's lane count)
  // The colour rows come from L3 (the first pass of the frame to read them) and their loads
  // took ~60 % of the kernel's samples: each of the 4 colour streams asks for its lines
  // 1024 floats (4 KiB) ahead, one prefetch per line (1080p bench frame, 1 thread, perf samples
  // of this kernel over 31 frames: 396-429 without, 279-289 at 4 KiB, 303-330 at 2 KiB, 266-338
  // at 8 KiB; prefetching the level row as well: no better). Reads past a row's end only
  // prefetch.
  constexpr int kAheadFloats = 1024;
  const hn::ScalableTag<float> d;
  const int n = static_cast<int>(hn::Lanes(d));
  const auto zero = hn::Zero(d), inv16 = hn::Set(d, 1.0f / 16.0f);
  const auto one = hn::Set(d, 1.0f);
  auto opaque = hn::Eq(one, one);  // every alpha read so far is 1
  // kCheck: sample_is_sanitary (render/sanitize.hpp) of every colour sample read, as vectors.
  const auto min_normal = hn::Set(d, std::numeric_limits<float>::min());
  const auto max_colour = hn::Set(d, kMaxColorValue);
  auto clean = hn::Eq(one, one);
  auto check = [&](auto v, bool alpha) {
    const auto m = alpha ? v : hn::Abs(v);
    const auto ok = hn::Or(hn::Eq(v, zero), hn::And(hn::Ge(m, min_normal), hn::Le(m, alpha ? one : max_colour)));
    clean = hn::And(clean, ok);
  };
  // Partial sums of the chunk's blocks: 0 Σc, 1 max c, 2-5 Σ c·colour, 6-9 Σ colour.
  HWY_ALIGN float acc[10][kChunk];
  int i = i0;
  while (i + n <= i1) {
    const int m = std::min(kChunk, (i1 - i) / n * n);  // whole vectors of blocks
    for (int q = 0; q < 10; ++q)
      for (int b = 0; b < m; b += n) hn::Store(zero, d, acc[q] + b);
    for (int k = 0; k < 4; ++k) {
      const float* const cr = rows[k][4];
      const float* const sr[4] = {rows[k][0], rows[k][1], rows[k][2], rows[k][3]};
      for (int b = 0; b < m; b += n) {
        const std::ptrdiff_t px = 4 * static_cast<std::ptrdiff_t>(i + b);
        // LoadInterleaved4 splits 4n consecutive pixels into the 4 columns of n blocks.
        auto c0 = zero, c1 = zero, c2 = zero, c3 = zero;
        hn::LoadInterleaved4(d, cr + px, c0, c1, c2, c3);
        hn::Store(hn::Add(hn::Load(d, acc[0] + b), hn::Add(hn::Add(c0, c1), hn::Add(c2, c3))), d, acc[0] + b);
        hn::Store(hn::Max(hn::Load(d, acc[1] + b), hn::Max(hn::Max(c0, c1), hn::Max(c2, c3))), d, acc[1] + b);
        for (int ch = 0; ch < 4; ++ch) {
          for (int l = 0; l < 4 * n; l += 16) hwy::Prefetch(sr[ch] + px + kAheadFloats + l);  // see kAheadFloats
          auto s0 = zero, s1 = zero, s2 = zero, s3 = zero;
          hn::LoadInterleaved4(d, sr[ch] + px, s0, s1, s2, s3);
          hn::Store(hn::Add(hn::Load(d, acc[2 + ch] + b), hn::Add(hn::Add(hn::Mul(c0, s0), hn::Mul(c1, s1)),
                                                                  hn::Add(hn::Mul(c2, s2), hn::Mul(c3, s3)))),
                    d, acc[2 + ch] + b);
          hn::Store(hn::Add(hn::Load(d, acc[6 + ch] + b), hn::Add(hn::Add(s0, s1), hn::Add(s2, s3))), d,
                    acc[6 + ch] + b);
          if (ch == 3)
            opaque = hn::And(
                opaque, hn::And(hn::And(hn::Eq(s0, one), hn::Eq(s1, one)), hn::And(hn::Eq(s2, one), hn::Eq(s3, one))));
          if (kCheck) {
            check(s0, ch == 3);
            check(s1, ch == 3);
            check(s2, ch == 3);
            check(s3, ch == 3);
          }
        }
      }
    }
    for (int b = 0; b < m; b += n) {
      const auto csum = hn::Load(d, acc[0] + b);
      const auto cb = reduce_max ? hn::Load(d, acc[1] + b) : hn::Mul(csum, inv16);
      const auto has = hn::Gt(csum, zero);
      const auto den = hn::IfThenElse(has, csum, hn::Set(d, 1.0f));
      for (int ch = 0; ch < 4; ++ch) {
        const auto col = hn::IfThenElse(has, hn::Div(hn::Load(d, acc[2 + ch] + b), den),
                                        hn::Mul(hn::Load(d, acc[6 + ch] + b), inv16));
        hn::StoreU(hn::Mul(cb, col), d, out[ch] + i + b);
      }
      hn::StoreU(cb, d, out[4] + i + b);
    }
    i += m;
  }
  if (!hn::AllTrue(d, opaque)) alpha_one = false;
  if (kCheck && !hn::AllTrue(d, clean)) sanitary = false;
  return i;
}

int LargeReduce(const float* const rows[4][5], bool reduce_max, float* const out[5], int i0, int i1, bool& alpha_one,
                bool* sanitary) {
  if (sanitary) return LargeReduceT<true>(rows, reduce_max, out, i0, i1, alpha_one, *sanitary);
  bool unused = true;
  return LargeReduceT<false>(rows, reduce_max, out, i0, i1, alpha_one, unused);
}

}  // namespace HWY_NAMESPACE
}  // namespace dofkit::detail::starcraft
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace dofkit::detail::starcraft {

HWY_EXPORT(FinalWeights);
HWY_EXPORT(FinalMix);
HWY_EXPORT(FinalHlerp);
HWY_EXPORT(FinalBilerp);
HWY_EXPORT(LargeReduce);
HWY_EXPORT(LevelsRow);

int final_weights_simd(const WeightRow& r, int x0, int x1, bool& any) {
  return HWY_DYNAMIC_DISPATCH(FinalWeights)(r, x0, x1, any);
}
int final_mix_simd(const MixRow& r, int x0, int x1) { return HWY_DYNAMIC_DISPATCH(FinalMix)(r, x0, x1); }
void flush_streams() { hwy::FlushStream(); }
int final_hlerp_simd(const float* v, float* out, int i0, int i1) {
  return HWY_DYNAMIC_DISPATCH(FinalHlerp)(v, out, i0, i1);
}
int final_bilerp_simd(const float* a, const float* b, float* out, int i0, int i1, float ty) {
  return HWY_DYNAMIC_DISPATCH(FinalBilerp)(a, b, out, i0, i1, ty);
}
int levels_row_simd(const float* r, float* c, int x0, int x1, float vs, float vm, float vl) {
  return HWY_DYNAMIC_DISPATCH(LevelsRow)(r, c, x0, x1, vs, vm, vl);
}
int large_reduce_simd(const float* const rows[4][5], bool reduce_max, float* const out[5], int i0, int i1,
                      bool& alpha_one, bool* sanitary) {
  return HWY_DYNAMIC_DISPATCH(LargeReduce)(rows, reduce_max, out, i0, i1, alpha_one, sanitary);
}

}  // namespace dofkit::detail::starcraft
#endif  // HWY_ONCE
