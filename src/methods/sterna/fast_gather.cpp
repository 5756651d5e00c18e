// Over 800 lines: the gather templates are compiled once per target copy here, beside the dispatch that picks one.
// Fast P7: the 49-tap gather, register-blocked. Same sums as gather.cpp, same order, in the
// baseline copy; the FMA copies (the usual case) agree with gather.cpp to rounding and take,
// per frame, the cheapest of three forms of the sum: in the AVX-512 copy the fold form
// wherever the kernel is symmetric about the horizontal axis (Sterna's rings: see FoldKernel;
// it walks rows, the two others column strips), else each bilinear tap written separably (see
// tap_rows2), or the kernel as texel weights (see texel_rows). What follows describes the strip
// walk.
//
// gather.cpp accumulates tap by tap into row-length arrays: per tap and channel it loads
// 4 source values, the accumulator, and stores the accumulator back. Here a segment of 32
// texels (4 vectors) of one channel keeps its accumulators in registers for the 49 taps, so a
// tap costs its 4 loads per vector and nothing else; the per-tap bilinear weights are
// broadcast once per tap. Each tap is one linear offset dy·pitch + dx into the padded plane,
// so no index is clamped and no branch is taken.
//
// Work: the 8×8 tile bits of tile classification select the fields per segment row — a
// segment whose tiles have no near texel does not run the near gather (gather.cpp merges runs
// of active tiles and computes both fields over the run). Per texel the result is selected as
// in gather.cpp: near where nearBlur_h > 0 else colour_h; far where far_h > 0 else 0.
//
// Locality: a task is one column segment. It goes channel by channel and, inside, row by
// row: the source rows one channel's taps read for row y (≈ 2·reach + 2 rows × a few cache
// lines, ~10 kB at reach 15) are, all but one, those of row y − 1, so they stay in L1. The far
// denominator Σ far_h runs first and is kept as 1/den per texel (gather.cpp computes the same
// 1/den once per texel and multiplies each channel by it).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <immintrin.h>
#include <utility>
#include <vector>

#include "core/parallel.hpp"
#include "core/simd_target.hpp"
#include "methods/sterna/fast.hpp"
#include "methods/sterna/fast_gather.hpp"
#include "methods/sterna/v8.hpp"

namespace dofkit::detail::sterna::fast {

namespace {

constexpr std::uint8_t kNearBit = 1, kFarBit = 2;
constexpr int kStripTiles = 4;  // tiles per column segment
static_assert(kTile == 8, "one tile row is one 8-lane chunk");

// A tap with its weights already broadcast to vectors (loaded, not rebuilt, per tap): the
// four bilinear weights for the baseline kernel, fx, fy and 1 − fy for the FMA kernel.
struct alignas(32) TapV {
  V8 w00, w10, w01, w11;
  V8 fx, fy, gy;
  std::ptrdiff_t off;
};

constexpr int kSeg = kStripTiles * kTile;  // texels per segment = strip width (32)
constexpr int kVecs = kSeg / 8;

// Two ways to sum one bilinear tap, chosen per compiled copy (kFma):
//
// * baseline (kFma false): gather.cpp's own sum w00·a + w10·b + w01·c + w11·d with the
//   weights w00 = (1−fx)(1−fy) …, rounded after every operation — bit-identical to impl=plain.
//   Per tap and pair of output vectors (rows y, y+1 share the middle source row): 6 loads,
//   8 multiplies, 8 adds. Zen 3 runs multiplies/FMAs on two pipes (FP0/1) and adds on two
//   others (FP2/3), so both pairs are busy 4 cycles while the loads need 3.
//
// * FMA (AVX2+FMA / AVX-512 copies): the same bilinear value written separably. With the tap's
//   source rows k = 0, 1, 2 (a_k at x, b_k at x+1),
//     h_k = a_k − fx·(a_k − b_k)                 (horizontal lerp: 1 sub + 1 FNMA each)
//   row y    += h_0 + fy·(h_1 − h_0)             (sub, FMA, add)
//   row y+1   = (1−fy)·h_1 + (fy·h_2 + row y+1)  (2 FMAs, the accumulator inside)
//   Both expand to Σ (1−fx)(1−fy)a + … exactly in real arithmetic; only the rounding differs.
//   (a − fx·(a − b) rounds exactly as a + fx·(b − a) — negation is exact — but a − b lets the
//   b load be the sub's memory operand: 14 instructions per vector pair instead of 17.)
//   Count: 5 ops on FP2/3 (4 subs, 1 add) and 6 on FP0/1 (FMAs) — 3 cycles, as the 6 loads.
//   The two output rows use different forms (row y: 7 add-pipe/5 FMA-pipe ops if both used
//   the first, the reverse with the second), so a row's sum depends on its parity; the last
//   row of an odd-height frame (gather_seg) is an even row and uses the row-y form.
//   The relative rounding of h_0 + fy·(h_1 − h_0) is no longer bounded by that of a sum of
//   non-negative terms (the difference can cancel), but it stays of the order of one ulp of
//   the larger source value: tests/sterna/sterna_fast_test.cpp measures the distance to
//   impl=plain (worst 2.9e-6 relative).
//   Measured (1080p bench frame, 1 thread, Zen 3): the gather's own samples (perf) −3..−6 %,
//   the frame −2.9..−3.6 % min-of-min. Less than the 4 → 3 cycle model says: the loop is not
//   bound by the FP pipes alone — about 7/16 of these unaligned 32-byte loads cross a 64-byte
//   line (two load slots each), and only ~70 % of the gather's time is in the tap loops. So
//   the FMA copies also take four rows per pass (gather_seg4: 2.5 loads per output vector
//   instead of 3): gather ≈ 17.5 → 16.0 ms CPU per frame (perf samples, old → now), frame
//   −4.8 % min-of-min at 1 thread, −4.9 % at 2.
//
// * texel form (FMA copies, chosen per frame where it needs fewer FMAs, see gather()): the
//   taps touch a fixed set of source texels, each with a fixed weight, the sum of the bilinear
//   weights of the taps that touch it (at kernel_scale 1: 129 texels for the 49 taps — the
//   taps on the axes hit one or two texels, the others four, and neighbours share some). The
//   gather is then Σ weight·texel, one FMA per texel and output vector, and rows y and y + 1
//   share the loads of the source rows they both read: a source texel at (dx, s) relative to
//   row y is texel (dx, s) of row y's kernel and (dx, s − 1) of row y + 1's. Terms are summed
//   in a fixed order: first the texels both rows use (by s, then dx; one load per vector
//   serves two FMAs), then those of row y alone, then those of row y + 1 alone. So a row's
//   sum depends only on its parity (even rows are the first of a pair; the last row of an
//   odd-height frame is an even row and takes the same order), and constant_near_body repeats
//   it in scalar arithmetic. Same real-number sum as gather.cpp, rounded differently (each
//   weight rounded once from its double sum, then one rounding per FMA).
//   What it gains depends on how many texels the taps share. At kernel_scale 1 (rings 2 / 4 /
//   6 texels) rows y, y + 1 read 162 texels, 96 of them both: 258 FMAs per row pair against
//   the separable form's 2 · 2.75 · 49 ≈ 270 FMA-pipe operations (plus 220 adds and ~430 loads);
//   in a micro-benchmark (Zen 3, one plane, the gather's walk) 92 against 161 cycles per output
//   vector, and the 1080p render with kernel_scale=1 takes 0.92–0.93 of the time. Spread wider
//   (the bench frame's automatic scale is 2.4, 4.8 at 4K) nearly every tap has four texels of
//   its own: 362 FMAs per row pair at 2.4, and the texel form made the bench frame 5 % slower
//   (micro-benchmark 147 against 158 cycles, but the render 1.05 per round): gather() takes
//   it only where it needs no more FMAs per row pair than the separable form's FMA-pipe work.

// a·b + c rounded once (vfmadd231: c ← a·b + c). Written as asm rather than the intrinsic:
// the intrinsic's wrapper does not inline into these target-less helpers, and GCC does not
// declare its builtin outside FMA code. The asm is only ever reached from the FMA copies,
// and the compiler cannot contract, split or reorder it (no fp-contract setting involved).
template <bool kFma, class T>
__attribute__((always_inline)) inline T fmadd(T a, T b, T c) {
  static_assert(kFma, "only the FMA kernels fuse");
#if !defined(__clang__)
  if constexpr (sizeof(T) == 32)
    __asm__("vfmadd231ps %2, %1, %0" : "+x"(c) : "x"(a), "x"(b));
  else
    __asm__("vfmadd231ss %2, %1, %0" : "+x"(c) : "x"(a), "x"(b));
  return c;
#else
  return a * b + c;  // (never instantiated: clang builds only the baseline kernel)
#endif
}

// c − a·b rounded once (vfnmadd231: c ← −(a·b) + c).
template <bool kFma, class T>
__attribute__((always_inline)) inline T fnmadd(T a, T b, T c) {
  static_assert(kFma, "only the FMA kernels fuse");
#if !defined(__clang__)
  if constexpr (sizeof(T) == 32)
    __asm__("vfnmadd231ps %2, %1, %0" : "+x"(c) : "x"(a), "x"(b));
  else
    __asm__("vfnmadd231ss %2, %1, %0" : "+x"(c) : "x"(a), "x"(b));
  return c;
#else
  return c - a * b;  // (never instantiated, as fmadd)
#endif
}

// *p in all eight lanes, by vbroadcastss from memory (FMA copies only). Written as asm for the
// reason fmadd is: left to itself, GCC built splat() of a weight that had just been loaded
// together with its neighbour through four stores to the stack and a reload (a
// store-forwarding stall per term, which made the gather twice as slow as the tap form).
template <bool kFma>
__attribute__((always_inline)) inline V8 broadcast(const float* p) {
  static_assert(kFma, "only the FMA kernels use it");
#if !defined(__clang__)
  V8 r;
  __asm__("vbroadcastss %1, %0" : "=x"(r) : "m"(*p));
  return r;
#else
  return splat(*p);  // (never instantiated, as fmadd)
#endif
}

// One tap for one output row from source rows (a0, b0) above and (a1, b1) below.
template <bool kFma, class T>
__attribute__((always_inline)) inline T tap_row0(T acc, T a0, T b0, T a1, T b1, T w00, T w10, T w01, T w11, T fx,
                                                 T fy) {
  if constexpr (kFma) {
    const T h0 = fnmadd<true>(fx, a0 - b0, a0), h1 = fnmadd<true>(fx, a1 - b1, a1);
    return acc + fmadd<true>(fy, h1 - h0, h0);
  } else {
    (void)fx, (void)fy;
    return acc + (w00 * a0 + w10 * b0 + w01 * a1 + w11 * b1);
  }
}

// One tap for output rows y (acc0: source rows 0, 1) and y + 1 (acc1: source rows 1, 2).
template <bool kFma, class T>
__attribute__((always_inline)) inline void tap_rows2(T& acc0, T& acc1, T a0, T b0, T a1, T b1, T a2, T b2,
                                                     const TapV& tp) {
  if constexpr (kFma) {
    const T fx = tp.fx, fy = tp.fy, gy = tp.gy;
    const T h0 = fnmadd<true>(fx, a0 - b0, a0), h1 = fnmadd<true>(fx, a1 - b1, a1), h2 = fnmadd<true>(fx, a2 - b2, a2);
    acc0 = acc0 + fmadd<true>(fy, h1 - h0, h0);
    acc1 = fmadd<true>(gy, h1, fmadd<true>(fy, h2, acc1));
  } else {
    const T w00 = tp.w00, w10 = tp.w10, w01 = tp.w01, w11 = tp.w11;
    acc0 += w00 * a0 + w10 * b0 + w01 * a1 + w11 * b1;
    acc1 += w00 * a1 + w10 * b1 + w01 * a2 + w11 * b2;
  }
}

// Σ_taps bilinear(src) for the kSeg texels starting at `base` (one channel), into acc.
template <bool kFma>
__attribute__((always_inline)) inline void gather_seg(const float* base, const TapV* taps, int ntaps,
                                                      std::ptrdiff_t pitch, V8* acc) {
  for (int v = 0; v < kVecs; ++v) acc[v] = splat(0.0f);
  for (int t = 0; t < ntaps; ++t) {
    const TapV& tp = taps[t];
    const float* r0 = base + tp.off;
    const float* r1 = r0 + pitch;
    for (int v = 0; v < kVecs; ++v)
      acc[v] = tap_row0<kFma>(acc[v], load8(r0 + 8 * v), load8(r0 + 8 * v + 1), load8(r1 + 8 * v),
                              load8(r1 + 8 * v + 1), tp.w00, tp.w10, tp.w01, tp.w11, tp.fx, tp.fy);
  }
}

// gather_seg for rows y (acc0) and y + 1 (acc1) at once: a tap's second source row for y is
// its first for y + 1, so 6 loads serve two output vectors instead of 8.
//
// kPin: left to itself GCC folds a load used twice into both operations that use it (the
// baseline: a1, d feed both rows' sums; FMA: each a_k feeds its sub and its FMA), so the loop
// issues 8 loads per vector again. An empty asm that "modifies" them in a vector register
// pins them there (6 loads). It needs a 32-byte vector register, so only the AVX2 /
// AVX-512 copies use it (measured: gather 19.2–19.9 → 17.8–19.1 ms CPU per 1080p frame).
template <bool kPin, bool kFma>
__attribute__((always_inline)) inline void gather_seg2(const float* base, const TapV* taps, int ntaps,
                                                       std::ptrdiff_t pitch, V8* acc0, V8* acc1) {
  for (int v = 0; v < kVecs; ++v) acc0[v] = acc1[v] = splat(0.0f);
  for (int t = 0; t < ntaps; ++t) {
    const TapV& tp = taps[t];
    const float* r0 = base + tp.off;
    const float* r1 = r0 + pitch;
    const float* r2 = r1 + pitch;
    for (int v = 0; v < kVecs; ++v) {
      V8 a0 = load8(r0 + 8 * v), a1 = load8(r1 + 8 * v), d = load8(r1 + 8 * v + 1), a2 = load8(r2 + 8 * v);
#if !defined(__clang__)  // (clang checks the constraint even where kPin is false)
      if constexpr (kPin && kFma) __asm__("" : "+x"(a0), "+x"(a1), "+x"(a2));  // a_k: sub and FMA
      if constexpr (kPin && !kFma) __asm__("" : "+x"(a1), "+x"(d));            // row 1: both sums
#endif
      tap_rows2<kFma>(acc0[v], acc1[v], a0, load8(r0 + 8 * v + 1), a1, d, a2, load8(r2 + 8 * v + 1), tp);
    }
  }
}

// gather_seg2 for rows y .. y + 3 (FMA kernel only): the four rows read source rows 0 .. 4,
// so 10 loads serve four output vectors (2.5 each instead of 3). Rows y, y + 2 use the even
// form and y + 1, y + 3 the odd form of tap_rows2, with the same operations in the same tap
// order, so the sums are bit-identical to two gather_seg2 calls (checked when written: the
// `dofkit render` EXR pixel data of two scenes at 641×361/363/365, 1 and 2 threads, equal to
// the two-row version's). Per tap and output vector: 2.5 loads, 2.75 FMAs, 2.25 subs/adds
// (h_2 serves both pairs). Sixteen accumulators do not fit the 16 AVX2 registers with the
// weights, so the segment is done in two halves of kVecs / 2 vectors (8 accumulators,
// fx/fy/1−fy, temporaries). kPin keeps each a_k (sub and FNMA) in a register, as gather_seg2.
template <bool kPin>
__attribute__((always_inline)) inline void gather_seg4(const float* base, const TapV* taps, int ntaps,
                                                       std::ptrdiff_t pitch, V8 (*acc)[kVecs]) {
  constexpr int kHalf = kVecs / 2;
  for (int half = 0; half < 2; ++half) {
    V8 a[4][kHalf];
    for (int r = 0; r < 4; ++r)
      for (int v = 0; v < kHalf; ++v) a[r][v] = splat(0.0f);
    const float* b0 = base + 8 * kHalf * half;
    for (int t = 0; t < ntaps; ++t) {
      const TapV& tp = taps[t];
      const float* r0 = b0 + tp.off;
      for (int v = 0; v < kHalf; ++v) {
        const float* p = r0 + 8 * v;
        V8 s0 = load8(p), s1 = load8(p + pitch), s2 = load8(p + 2 * pitch), s3 = load8(p + 3 * pitch),
           s4 = load8(p + 4 * pitch);
#if !defined(__clang__)
        if constexpr (kPin) __asm__("" : "+x"(s0), "+x"(s1), "+x"(s2), "+x"(s3), "+x"(s4));
#endif
        // tap_rows2's operations for rows (y, y + 1) and (y + 2, y + 3), h_2 shared.
        const V8 fx = tp.fx, fy = tp.fy, gy = tp.gy;
        const V8 h0 = fnmadd<true>(fx, s0 - load8(p + 1), s0), h1 = fnmadd<true>(fx, s1 - load8(p + pitch + 1), s1),
                 h2 = fnmadd<true>(fx, s2 - load8(p + 2 * pitch + 1), s2),
                 h3 = fnmadd<true>(fx, s3 - load8(p + 3 * pitch + 1), s3),
                 h4 = fnmadd<true>(fx, s4 - load8(p + 4 * pitch + 1), s4);
        a[0][v] = a[0][v] + fmadd<true>(fy, h1 - h0, h0);
        a[1][v] = fmadd<true>(gy, h1, fmadd<true>(fy, h2, a[1][v]));
        a[2][v] = a[2][v] + fmadd<true>(fy, h3 - h2, h2);
        a[3][v] = fmadd<true>(gy, h3, fmadd<true>(fy, h4, a[3][v]));
      }
    }
    for (int r = 0; r < 4; ++r)
      for (int v = 0; v < kHalf; ++v) acc[r][kHalf * half + v] = a[r][v];
  }
}

struct Job {
  const Buffers* b;
  const TapV* taps;
  int ntaps;
  // The texel form (FMA copies, where `texel` is set).
  bool texel;
  const TexelPair* both;
  int nboth;
  const Texel* only0;
  int nonly0;
  const Texel* only1;
  int nonly1;
  float inv_taps;
  // Opaque-frame shortcuts (see gather()): colour_h alpha is this one value everywhere, so its
  // near gather is one number per row parity (near_alpha[y % 2], computed once) ...
  bool near_alpha_const;
  float near_alpha[2];
  // ... and colourFar_h alpha equals far_h bit for bit, so its far gather is the denominator's.
  bool far_alpha_is_den;
  // per_pixel_scale: the far field is gathered per texel afterwards (far_per_texel), not here.
  bool skip_far;
  // Prefetch: the row that output row y + kAhead will be the first to read (its last tap row,
  // dy_max + 1 below), from column dx_min over `span` floats.
  int pf_dy, pf_dx, pf_span;
  // The fold form (see FoldKernel), where `fold` is set.
  const FoldKernel* fold = nullptr;
};

// The texels only one row of a pair reads, added to that row's four accumulators.
template <bool kFma>
__attribute__((always_inline)) inline void add_texels(const float* base, const Texel* t, int n, V8& a0, V8& a1, V8& a2,
                                                      V8& a3) {
  for (int k = 0; k < n; ++k) {
    const float* p = base + t[k].off;
    const V8 w = broadcast<kFma>(&t[k].w);
    a0 = fmadd<kFma>(w, load8(p), a0), a1 = fmadd<kFma>(w, load8(p + 8), a1);
    a2 = fmadd<kFma>(w, load8(p + 16), a2), a3 = fmadd<kFma>(w, load8(p + 24), a3);
  }
}

// Texel-form sums of the segment at `base` for row y (acc0) and, with kTwo, row y + 1
// (acc1), y even. Eight accumulators, four source vectors and two weights: 14 of the 16
// AVX2 registers.
template <bool kTwo>
__attribute__((always_inline)) inline void texel_rows(const float* base, const Job& job, V8* acc0, V8* acc1) {
  V8 a0 = splat(0.0f), a1 = a0, a2 = a0, a3 = a0, b0 = a0, b1 = a0, b2 = a0, b3 = a0;
  for (int k = 0; k < job.nboth; ++k) {
    const TexelPair& t = job.both[k];
    const float* p = base + t.off;
    const V8 s0 = load8(p), s1 = load8(p + 8), s2 = load8(p + 16), s3 = load8(p + 24);
    const V8 w = broadcast<true>(&t.w0);
    a0 = fmadd<true>(w, s0, a0), a1 = fmadd<true>(w, s1, a1), a2 = fmadd<true>(w, s2, a2), a3 = fmadd<true>(w, s3, a3);
    if constexpr (kTwo) {
      const V8 u = broadcast<true>(&t.w1);
      b0 = fmadd<true>(u, s0, b0), b1 = fmadd<true>(u, s1, b1), b2 = fmadd<true>(u, s2, b2),
      b3 = fmadd<true>(u, s3, b3);
    }
  }
  add_texels<true>(base, job.only0, job.nonly0, a0, a1, a2, a3);
  acc0[0] = a0, acc0[1] = a1, acc0[2] = a2, acc0[3] = a3;
  if constexpr (kTwo) {
    add_texels<true>(base, job.only1, job.nonly1, b0, b1, b2, b3);
    acc1[0] = b0, acc1[1] = b1, acc1[2] = b2, acc1[3] = b3;
  }
}

// The near gather of a plane that holds v everywhere, for an even (parity 0) or odd output
// row: the operations of the kernel the gather uses (gather_seg2 / gather_seg, or
// texel_rows) for one lane, in scalar arithmetic (which rounds exactly as the vector lanes
// do). With the FMA kernels the two row parities round differently (the separable form:
// h_k = v + fx·0 = v, but the two row forms differ; the texel form: different weights in a
// different order), so the value depends on the row's parity.
template <bool kFma>
__attribute__((always_inline)) inline float constant_near_body(const Job& job, float v, int parity) {
  if constexpr (kFma) {
    if (job.texel) {
      float acc = 0.0f;
      for (int k = 0; k < job.nboth; ++k) acc = fmadd<true>(parity ? job.both[k].w1 : job.both[k].w0, v, acc);
      const Texel* only = parity ? job.only1 : job.only0;
      const int n = parity ? job.nonly1 : job.nonly0;
      for (int k = 0; k < n; ++k) acc = fmadd<true>(only[k].w, v, acc);
      return acc * job.inv_taps;
    }
  }
  float acc0 = 0.0f, acc1 = 0.0f;
  for (int t = 0; t < job.ntaps; ++t) {
    const TapV& tp = job.taps[t];
    if constexpr (kFma) {
      const float fx = tp.fx[0], fy = tp.fy[0], gy = tp.gy[0];
      const float h = fnmadd<true>(fx, v - v, v);
      acc0 = acc0 + fmadd<true>(fy, h - h, h);
      acc1 = fmadd<true>(gy, h, fmadd<true>(fy, h, acc1));
    } else {
      acc0 += tp.w00[0] * v + tp.w10[0] * v + tp.w01[0] * v + tp.w11[0] * v;
      acc1 = acc0;
    }
  }
  return (parity ? acc1 : acc0) * job.inv_taps;
}

constexpr int kAhead = 3;  // rows of look-ahead for the prefetch

// Rows enter the tap window one per output row; the new one comes from L3/DRAM (the padded
// planes are ~25 MB at 1080p), and the hardware prefetcher does not follow a walk down a
// column of 4 kB-strided rows, so ask for it a few rows early.
__attribute__((always_inline)) inline void prefetch_ahead(const Job& job, const float* base, int y, int h,
                                                          std::ptrdiff_t pitch) {
  if (y + kAhead >= h) return;
  const float* p = base + (kAhead + job.pf_dy) * pitch + job.pf_dx;
  for (int k = 0; k < job.pf_span; k += 16) __builtin_prefetch(p + k);
}

// Whether any tile of segment [tx0, tx1) in tile row ty has `bit`.
__attribute__((always_inline)) inline bool seg_has(const Buffers& b, int ty, int tx0, int tx1, std::uint8_t bit) {
  const std::uint8_t* tiles = b.tiles->data() + static_cast<std::size_t>(ty) * b.tiles_x;
  for (int tx = tx0; tx < tx1; ++tx)
    if (tiles[tx] & bit) return true;
  return false;
}

// kSeg values of an unpadded row from x0 (n valid, the rest 0).
__attribute__((always_inline)) inline void load_seg(const float* row, int x0, int n, V8* out) {
  if (n == kSeg) {
    for (int v = 0; v < kVecs; ++v) out[v] = load8(row + x0 + 8 * v);
    return;
  }
  float tmp[kSeg] = {};
  std::copy(row + x0, row + x0 + n, tmp);
  for (int v = 0; v < kVecs; ++v) out[v] = load8(tmp + 8 * v);
}

__attribute__((always_inline)) inline void store_seg(float* row, int x0, int n, const V8* in) {
  if (n == kSeg) {
    for (int v = 0; v < kVecs; ++v) store8(row + x0 + 8 * v, in[v]);
    return;
  }
  float tmp[kSeg];
  for (int v = 0; v < kVecs; ++v) store8(tmp + 8 * v, in[v]);
  std::copy(tmp, tmp + n, row + x0);
}

// One segment of kSeg texels (tiles [tx0, tx1)) over all rows: channel by channel, rows
// inner, so the source rows one channel's taps read (≈ 2·reach + 2 rows × a few cache lines)
// stay in L1 while the segment walks down.
template <bool kPin, bool kFma>
__attribute__((always_inline)) inline void gather_strip_body(const Job& job, int tx0, int tx1, float* inv_den) {
  constexpr int kRows = kFma ? 4 : 2;  // output rows per pass over the taps
  static_assert(kTile % kRows == 0);
  const Buffers& b = *job.b;
  const int h = b.h;
  const int x0 = tx0 * kTile, n = std::min(kSeg, b.w - x0);
  const std::ptrdiff_t pitch = b.near_src->width();
  const V8 inv_taps = splat(job.inv_taps);
  const V8 zero = splat(0.0f);
  V8 acc[kRows][kVecs], res[kVecs];
  // Σ taps for rows y .. y + kRows − 1 (those < h) of plane `src`, into acc[0 ..]. Rows come
  // in groups that share a tile row (kTile is a multiple of kRows), so they share the field
  // bits.
  // (always_inline: the lambda's own body would otherwise be compiled for the baseline target,
  // not for the AVX copy it is called from.)
  auto run = [&](const Image& src, int c, int y) __attribute__((always_inline)) {
    const float* base = b.src_row(src, c, y) + x0;
    for (int r = 0; r < kRows; ++r) prefetch_ahead(job, base + r * pitch, y + r, h, pitch);
    if constexpr (kFma) {
      if (job.texel) {  // in pairs (an even row and the next), a last single row alone
        for (int r = 0; r < kRows && y + r < h; r += 2) {
          if (y + r + 1 < h)
            texel_rows<true>(base + r * pitch, job, acc[r], acc[r + 1]);
          else
            texel_rows<false>(base + r * pitch, job, acc[r], nullptr);
        }
        return;
      }
    }
    if constexpr (kRows == 4) {
      if (y + 3 < h) {
        gather_seg4<kPin>(base, job.taps, job.ntaps, pitch, acc);
        return;
      }
    }
    // The rest in pairs, the last single row (always an even row) alone.
    for (int r = 0; r < kRows && y + r < h; r += 2) {
      const float* br = base + r * pitch;
      if (y + r + 1 < h)
        gather_seg2<kPin, kFma>(br, job.taps, job.ntaps, pitch, acc[r], acc[r + 1]);
      else
        gather_seg<kFma>(br, job.taps, job.ntaps, pitch, acc[r]);
    }
  };
  // Near field: (1/49) Σ colour_h where nearBlur_h > 0, else colour_h.
  for (int c = 0; c < 4; ++c)
    for (int y = 0; y < h; y += kRows) {
      const bool active = seg_has(b, y / kTile, tx0, tx1, kNearBit);
      const bool gathered = active && !(c == 3 && job.near_alpha_const);
      if (gathered) run(*b.near_src, c, y);
      for (int r = 0; r < kRows && y + r < h; ++r) {
        const float* base = b.src_row(*b.near_src, c, y + r) + x0;
        if (active) {
          V8 nbv[kVecs];
          load_seg(b.near_blur->row(0, y + r), x0, n, nbv);
          for (int v = 0; v < kVecs; ++v) {
            const V8 g = gathered ? acc[r][v] * inv_taps : splat(job.near_alpha[r & 1]);
            res[v] = nbv[v] > zero ? g : load8(base + 8 * v);
          }
        } else {
          for (int v = 0; v < kVecs; ++v) res[v] = load8(base + 8 * v);
        }
        store_seg(b.dof_near->row(c, y + r), x0, n, res);
      }
    }
  if (job.skip_far) return;
  // Far field: the denominator Σ far_h first (kept as 1/den per texel), then the channels.
  for (int y = 0; y < h; y += kRows) {
    const bool active = seg_has(b, y / kTile, tx0, tx1, kFarBit);
    if (active) run(*b.far_src, 4, y);
    for (int r = 0; r < kRows && y + r < h; ++r) {
      float* id = inv_den + static_cast<std::size_t>(y + r) * kSeg;
      if (active) {
        V8 m[kVecs];
        for (int v = 0; v < kVecs; ++v) {
          m[v] = 1.0f / acc[r][v];
          store8(id + 8 * v, m[v]);
        }
        if (job.far_alpha_is_den) {  // alpha = Σ alpha_far / Σ far_h with the two sums equal
          const float* fr = b.far_h_row(y + r) + x0;
          for (int v = 0; v < kVecs; ++v) res[v] = load8(fr + 8 * v) > zero ? acc[r][v] * m[v] : zero;
          store_seg(b.dof_far->row(3, y + r), x0, n, res);
        }
      } else if (job.far_alpha_is_den) {
        for (int v = 0; v < kVecs; ++v) res[v] = zero;
        store_seg(b.dof_far->row(3, y + r), x0, n, res);
      }
    }
  }
  for (int c = 0; c < (job.far_alpha_is_den ? 3 : 4); ++c)
    for (int y = 0; y < h; y += kRows) {
      const bool active = seg_has(b, y / kTile, tx0, tx1, kFarBit);
      if (active) run(*b.far_src, c, y);
      for (int r = 0; r < kRows && y + r < h; ++r) {
        if (active) {
          const float* fr = b.far_h_row(y + r) + x0;  // padded plane: whole vectors are readable
          const float* id = inv_den + static_cast<std::size_t>(y + r) * kSeg;
          for (int v = 0; v < kVecs; ++v) res[v] = load8(fr + 8 * v) > zero ? acc[r][v] * load8(id + 8 * v) : zero;
        } else {
          for (int v = 0; v < kVecs; ++v) res[v] = zero;
        }
        store_seg(b.dof_far->row(c, y + r), x0, n, res);
      }
    }
}

#if !defined(__clang__)
// Vector helpers of the fold form, for V8 (AVX2 copy) and V16 (AVX-512 copy, zmm registers).
// The FMA and the broadcast are asm for the reasons given at fmadd and broadcast.
typedef float V16 __attribute__((vector_size(64)));
typedef float V8u __attribute__((vector_size(32), aligned(4), may_alias));
typedef float V16u __attribute__((vector_size(64), aligned(4), may_alias));

template <class T>
__attribute__((always_inline)) inline T loadv(const float* p) {
  T v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
template <class T>
__attribute__((always_inline)) inline void storev(float* p, T v) {
  std::memcpy(p, &v, sizeof v);
}
template <class T>
__attribute__((always_inline)) inline T bcastv(const float* p) {
  T r;
  if constexpr (sizeof(T) == 64)
    __asm__("vbroadcastss %1, %0" : "=v"(r) : "m"(*p));
  else
    __asm__("vbroadcastss %1, %0" : "=x"(r) : "m"(*p));
  return r;
}
// w·(*p) + c rounded once, the vector at p read by the FMA itself. (By value: an accumulator
// passed by reference into the asm keeps GCC from holding the array of them in registers.)
template <class T>
__attribute__((always_inline)) inline T fmadd_mem(T c, T w, const float* p) {
  if constexpr (sizeof(T) == 64)
    __asm__("vfmadd231ps %2, %1, %0" : "+v"(c) : "v"(w), "m"(*reinterpret_cast<const V16u*>(p)));
  else
    __asm__("vfmadd231ps %2, %1, %0" : "+x"(c) : "x"(w), "m"(*reinterpret_cast<const V8u*>(p)));
  return c;
}

// The fold form over tile rows [ty0, ty1): per group of kR output rows, plane by plane, the
// sums of chunks of kVecs vectors VT (the chunks cover the runs of tiles that need the plane's
// field; a chunk that would reach past the row moves left, so it recomputes some sums, the
// same values), then the per-texel results over the whole rows as gather_strip_body's (near
// where nearBlur_h > 0 else colour_h; far where far_h > 0 else 0; selects, so the sums of
// tiles without the field are never used). kR × kVecs accumulators keep the FMA pipes busy;
// kR rows share the loads of the V build, so the source rows a group reads from L2 serve kR
// rows (4 rows of 64 texels: 35 source rows × 1.5 (the chunk's reach) per 4 output rows; it
// was 33 × 1.25 per 2 rows with 2 × 128 texels, whose V build took a third of the pass).
// Scratch: vbuf holds the V rows of the kR rows (kR · |e| · vstride floats), acc their sums and
// inv_den their 1/Σ far_h (kR rows of `stride` floats each, stride ≥ w + chunk).
template <class VT, int kVecs, int kR>
__attribute__((always_inline)) inline void fold_rows_body(const Job& job, int ty0, int ty1, float* vbuf, float* acc,
                                                          float* inv_den, int stride) {
  constexpr int kL = sizeof(VT) / sizeof(float);
  constexpr int kCW = kL * kVecs;  // texels per chunk
  const Buffers& b = *job.b;
  const FoldKernel& F = *job.fold;
  const int w = b.w, h = b.h;
  const std::ptrdiff_t pitch = b.near_src->width();
  const int ne = static_cast<int>(F.e.size());
  const int vs = F.vstride;
  const std::ptrdiff_t vrow = static_cast<std::ptrdiff_t>(ne) * vs;  // floats of one output row's V rows
  const FoldTerm* pr = F.pairs.data();
  const int np = static_cast<int>(F.pairs.size());
  const FoldTerm* sg = F.single.data();
  const int nsg = static_cast<int>(F.single.size());
  // Sums of rows y … y + kR − 1 of plane c of src over texels x0 … x0 + kNV·kL − 1, into acc
  // (kNV ≤ kVecs vectors: a run's last chunk takes only the vectors it needs, see runs()).
  auto chunk = [&]<int kNV>(const Image& src, int c, int y, int x0) __attribute__((always_inline)) {
    // V rows of the kR output rows. With S[k] = src row y + k, V_e(y + r) = S[r + e] + S[r − e]:
    // going through e = 1, 2, …, U[r] = S[r + e] and D[r] = S[r − e] shift by one row per step
    // (U[r] ← U[r + 1], D[r] ← D[r − 1]), so each source vector is loaded once for all kR rows;
    // the rows of e that no pair uses are not stored.
    const float* base = b.src_row(src, c, y) + x0 + F.bx;
    const int* slot = F.e_slot.data();
    const int emax = static_cast<int>(F.e_slot.size()) - 1;
    // (The V columns this chunk's pairs read: its kNV·kL texels and the kernel's dx span.)
    const int vend = kNV == kVecs ? vs : std::min(vs, (kNV * kL + F.vspan + kL - 1) / kL * kL);
    for (int k = 0; k < vend; k += kL) {
      const float* p = base + k;
      VT U[kR], D[kR];
      for (int r = 0; r < kR; ++r) U[r] = D[r] = loadv<VT>(p + r * pitch);
      if (slot[0] >= 0)
        for (int r = 0; r < kR; ++r) storev(vbuf + r * vrow + slot[0] * vs + k, U[r]);
      for (int e = 1; e <= emax; ++e) {
        for (int r = 0; r + 1 < kR; ++r) U[r] = U[r + 1];
        for (int r = kR - 1; r > 0; --r) D[r] = D[r - 1];
        U[kR - 1] = loadv<VT>(p + (kR - 1 + e) * pitch);
        D[0] = loadv<VT>(p - e * pitch);
        if (slot[e] >= 0)
          for (int r = 0; r < kR; ++r) storev(vbuf + r * vrow + slot[e] * vs + k, U[r] + D[r]);
      }
    }
    VT a[kR][kNV];
    for (int r = 0; r < kR; ++r)
      for (int v = 0; v < kNV; ++v) a[r][v] = VT{};
    for (int k = 0; k < np; ++k) {
      const VT wv = bcastv<VT>(&pr[k].w);
      const float* q = vbuf + pr[k].off;
      for (int r = 0; r < kR; ++r)
        for (int v = 0; v < kNV; ++v) a[r][v] = fmadd_mem(a[r][v], wv, q + r * vrow + kL * v);
    }
    const float* P = b.src_row(src, c, y) + x0;
    for (int k = 0; k < nsg; ++k) {
      const VT wv = bcastv<VT>(&sg[k].w);
      const float* q = P + sg[k].off;
      for (int r = 0; r < kR; ++r)
        for (int v = 0; v < kNV; ++v) a[r][v] = fmadd_mem(a[r][v], wv, q + r * pitch + kL * v);
    }
    for (int r = 0; r < kR; ++r)
      for (int v = 0; v < kNV; ++v) storev(acc + r * stride + x0 + kL * v, a[r][v]);
  };
  // A chunk of kNV vectors from x, moved left where it would reach past the row (it then
  // recomputes some sums: the same values).
  auto chunk_at = [&]<int kNV>(const Image& src, int c, int y, int x) __attribute__((always_inline)) {
    constexpr int kW = kNV * kL;
    chunk.template operator()<kNV>(src, c, y, w >= kW ? std::min(x, w - kW) : 0);
  };
  // chunk() over the runs of tiles of tile row ty with `bit`.
  auto runs = [&](int ty, std::uint8_t bit, const Image& src, int c, int y) __attribute__((always_inline)) {
    const std::uint8_t* t = b.tiles->data() + static_cast<std::size_t>(ty) * b.tiles_x;
    for (int tx = 0; tx < b.tiles_x;) {
      if (!(t[tx] & bit)) {
        ++tx;
        continue;
      }
      int te = tx;
      while (te < b.tiles_x && (t[te] & bit)) ++te;
      const int end = std::min(te * kTile, w);
      // Whole chunks, then the last one only as wide as the rest of the run needs, in vectors
      // (a run is whole 8-texel tiles: with 64-texel chunks throughout, 11 % of the bench
      // frame's chunk texels lay past their runs; with the narrow last chunk 1 %). Every lane
      // takes the same operations in the same order whatever the chunk's width.
      int x = tx * kTile;
      for (; end - x > kCW - kL; x += kCW) chunk_at.template operator()<kVecs>(src, c, y, x);
      static_assert(kVecs == 4, "the tail below covers 1 … 3 vectors");
      const int rest = (end - x + kL - 1) / kL;
      if (rest == 3)
        chunk_at.template operator()<3>(src, c, y, x);
      else if (rest == 2)
        chunk_at.template operator()<2>(src, c, y, x);
      else if (rest == 1)
        chunk_at.template operator()<1>(src, c, y, x);
      tx = te;
    }
  };
  const VT zero = VT{}, inv_taps = VT{} + job.inv_taps;
  for (int ty = ty0; ty < ty1; ++ty)
    for (int y = ty * kTile; y < std::min(h, (ty + 1) * kTile); y += kR) {
      const int nr = std::min(kR, h - y);
      // Near field: (1/49) Σ colour_h where nearBlur_h > 0, else colour_h.
      for (int c = 0; c < 4; ++c) {
        const bool gathered = !(c == 3 && job.near_alpha_const);
        if (gathered) runs(y / kTile, kNearBit, *b.near_src, c, y);
        for (int r = 0; r < nr; ++r) {
          const float* col = b.src_row(*b.near_src, c, y + r);
          const float* nb = b.near_blur->row(0, y + r);
          const float* g = acc + r * stride;
          float* out = b.dof_near->row(c, y + r);
          const float na = job.near_alpha[(y + r) & 1];
          int x = 0;
          for (; x + kL <= w; x += kL)
            storev(out + x, loadv<VT>(nb + x) > zero ? (gathered ? loadv<VT>(g + x) * inv_taps : VT{} + na)
                                                     : loadv<VT>(col + x));
          for (; x < w; ++x) out[x] = nb[x] > 0.0f ? (gathered ? g[x] * job.inv_taps : na) : col[x];
        }
      }
      if (job.skip_far) continue;
      // Far field: the denominator Σ far_h first (kept as 1/den per texel), then the channels.
      runs(y / kTile, kFarBit, *b.far_src, 4, y);
      for (int r = 0; r < nr; ++r) {
        const float* fr = b.far_h_row(y + r);
        const float* g = acc + r * stride;
        float* id = inv_den + r * stride;
        float* out = b.dof_far->row(3, y + r);
        int x = 0;
        for (; x + kL <= w; x += kL) {
          const VT d = loadv<VT>(g + x), m = 1.0f / d;
          storev(id + x, m);
          if (job.far_alpha_is_den) storev(out + x, loadv<VT>(fr + x) > zero ? d * m : zero);
        }
        for (; x < w; ++x) {
          const float m = 1.0f / g[x];
          id[x] = m;
          if (job.far_alpha_is_den) out[x] = fr[x] > 0.0f ? g[x] * m : 0.0f;
        }
      }
      for (int c = 0; c < (job.far_alpha_is_den ? 3 : 4); ++c) {
        runs(y / kTile, kFarBit, *b.far_src, c, y);
        for (int r = 0; r < nr; ++r) {
          const float* fr = b.far_h_row(y + r);
          const float* g = acc + r * stride;
          const float* id = inv_den + r * stride;
          float* out = b.dof_far->row(c, y + r);
          int x = 0;
          for (; x + kL <= w; x += kL)
            storev(out + x, loadv<VT>(fr + x) > zero ? loadv<VT>(g + x) * loadv<VT>(id + x) : zero);
          for (; x < w; ++x) out[x] = fr[x] > 0.0f ? g[x] * id[x] : 0.0f;
        }
      }
    }
}

// The fold form's sum over a plane that holds v everywhere (V_0 = v, V_e = v + v, single
// texels v), in fold_rows_body's order, scalar (rounding as the vector lanes).
float constant_fold(const FoldKernel& F, float v) {
  float acc = 0.0f;
  for (std::size_t k = 0; k < F.pairs.size(); ++k) acc = fmadd<true>(F.pairs[k].w, F.e_of[k] == 0 ? v : v + v, acc);
  for (const FoldTerm& t : F.single) acc = fmadd<true>(t.w, v, acc);
  return acc;
}
#endif

// gather_strip_body (and the constant-plane sums that must match it) compiled for AVX-512,
// AVX2+FMA and the baseline, chosen at run time (as target_clones would, which cannot be used
// here: the pinned loads exist only in the AVX copies, and the choice of the strip kernel and
// of constant_near must be the same one). Contraction stays off in all three: the FMA copies
// fuse exactly the operations written with fmadd, nothing else.
struct Kernels {
  void (*strip)(const Job& job, int tx0, int tx1, float* inv_den);
  float (*constant_near)(const Job& job, float v, int parity);
  // The fold form (FMA copies only; null otherwise) and its chunk width in texels.
  void (*fold)(const Job& job, int ty0, int ty1, float* vbuf, float* acc, float* inv_den, int stride) = nullptr;
  int fold_chunk = 0;
};
#if defined(__clang__)
void gather_strip_base(const Job& job, int tx0, int tx1, float* inv_den) {
  gather_strip_body<false, false>(job, tx0, tx1, inv_den);
}
float constant_near_base(const Job& job, float v, int parity) { return constant_near_body<false>(job, v, parity); }
const Kernels& kernels() {
  static const Kernels k{gather_strip_base, constant_near_base};
  return k;
}
#else
#define STERNA_GATHER_COPY(suffix, attrs, pin, fma)                                                                \
  __attribute__((attrs, optimize("fp-contract=off"))) void gather_strip_##suffix(const Job& job, int tx0, int tx1, \
                                                                                 float* inv_den) {                 \
    gather_strip_body<pin, fma>(job, tx0, tx1, inv_den);                                                           \
  }                                                                                                                \
  __attribute__((attrs, optimize("fp-contract=off"))) float constant_near_##suffix(const Job& job, float v,        \
                                                                                   int parity) {                   \
    return constant_near_body<fma>(job, v, parity);                                                                \
  }
STERNA_GATHER_COPY(avx512, target("avx512f,fma"), true, true)
STERNA_GATHER_COPY(avx2, target("avx2,fma"), true, true)
STERNA_GATHER_COPY(base, used, false, false)  // (`used`: a no-op attribute, the macro wants one)
#undef STERNA_GATHER_COPY
__attribute__((target("avx512f,fma"), optimize("fp-contract=off"))) void fold_rows_avx512(const Job& job, int ty0,
                                                                                          int ty1, float* vbuf,
                                                                                          float* acc, float* inv_den,
                                                                                          int stride) {
  fold_rows_body<V16, 4, 4>(job, ty0, ty1, vbuf, acc, inv_den, stride);
}
// The widest copy the CPU runs, at most core::simd_level_cap() (tests pin narrower ones).
const Kernels& kernels() {
  static const Kernels k512{gather_strip_avx512, constant_near_avx512, fold_rows_avx512, 64};
  static const Kernels k2{gather_strip_avx2, constant_near_avx2};
  static const Kernels kb{gather_strip_base, constant_near_base};
  const core::SimdLevel cap = core::simd_level_cap();
  if (!__builtin_cpu_supports("fma")) return kb;
  if (__builtin_cpu_supports("avx512f") && cap >= core::SimdLevel::avx512) return k512;
  if (__builtin_cpu_supports("avx2") && cap >= core::SimdLevel::avx2) return k2;
  return kb;
}
#endif

STERNA_SIMD void classify_row(const float* __restrict nb, const float* __restrict fr, std::uint8_t* tiles, int w) {
  const V8 zero = splat(0.0f);
  int x0 = 0, t = 0;
  for (; x0 + kTile <= w; x0 += kTile, ++t)  // whole tiles: one vector each
    tiles[t] |= (any(load8(nb + x0) > zero) ? kNearBit : 0) | (any(load8(fr + x0) > zero) ? kFarBit : 0);
  for (; x0 < w; x0 += kTile, ++t) {
    const int x1 = std::min(w, x0 + kTile);
    bool nn = false, ff = false;
    for (int x = x0; x < x1; ++x) {
      nn |= nb[x] > 0.0f;
      ff |= fr[x] > 0.0f;
    }
    tiles[t] |= (nn ? kNearBit : 0) | (ff ? kFarBit : 0);
  }
}

}  // namespace

void gather(const Settings& s, Buffers& b) {
  const int w = b.w, h = b.h;
  b.tiles_x = (w + kTile - 1) / kTile;
  b.tiles_y = (h + kTile - 1) / kTile;
  b.tiles->assign(static_cast<std::size_t>(b.tiles_x) * b.tiles_y, 0);
  core::parallel_for(b.tiles_y, [&](int t0, int t1) {
    for (int ty = t0; ty < t1; ++ty)
      for (int y = ty * kTile; y < std::min(h, (ty + 1) * kTile); ++y)
        classify_row(b.near_blur->row(0, y), b.far_h_row(y), b.tiles->data() + static_cast<std::size_t>(ty) * b.tiles_x,
                     w);
  });
  // Bit 1: colour_h alpha is a0 everywhere (== : its least and largest value are equal), bit 2:
  // colourFar_h alpha equals far_h bit for bit; from the downsample's per-row figures (it used
  // to be two scans of three planes here, ~2 % of the frame).
  const float a0 = b.src_row(*b.near_src, 3, 0)[0];
  float alpha_lo = a0, alpha_hi = a0;
  bool far_differs = false;
  for (int y = 0; y < h; ++y) {
    const Buffers::AlphaRow& r = (*b.alpha_rows)[y];
    alpha_lo = std::min(alpha_lo, r.lo);
    alpha_hi = std::max(alpha_hi, r.hi);
    far_differs = far_differs || r.far_differs;
  }
  const std::uint8_t alpha_bits = (alpha_lo == alpha_hi ? 1 : 0) | (far_differs ? 0 : 2);

  const int pitch = b.near_src->width();
  alignas(32) TapV taps[kTaps];
  const int ntaps = static_cast<int>(std::min<std::size_t>(s.offsets.size(), kTaps));
  int dx_min = 0, dx_max = 0, dy_max = 0;
  thread_local std::vector<std::pair<float, float>> scaled;  // (per rendering thread, grown once)
  scaled.clear();
  for (int t = 0; t < ntaps; ++t) {
    const float ox = s.offsets[t].x * s.kernel_scale, oy = s.offsets[t].y * s.kernel_scale;
    scaled.emplace_back(ox, oy);
    const Tap tp = split(ox, oy, pitch);
    taps[t] = {splat(tp.w00), splat(tp.w10), splat(tp.w01),    splat(tp.w11),
               splat(tp.fx),  splat(tp.fy),  splat(1 - tp.fy), tp.off};
    dx_min = std::min(dx_min, static_cast<int>(std::floor(ox)));
    dx_max = std::max(dx_max, static_cast<int>(std::floor(ox)) + 1);
    dy_max = std::max(dy_max, static_cast<int>(std::floor(oy)) + 1);
  }
  const float inv_taps = 1.0f / static_cast<float>(s.offsets.size());
  // Opaque frames (alpha 1 everywhere, the usual case): the downsample's alpha mean is then
  // 4/4 = 1 exactly and the bilateral alpha is Σwb·1 / Σwb = 1 exactly, times far(TL) — the far
  // CoC itself. Two of the nine gathered planes are then known without gathering: the near
  // alpha gather of a constant plane gives one value everywhere, and the far alpha gather is
  // the denominator's sum, so alpha_far = den · (1/den). Both are the very operations of the
  // full gather on the same inputs, so the output stays bit-identical; the checks are exact
  // (==, bit patterns) and any frame that fails them takes the full gather. (Bit-identical to
  // the full gather, that is; with the FMA kernel that differs from plain by rounding.)
  // (With the FMA kernel the near alpha of a constant plane differs between even and odd rows
  // by rounding — see tap_rows2 and texel_rows — so it is computed once per parity, by the
  // same compiled copy and form as the gather it stands for.)
  // The FMA copies' form: texel weights where a row pair needs no more FMAs that way than the
  // separable form's FMA-pipe operations (2.75 per tap and output row; see the top).
  thread_local TexelKernel texels;
  build_texel_kernel(scaled, pitch, texels);
  const long texel_fmas = 2L * static_cast<long>(texels.both.size()) + static_cast<long>(texels.only0.size()) +
                          static_cast<long>(texels.only1.size());
  const bool texel = 4 * texel_fmas <= 22L * ntaps;  // ≤ 2 rows × 2.75 × ntaps
  const Kernels& kern = kernels();
  const bool near_alpha_const = (alpha_bits & 1) != 0;
  Job job{.b = &b,
          .taps = taps,
          .ntaps = ntaps,
          .texel = texel,
          .both = texels.both.data(),
          .nboth = static_cast<int>(texels.both.size()),
          .only0 = texels.only0.data(),
          .nonly0 = static_cast<int>(texels.only0.size()),
          .only1 = texels.only1.data(),
          .nonly1 = static_cast<int>(texels.only1.size()),
          .inv_taps = inv_taps,
          .near_alpha_const = near_alpha_const,
          .near_alpha = {0.0f, 0.0f},
          .far_alpha_is_den = (alpha_bits & 2) != 0,
          .skip_far = s.per_pixel_scale,
          .pf_dy = dy_max,
          .pf_dx = dx_min,
          .pf_span = dx_max - dx_min + kSeg + 8};
  // The fold form wherever it pays (AVX-512 copy; see FoldKernel).
  thread_local FoldKernel fold_tls;
  FoldKernel& fold = fold_tls;  // (the workers see the calling thread's, through the reference)
  if (kern.fold) build_fold_kernel(scaled, pitch, kern.fold_chunk, fold);
  if (kern.fold && fold.ok) {
#if !defined(__clang__)
    job.fold = &fold;
    if (near_alpha_const) job.near_alpha[0] = job.near_alpha[1] = constant_fold(fold, a0) * inv_taps;
    const int stride = (w + kern.fold_chunk + 15) / 16 * 16;
    core::parallel_for(b.tiles_y, [&](int t0, int t1) {
      // (per thread, grown once; 64-byte aligned)
      thread_local std::vector<float> buf;
      const std::size_t nv = 4 * fold.e.size() * static_cast<std::size_t>(fold.vstride);
      const std::size_t n = nv + 8 * static_cast<std::size_t>(stride) + 16;
      if (buf.size() < n) buf.resize(n);
      float* p = buf.data();
      p += (16 - (reinterpret_cast<std::uintptr_t>(p) >> 2) % 16) % 16;
      kern.fold(job, t0, t1, p, p + nv, p + nv + 4 * static_cast<std::size_t>(stride), stride);
    });
    if (s.per_pixel_scale) far_per_texel(s, b);
    return;
#endif
  }
  if (near_alpha_const)
    for (int parity = 0; parity < 2; ++parity) job.near_alpha[parity] = kern.constant_near(job, a0, parity);
  const int strips = (b.tiles_x + kStripTiles - 1) / kStripTiles;
  core::parallel_for(strips, [&](int s0, int s1) {
    thread_local std::vector<float> inv_den;  // 1/Σ far_h of one strip, h × kSeg
    if (inv_den.size() < static_cast<std::size_t>(h) * kSeg) inv_den.resize(static_cast<std::size_t>(h) * kSeg);
    for (int st = s0; st < s1; ++st)
      kern.strip(job, st * kStripTiles, std::min(b.tiles_x, (st + 1) * kStripTiles), inv_den.data());
  });
  if (s.per_pixel_scale) far_per_texel(s, b);
}

}  // namespace dofkit::detail::sterna::fast
