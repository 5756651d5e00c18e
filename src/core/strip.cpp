// The strip operations of core/strip.hpp, shared by both strip filters, core/filters.cpp
// (gaussian_blur_plane, the box blurs) and core/weighted_gaussian.cpp (the normalised Gaussian
// of starcraft's medium level): the transposes between rows and strips and the extended-box
// passes over a strip.
//
// Precision: the window sum S_i = Σ_{|k|<=r} v_{i+k} is updated as S_{i+1} = S_i + v_{i+r+1}
// − v_{i−r} in float. Each update adds a rounding error of at most ε·|S| (ε = 2⁻²⁴), so after
// m updates the drift is <= m·ε·max|S|; recomputing S from scratch every kResync outputs caps
// m, i.e. the error stays below ~kResync·ε ≈ 2e-6 of the local window magnitude (the plain
// form's double sums are exact to that level, its float output rounding is ε).
#include <algorithm>
#include <cstddef>
#include <cstdint>

#include "core/clones.hpp"
#include "core/filters.hpp"
#include "core/simd_target.hpp"
#include "core/strip.hpp"

namespace dofkit::core::strip {

static_assert(kStripLanes == 16, "a strip step is one 16-lane vector");
constexpr int kLanes = kStripLanes;
#define SP_LOAD8(p) (*reinterpret_cast<const Vec8u*>(p))
#define SP_STORE8(p, v) (*reinterpret_cast<Vec8u*>(p) = (v))

#if defined(__clang__)
#define DOFKIT_STRIP_AVX512 0
#else
#define DOFKIT_STRIP_AVX512 1
// The AVX-512 bodies below (chosen at run time): a function of its own per target rather than a
// DOFKIT_CLONES copy, because a strip step is one 16-lane vector there and two 8-lane ones
// elsewhere, and GCC's AVX2 code for generic 16-lane vectors goes through the stack (an AVX2
// clone of the 16-lane cascade ran 2.7× the instructions of the 8-lane one) and splits
// 16-lane shuffles into single-element moves. No FMA contraction, as in DOFKIT_CLONES
// (AVX-512F implies FMA; see core/clones.hpp). Under clang (the fuzz build) the 8-lane form
// runs everywhere.
#define SP_AVX512 __attribute__((target("avx512f"), optimize("fp-contract=off")))
#endif

namespace {

bool has_avx512f() {
#if DOFKIT_STRIP_AVX512
  static const bool yes = __builtin_cpu_supports("avx512f");
  return yes && simd_level_cap() >= SimdLevel::avx512;
#else
  return false;
#endif
}

// Vectors of W floats (GCC/clang vector extension) and their unaligned, aliasing form. A strip
// step (16 lanes) is kLanes / W of them: one zmm value in the AVX-512 body, two ymm (AVX2
// clone) or xmm pairs (baseline) in the DOFKIT_CLONES one. Element by element the same
// scalar operations in the same order whatever W.
template <int W>
struct VecOf;
template <>
struct VecOf<8> {
  typedef float T __attribute__((vector_size(32)));
  typedef float U __attribute__((vector_size(32), aligned(4), may_alias));
};
template <>
struct VecOf<16> {
  typedef float T __attribute__((vector_size(64)));
  typedef float U __attribute__((vector_size(64), aligned(4), may_alias));
};
typedef VecOf<16>::T Vec16;
#define SP_LOAD(p) (*reinterpret_cast<const VecOf<16>::U*>(p))
#define SP_STORE(p, v) (*reinterpret_cast<VecOf<16>::U*>(p) = (v))
#define SP_LOADW(p) (*reinterpret_cast<const typename VecOf<W>::U*>(p))
#define SP_STOREW(p, v) (*reinterpret_cast<typename VecOf<W>::U*>(p) = (v))

// The passes run as a cascade: pass q + 1 runs kResync·m outputs behind pass q, in the same
// loop (cascade_steps), instead of one pass over the whole strip after the other. Why: one
// pass alone is a single chain of dependent adds, sum += hi − lo, one add latency (4 cycles)
// per step whatever the vector width, and each pass streams both strip buffers through L2
// (a 1080p strip is 123 KB, L1 48 KB). In the cascade the passes' chains are independent,
// and pass q + 1 reads pass q's output a few KB after it was written, from L1; what bounds a
// step then is the FP ports (6–7 adds and multiplies per sample and pass, two 512-bit ports:
// ~3.3 cycles per 16-lane step and pass), see kPrefetch for the figures.
//
// Which lag is safe: in time block T pass q computes its block B = T − q·m, outputs
// [32B, 32B + 32) (kResync = 32), and reads its input (pass q − 1's output) at most up to
// 32B + 31 + r + 1. Pass q − 1 has completed its blocks before B + m, outputs < 32B + 32m:
// with 32m >= r + 33 every sample read was written in an earlier time block, never in the
// current one (so the passes of a time block may run in any order or interleaved). The same
// bound covers the border: a read past the end (the right pad) needs pass q − 1 finished,
// which it then is, and its right pad is filled right after the time block that finished it;
// its left pad right after its first block, before pass q starts. Writes cannot overtake
// reads: pass q writes its output (which is pass q − 1's input buffer, the strips
// alternate) at [32B, 32B + 32), below where pass q − 1 still reads (32B + 32m − r − 1 and
// up, and its left pad only in blocks below (r + 1)/32 < m); pass q + 2 writes the same
// buffer as pass q only behind everything pass q + 1 still reads. So every pass sees exactly
// the input it saw when the passes ran one after the other. (Tried and dropped: handing the
// samples from pass to pass through L1-sized rings instead of the second strip buffer, the
// last pass writing in place: no faster for starcraft's two passes, whose strips come from
// L3 there, and 1.1–1.2× the time for layered's three.)
template <int W>
struct Pass {
  static constexpr int kV = kLanes / W;  // vectors per step
  typedef typename VecOf<W>::T V;
  const float* src;       // input, sample 0
  float* dst;             // output, sample 0
  V s[kV], f[kV], g[kV];  // window sum; pending fresh sums of the next two resync points
};

// The first pass of a cascade writes lines of the second strip buffer that are not in L1
// (the buffers are 2 × 123 KB at 1080p), and its stores then wait for the lines to arrive;
// with dozens of stores pending, the leaving-sample loads also run into 4K-aliasing false
// dependences on them. Fetching the lines kPrefetch outputs ahead lets the stores complete at
// L1 speed: a two-pass cascade over a 1920-sample strip in L2, AVX-512, 2.9 → 1.7 ns per
// vector and pass (the passes one after the other: 2.3). A plain prefetch (prefetcht0: the
// clones' targets have no PRFCHW): the line, held by this core alone, arrives in L1
// exclusive, so the store needs no second request; prefetchw measured the same.
// The 8-lane body (AVX2 clone) runs ~14 % more instructions than the one-pass-at-a-time loop
// it replaces (a load instead of a memory operand for the leaving sample, the prefetch, the
// pending sums of three passes spilled: 18 ymm values) but, compiled for AVX2 and timed on
// the same strips, 0.74–0.97 of its time.
constexpr int kPrefetch = 16;

// a · b for 16-lane vectors, rounded like the float multiply but without its microcode assist
// on subnormal operands or results. On Intel cores a vector multiply whose input or output
// has a subnormal lane takes ~100+ cycles (measured ~20× a normal one on a Sapphire Rapids
// core; additions are not affected), and the cascaded blurs of layered's near accumulator carry
// subnormal tails (each finite-support blur multiplies the far tail by its end weights). The
// product of two floats is exact in double (24 + 24 <= 53 bits, and 2^-298 is far inside
// double's range), so converting it to float rounds the exact product once, as the float
// multiply does (gradual underflow included): the same bits. The empty asm keeps GCC from
// narrowing (float)((double)a · (double)b) back to a float multiply (match.pd may). Clang
// rejects a 512-bit asm operand here (this inline function has no AVX-512 target of its own;
// only its callers do), so clang builds (the fuzz build) go without it: a compiler that
// narrows the expression computes the same bits, it only brings the assist back.
template <typename V>
__attribute__((always_inline)) inline V mul_exact16(V a, V b) {
  typedef float F8 __attribute__((vector_size(32)));
  typedef double D8 __attribute__((vector_size(64)));
  const F8 al = __builtin_shufflevector(a, a, 0, 1, 2, 3, 4, 5, 6, 7);
  const F8 ah = __builtin_shufflevector(a, a, 8, 9, 10, 11, 12, 13, 14, 15);
  const F8 bl = __builtin_shufflevector(b, b, 0, 1, 2, 3, 4, 5, 6, 7);
  const F8 bh = __builtin_shufflevector(b, b, 8, 9, 10, 11, 12, 13, 14, 15);
  D8 xl = __builtin_convertvector(al, D8), xh = __builtin_convertvector(ah, D8);
  D8 yl = __builtin_convertvector(bl, D8), yh = __builtin_convertvector(bh, D8);
#if !defined(__clang__)
  asm("" : "+v"(xl), "+v"(xh), "+v"(yl), "+v"(yh));
#endif
  const F8 rl = __builtin_convertvector(xl * yl, F8), rh = __builtin_convertvector(xh * yh, F8);
  return __builtin_shufflevector(rl, rh, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
}

// Steps t … end − 1 of one block of NP passes, pass q from output i0[q] + t on: out = (sum +
// alpha·(lo + hi))·norm, then the window slides, sum += hi − (sample i − r); kFresh >= 1 also
// adds hi to the next resync point's pending sum (f), kFresh == 2 to the one after it (g).
// Sample i − r leaving the window is the next step's lo, so it stays in a register (l).
// Vector v of a step holds lanes v·W … v·W + W − 1. (Inlined into each strip_passes body:
// vector arguments are fine there.)
template <int W, int NP, int kFresh, bool kExact, int kV = kLanes / W, typename V = typename VecOf<W>::T>
__attribute__((always_inline)) inline void cascade_steps(int t, int end, const float* const (&lo)[NP],
                                                         const float* const (&hi)[NP], float* const (&d)[NP],
                                                         V (&s)[NP][kV], V (&f)[NP][kV], V (&g)[NP][kV], V (&l)[NP][kV],
                                                         V va, V vn) {
  for (; t < end; ++t) {
    const std::ptrdiff_t o = static_cast<std::ptrdiff_t>(t) * kLanes;
    __builtin_prefetch(d[0] + o + kPrefetch * kLanes, 1);  // see kPrefetch
#pragma GCC unroll 4
    for (int q = 0; q < NP; ++q)
#pragma GCC unroll 2
      for (int v = 0; v < kV; ++v) {
        const V h = SP_LOADW(hi[q] + o + v * W);
        if constexpr (kExact) {
          static_assert(W == 16);
          SP_STOREW(d[q] + o + v * W, mul_exact16(s[q][v] + mul_exact16(va, l[q][v] + h), vn));
        } else {
          SP_STOREW(d[q] + o + v * W, (s[q][v] + va * (l[q][v] + h)) * vn);
        }
        const V x = SP_LOADW(lo[q] + o + kLanes + v * W);  // sample i − r, leaving the window
        s[q][v] += h - x;
        l[q][v] = x;
        if constexpr (kFresh >= 1) f[q][v] += h;
        if constexpr (kFresh >= 2) g[q][v] += h;
      }
  }
}

// One block of NP passes, pass q's outputs i0[q] … i0[q] + len − 1: steps [0, cf) update the
// window only, [cf, cg) also f, [cg, len) also g (see strip_passes).
template <int W, int NP, bool kExact = false, int kV = kLanes / W, typename V = typename VecOf<W>::T>
__attribute__((always_inline)) inline void cascade_block(Pass<W>* const* ps, const int* i0, int len, int cf, int cg,
                                                         int r, V va, V vn) {
  const float* lo[NP];
  const float* hi[NP];
  float* d[NP];
  V s[NP][kV], f[NP][kV], g[NP][kV], l[NP][kV];
#pragma GCC unroll 4
  for (int q = 0; q < NP; ++q) {
    lo[q] = ps[q]->src + static_cast<std::ptrdiff_t>(i0[q] - r - 1) * kLanes;  // sample i − r − 1
    hi[q] = ps[q]->src + static_cast<std::ptrdiff_t>(i0[q] + r + 1) * kLanes;  // sample i + r + 1
    d[q] = ps[q]->dst + static_cast<std::ptrdiff_t>(i0[q]) * kLanes;
#pragma GCC unroll 2
    for (int v = 0; v < kV; ++v) {
      s[q][v] = ps[q]->s[v];
      f[q][v] = ps[q]->f[v];
      g[q][v] = ps[q]->g[v];
      l[q][v] = SP_LOADW(lo[q] + v * W);
    }
  }
  cascade_steps<W, NP, 0, kExact>(0, cf, lo, hi, d, s, f, g, l, va, vn);
  cascade_steps<W, NP, 1, kExact>(cf, cg, lo, hi, d, s, f, g, l, va, vn);
  cascade_steps<W, NP, 2, kExact>(cg, len, lo, hi, d, s, f, g, l, va, vn);
#pragma GCC unroll 4
  for (int q = 0; q < NP; ++q)
#pragma GCC unroll 2
    for (int v = 0; v < kV; ++v) {
      ps[q]->s[v] = s[q][v];
      ps[q]->f[v] = f[q][v];
      ps[q]->g[v] = g[q][v];
    }
}

// Replicates sample 0 into samples −1 … −(r + 1) and sample n − 1 into n … n + r.
inline void fill_pad_left(float* p, int r) {
  for (int i = 1; i <= r + 1; ++i)
    __builtin_memcpy(p - static_cast<std::ptrdiff_t>(i) * kLanes, p, sizeof(float) * kLanes);
}
inline void fill_pad_right(float* p, int n, int r) {
  const float* e = p + static_cast<std::ptrdiff_t>(n - 1) * kLanes;
  for (int i = 1; i <= r + 1; ++i)
    __builtin_memcpy(p + static_cast<std::ptrdiff_t>(n - 1 + i) * kLanes, e, sizeof(float) * kLanes);
}

constexpr int kMaxCascade = 3;  // passes per cascade: the callers run 1–3

// strip_passes with W-float vectors.
// tiny (W = 16 only; null: none): per chunk of kResync input samples, whether it holds a tiny
// sample (strip_tiny_chunks); the blocks within reach of one take the exact multiplies.
template <int W, int kV = kLanes / W, typename V = typename VecOf<W>::T>
__attribute__((always_inline)) inline float* strip_passes_w(float* a, float* b, int n, int pad, int r, float alpha,
                                                            int passes, const std::uint16_t* tiny = nullptr) {
  const float norm = static_cast<float>(1.0 / (2.0 * r + 1.0 + 2.0 * alpha));
  const V va = alpha + V{}, vn = norm + V{};
  const V zero = {};
  const std::ptrdiff_t off = static_cast<std::ptrdiff_t>(pad) * kLanes;
  // The window sums are recomputed from scratch at every kResync-th output R. The samples of
  // that fresh sum, R − r … R + r, all enter the window as `hi` during the 2r + 1 outputs
  // before R, so the fresh sum is built there (from 0, in the same order) instead of
  // re-reading them: the same value, bit for bit. Up to a window of kResync samples this
  // starts inside the block before R (one pending sum, f); up to 2·kResync it starts in the
  // block before that (a second pending sum, g, for the resync point after next) — the
  // medium level of starcraft at 4K (2r + 1 ≈ 43), where re-summing 43 samples per 32
  // outputs as one dependent chain of adds cost ~40 % of the pass. Wider windows re-sum.
  const int span = 2 * r + 1;
  const bool carry = span <= 2 * kResync;
  const int nb = (n + kResync - 1) / kResync;      // blocks per pass
  const int m = (r + 33 + kResync - 1) / kResync;  // lag between passes, in blocks (32m >= r + 33)
  // Block-relative starts of the f and g steps (a block of len outputs: clamped to it).
  auto from = [&](int k, int len) { return carry ? std::clamp(k * kResync - span, 0, len) : len; };
  for (int done = 0; done < passes;) {
    const int np = std::min(kMaxCascade, passes - done);
    Pass<W> ps[kMaxCascade];
    for (int q = 0; q < np; ++q) {
      ps[q].src = (q % 2 ? b : a) + off;
      ps[q].dst = (q % 2 ? a : b) + off;
      for (int v = 0; v < kV; ++v) ps[q].s[v] = ps[q].f[v] = ps[q].g[v] = zero;
    }
    fill_pad_left(a + off, r);
    fill_pad_right(a + off, n, r);
    for (int T = 0; T < nb + (np - 1) * m; ++T) {
      Pass<W>* full[kMaxCascade];
      int full_i0[kMaxCascade], nfull = 0;
      Pass<W>* part = nullptr;
      int part_i0 = 0;
      for (int q = 0; q < np; ++q) {
        const int B = T - q * m;
        if (B < 0 || B >= nb) continue;
        Pass<W>& p = ps[q];
        const int i0 = B * kResync;
        for (int v = 0; v < kV; ++v) {
          if (i0 == 0 && carry)  // the samples of the first pending sum that enter before output 0
            for (int k = kResync - r; k <= r; ++k)
              p.f[v] += SP_LOADW(p.src + static_cast<std::ptrdiff_t>(k) * kLanes + v * W);
          if (i0 == 0 || !carry) {
            p.s[v] = zero;
            for (int k = -r; k <= r; ++k)
              p.s[v] += SP_LOADW(p.src + static_cast<std::ptrdiff_t>(i0 + k) * kLanes + v * W);
          } else {
            p.s[v] = p.f[v];
            p.f[v] = p.g[v];
            p.g[v] = zero;
          }
        }
        if (i0 + kResync <= n)
          full[nfull] = &p, full_i0[nfull++] = i0;
        else
          part = &p, part_i0 = i0;
      }
      // Exact multiplies for this step's blocks if any input chunk within their reach holds a
      // tiny sample: pass p (1-based over all passes) at block B depends on the input chunks
      // B ± p·reach (a pass reads r + 1 samples either side). Only a question of speed: both
      // forms give the same bits.
      bool exact = false;
      if constexpr (W == 16) {
        if (tiny) {
          const int reach = (r + 1 + kResync - 1) / kResync;
          for (int q = 0; q < np && !exact; ++q) {
            const int B = T - q * m;
            if (B < 0 || B >= nb) continue;
            const int d = (done + q + 1) * reach;
            exact = tiny[std::min(nb, B + d + 1)] != tiny[std::max(0, B - d)];
          }
        }
      }
      if (exact) {
        if constexpr (W == 16) {
          switch (nfull) {
            case 1:
              cascade_block<W, 1, true>(full, full_i0, kResync, from(1, kResync), from(2, kResync), r, va, vn);
              break;
            case 2:
              cascade_block<W, 2, true>(full, full_i0, kResync, from(1, kResync), from(2, kResync), r, va, vn);
              break;
            case 3:
              cascade_block<W, 3, true>(full, full_i0, kResync, from(1, kResync), from(2, kResync), r, va, vn);
              break;
            default:
              break;
          }
          if (part) {
            const int len = n - part_i0;
            cascade_block<W, 1, true>(&part, &part_i0, len, from(1, len), from(2, len), r, va, vn);
          }
        }
      } else {
        switch (nfull) {
          case 1:
            cascade_block<W, 1>(full, full_i0, kResync, from(1, kResync), from(2, kResync), r, va, vn);
            break;
          case 2:
            cascade_block<W, 2>(full, full_i0, kResync, from(1, kResync), from(2, kResync), r, va, vn);
            break;
          case 3:
            cascade_block<W, 3>(full, full_i0, kResync, from(1, kResync), from(2, kResync), r, va, vn);
            break;
          default:
            break;
        }
        if (part) {
          const int len = n - part_i0;
          cascade_block<W, 1>(&part, &part_i0, len, from(1, len), from(2, len), r, va, vn);
        }
      }
      // The borders of the outputs that the next pass of this cascade reads.
      for (int q = 0; q + 1 < np; ++q) {
        const int B = T - q * m;
        if (B == 0) fill_pad_left(ps[q].dst, r);
        if (B == nb - 1) fill_pad_right(ps[q].dst, n, r);
      }
    }
    done += np;
    if (np % 2) std::swap(a, b);  // the cascade's result is in b after an odd number of passes
  }
  return a;
}

DOFKIT_CLONES
float* strip_passes8(float* a, float* b, int n, int pad, int r, float alpha, int passes) {
  return strip_passes_w<8>(a, b, n, pad, r, alpha, passes);
}

#if DOFKIT_STRIP_AVX512
// Per chunk c of kResync samples of a strip of n samples, whether it holds a sample x with
// 0 < |x| < 2^-96 (subnormals, or values a few products away from them; see mul_exact16),
// as the prefix counts tiny[c + 1] − tiny[c] ∈ {0, 1}: tiny[0] = 0, nb + 1 entries. A quick
// look at every eighth sample rejects most strips; then every second sample of each chunk.
// (The tails this is for are smooth; a missed sample costs time, not bits.) Returns false if
// no chunk has one.
typedef unsigned U16s __attribute__((vector_size(64)));
typedef unsigned U16su __attribute__((vector_size(64), aligned(4), may_alias));
// min over the samples [i0, i1) (step) of |x| − 1 as unsigned (x = ±0 wraps to the maximum).
SP_AVX512 __attribute__((always_inline)) inline U16s strip_min_mag(const float* a, int i0, int i1, int step, U16s m) {
  const U16s mag = U16s{} + 0x7fffffffu, one = U16s{} + 1u;
  for (int i = i0; i < i1; i += step) {
    const U16s u = (*reinterpret_cast<const U16su*>(a + static_cast<std::ptrdiff_t>(i) * kLanes) & mag) - one;
    m = m < u ? m : u;
  }
  return m;
}
SP_AVX512 __attribute__((always_inline)) inline unsigned strip_hmin(U16s m) {
  U16s t = __builtin_shufflevector(m, m, 8, 9, 10, 11, 12, 13, 14, 15, 0, 1, 2, 3, 4, 5, 6, 7);
  m = m < t ? m : t;
  t = __builtin_shufflevector(m, m, 4, 5, 6, 7, 0, 1, 2, 3, 12, 13, 14, 15, 8, 9, 10, 11);
  m = m < t ? m : t;
  t = __builtin_shufflevector(m, m, 2, 3, 0, 1, 6, 7, 4, 5, 10, 11, 8, 9, 14, 15, 12, 13);
  m = m < t ? m : t;
  t = __builtin_shufflevector(m, m, 1, 0, 3, 2, 5, 4, 7, 6, 9, 8, 11, 10, 13, 12, 15, 14);
  m = m < t ? m : t;
  return m[0];
}
SP_AVX512 bool strip_tiny_chunks(const float* a, int n, std::uint16_t* tiny) {
  constexpr unsigned kLim = kTinyMagnitudeBits - 1u;
  const U16s init = U16s{} + 0xffffffffu;
  if (strip_hmin(strip_min_mag(a, 0, n, 8, init)) >= kLim) return false;
  const int nb = (n + kResync - 1) / kResync;
  tiny[0] = 0;
  for (int c = 0; c < nb; ++c) {
    const unsigned m = strip_hmin(strip_min_mag(a, c * kResync, std::min(n, c * kResync + kResync), 2, init));
    tiny[c + 1] = static_cast<std::uint16_t>(tiny[c] + (m < kLim));
  }
  return tiny[nb] != 0;
}

SP_AVX512 float* strip_passes16(float* a, float* b, int n, int pad, int r, float alpha, int passes) {
  // The blocks near tiny samples take the multiplies through double (mul_exact16: the same
  // bits, no subnormal assists) on cores whose float multiply is slow there
  // (exact_tiny_multiplies); the rest, and every block elsewhere, the plain float multiplies.
  constexpr int kMaxChunks = 1024;
  std::uint16_t tiny[kMaxChunks + 1];
  if (n <= kMaxChunks * kResync && exact_tiny_multiplies() &&
      strip_tiny_chunks(a + static_cast<std::ptrdiff_t>(pad) * kLanes, n, tiny))
    return strip_passes_w<16>(a, b, n, pad, r, alpha, passes, tiny);
  return strip_passes_w<16>(a, b, n, pad, r, alpha, passes);
}
#endif

}  // namespace

float* strip_passes(float* a, float* b, int n, int pad, int r, float alpha, int passes) {
#if DOFKIT_STRIP_AVX512
  if (has_avx512f()) return strip_passes16(a, b, n, pad, r, alpha, passes);
#endif
  return strip_passes8(a, b, n, pad, r, alpha, passes);
}

// Column strips (the vertical sweep of core/filters.cpp). A strip row is 16 floats, one vector
// (it replaces a scalar copy loop in and a memmove call per row out), and one cache line of
// the plane where its rows are 64-byte aligned; consecutive rows are a plane row apart, as
// far as the 4 KiB page the hardware prefetchers stay within from 1024 columns on, so the
// load asks for the line kColumnAhead rows ahead (960 × 540 planes out of L3: 0.89 of the
// time without it). The store back finds the lines the load brought in (a 1080-row strip is
// 69 KB of lines, still in L2 when its passes are done). layered's vertical sweeps (quarter
// and half resolution, one thread) with the cascaded passes measured 0.72–0.87 of the
// time of that scalar copy in and memmove out.
constexpr int kColumnAhead = 16;

DOFKIT_CLONES
void load_columns(const float* src, std::size_t stride, int n, int nx, float* dst) {
  if (nx == kLanes) {
    for (int y = 0; y < n; ++y) {
      if (y + kColumnAhead < n) __builtin_prefetch(src + (y + kColumnAhead) * stride);
      __builtin_memcpy(dst + static_cast<std::size_t>(y) * kLanes, src + y * stride, sizeof(float) * kLanes);
    }
    return;
  }
  for (int y = 0; y < n; ++y) {  // the last strip of a plane whose width is no multiple of 16
    const float* s = src + y * stride;
    float* d = dst + static_cast<std::size_t>(y) * kLanes;
    for (int j = 0; j < nx; ++j) d[j] = s[j];
    for (int j = nx; j < kLanes; ++j) d[j] = s[nx - 1];
  }
}

DOFKIT_CLONES
void store_columns(const float* src, int n, int nx, float* dst, std::size_t stride) {
  if (nx == kLanes) {
    for (int y = 0; y < n; ++y)
      __builtin_memcpy(dst + y * stride, src + static_cast<std::size_t>(y) * kLanes, sizeof(float) * kLanes);
    return;
  }
  for (int y = 0; y < n; ++y)
    for (int j = 0; j < nx; ++j) dst[y * stride + j] = src[static_cast<std::size_t>(y) * kLanes + j];
}

// 8×8 transposes. The strip of a horizontal sweep is written and read back once per plane,
// so the transposes are a good part of such a sweep (starcraft's medium level: 7.5 % of the
// whole render on 1 thread, measured by skipping them). An 8×8 block costs 8 loads, 24
// shuffles and 8 stores; the SSE 4×4 form it replaces spent twice the loads and stores per
// value. Written with generic vector shuffles, which GCC turns into unpack/shuffle/permute
// instructions for each clone (AVX2: in-lane unpacks and shuffles, then 128-bit permutes).

namespace {

// o[k][j] = r[j][k] for an 8×8 block held in eight vectors.
__attribute__((always_inline)) inline void transpose8(const Vec8 r[8], Vec8 o[8]) {
  Vec8 t[8], u[8];
  for (int i = 0; i < 8; i += 2) {
    t[i] = __builtin_shufflevector(r[i], r[i + 1], 0, 8, 1, 9, 4, 12, 5, 13);
    t[i + 1] = __builtin_shufflevector(r[i], r[i + 1], 2, 10, 3, 11, 6, 14, 7, 15);
  }
  for (int i = 0; i < 8; i += 4)
    for (int h = 0; h < 2; ++h) {
      u[i + 2 * h] = __builtin_shufflevector(t[i + h], t[i + 2 + h], 0, 1, 8, 9, 4, 5, 12, 13);
      u[i + 2 * h + 1] = __builtin_shufflevector(t[i + h], t[i + 2 + h], 2, 3, 10, 11, 6, 7, 14, 15);
    }
  for (int k = 0; k < 4; ++k) {
    o[k] = __builtin_shufflevector(u[k], u[k + 4], 0, 1, 2, 3, 8, 9, 10, 11);
    o[k + 4] = __builtin_shufflevector(u[k], u[k + 4], 4, 5, 6, 7, 12, 13, 14, 15);
  }
}

}  // namespace

namespace {

// The 8×8 forms, every clone; on AVX-512 they take the columns past the last 16 (below).
DOFKIT_CLONES
void load_rows_transposed8(const float* const* rows, int nx, const float* mul, float* dst) {
  int x = 0;
  for (; x + 8 <= nx; x += 8)
    for (int j = 0; j < kLanes; j += 8) {
      Vec8 r[8], o[8];
      for (int i = 0; i < 8; ++i) r[i] = SP_LOAD8(rows[j + i] + x);
      transpose8(r, o);
      for (int k = 0; k < 8; ++k) {
        float* d = dst + static_cast<std::size_t>(x + k) * kLanes + j;
        SP_STORE8(d, mul ? o[k] * SP_LOAD8(mul + static_cast<std::size_t>(x + k) * kLanes + j) : o[k]);
      }
    }
  for (; x < nx; ++x)
    for (int j = 0; j < kLanes; ++j) {
      const std::size_t i = static_cast<std::size_t>(x) * kLanes + j;
      dst[i] = mul ? rows[j][x] * mul[i] : rows[j][x];
    }
}

DOFKIT_CLONES
void store_rows_transposed8(const float* src, int nx, float* const* rows, int nrows) {
  int x = 0;
  const int jv = nrows - nrows % 8;  // rows stored by the 8×8 blocks
  if (jv > 0)
    for (; x + 8 <= nx; x += 8)
      for (int j = 0; j < jv; j += 8) {
        Vec8 s[8], o[8];
        for (int k = 0; k < 8; ++k) s[k] = SP_LOAD8(src + static_cast<std::size_t>(x + k) * kLanes + j);
        transpose8(s, o);
        for (int i = 0; i < 8; ++i) SP_STORE8(rows[j + i] + x, o[i]);
      }
  for (int j = jv; j < nrows; ++j)  // the remaining rows of the block columns
    for (int xx = 0; xx < x; ++xx) rows[j][xx] = src[static_cast<std::size_t>(xx) * kLanes + j];
  for (; x < nx; ++x)
    for (int j = 0; j < nrows; ++j) rows[j][x] = src[static_cast<std::size_t>(x) * kLanes + j];
}

// 16×16 transposes on AVX-512: a block is 16 loads, 64 shuffles and 16 stores of zmm
// registers (the 8×8 form: 32, 96 and 32 of ymm for the same 256 values), each load a whole
// line of a row, each store a whole strip sample. Measured on a 1920-sample strip of 16 rows
// in L2 (out of L3): load 0.70–0.76 (0.83–0.84) of the 8×8 form's time, store 0.72–0.76
// (0.88–0.89); in starcraft's medium level (1 thread, perf samples per render) the loads
// ~0.9, the stores ~0.75 once the blocks start at aligned row columns (unaligned_head).
// Generic vectors again, but in a function of its own for AVX-512F, chosen at run time
// (like sterna's gather kernels): a target_clones copy for AVX2 would have to split 16-lane
// shuffles, and GCC lowers those to single-element moves (valgrind, which has no AVX-512,
// runs the 8×8 form). Same values: a transpose moves bits, and the product with mul is the
// same single multiply (no add to contract with it).
//
#if DOFKIT_STRIP_AVX512
// o[k][j] = r[j][k] for a 16×16 block held in sixteen vectors: 2×2 blocks of pairs (unpack),
// 4×4 blocks within each 128-bit lane (shuffle), then the lanes (two 128-bit shuffles).
__attribute__((always_inline)) inline void transpose16(const Vec16 r[16], Vec16 o[16]) {
  Vec16 t[16], u[16], w[16];
  for (int i = 0; i < 16; i += 2) {
    t[i] = __builtin_shufflevector(r[i], r[i + 1], 0, 16, 1, 17, 4, 20, 5, 21, 8, 24, 9, 25, 12, 28, 13, 29);
    t[i + 1] = __builtin_shufflevector(r[i], r[i + 1], 2, 18, 3, 19, 6, 22, 7, 23, 10, 26, 11, 27, 14, 30, 15, 31);
  }
  for (int i = 0; i < 16; i += 4)
    for (int h = 0; h < 2; ++h) {
      u[i + 2 * h] =
          __builtin_shufflevector(t[i + h], t[i + 2 + h], 0, 1, 16, 17, 4, 5, 20, 21, 8, 9, 24, 25, 12, 13, 28, 29);
      u[i + 2 * h + 1] =
          __builtin_shufflevector(t[i + h], t[i + 2 + h], 2, 3, 18, 19, 6, 7, 22, 23, 10, 11, 26, 27, 14, 15, 30, 31);
    }
  // Lane L of u[4i + c] holds rows 4i … 4i + 3 of column 4L + c; o[4L + c] gathers lane L of
  // u[c], u[4 + c], u[8 + c], u[12 + c].
  for (int i = 0; i < 16; i += 8)
    for (int c = 0; c < 4; ++c) {
      w[i + c] =
          __builtin_shufflevector(u[i + c], u[i + 4 + c], 0, 1, 2, 3, 4, 5, 6, 7, 16, 17, 18, 19, 20, 21, 22, 23);
      w[i + 4 + c] =
          __builtin_shufflevector(u[i + c], u[i + 4 + c], 8, 9, 10, 11, 12, 13, 14, 15, 24, 25, 26, 27, 28, 29, 30, 31);
    }
  for (int c = 0; c < 4; ++c) {
    o[c] = __builtin_shufflevector(w[c], w[8 + c], 0, 1, 2, 3, 8, 9, 10, 11, 16, 17, 18, 19, 24, 25, 26, 27);
    o[4 + c] = __builtin_shufflevector(w[c], w[8 + c], 4, 5, 6, 7, 12, 13, 14, 15, 20, 21, 22, 23, 28, 29, 30, 31);
    o[8 + c] = __builtin_shufflevector(w[4 + c], w[12 + c], 0, 1, 2, 3, 8, 9, 10, 11, 16, 17, 18, 19, 24, 25, 26, 27);
    o[12 + c] =
        __builtin_shufflevector(w[4 + c], w[12 + c], 4, 5, 6, 7, 12, 13, 14, 15, 20, 21, 22, 23, 28, 29, 30, 31);
  }
}

// Columns [0, nx16) (a multiple of 16) of load_rows_transposed / store_rows_transposed with
// all 16 rows.
SP_AVX512 void load_rows_transposed16(const float* const* rows, int nx16, const float* mul, float* dst) {
  for (int x = 0; x < nx16; x += 16) {
    Vec16 r[16], o[16];
    for (int i = 0; i < 16; ++i) r[i] = SP_LOAD(rows[i] + x);
    transpose16(r, o);
    for (int k = 0; k < 16; ++k) {
      float* d = dst + static_cast<std::size_t>(x + k) * kLanes;
      SP_STORE(d, mul ? o[k] * SP_LOAD(mul + static_cast<std::size_t>(x + k) * kLanes) : o[k]);
    }
  }
}

SP_AVX512 void store_rows_transposed16(const float* src, int nx16, float* const* rows) {
  for (int x = 0; x < nx16; x += 16) {
    Vec16 v[16], o[16];
    for (int k = 0; k < 16; ++k) v[k] = SP_LOAD(src + static_cast<std::size_t>(x + k) * kLanes);
    transpose16(v, o);
    for (int i = 0; i < 16; ++i) SP_STORE(rows[i] + x, o[i]);
  }
}

#endif

// The columns before the first where all 16 rows are 64-byte aligned (or, if the rows are
// aligned differently, all of them): the 16×16 blocks start there, so that none of their row
// accesses straddles two cache lines (a row that starts at 16 mod 64, starcraft's ring rows
// for one, made every 16-lane store of the rows two partial-line stores: 1.15–1.3 of the
// 8×8 form's time there).
template <typename Row>
int unaligned_head(Row* const* rows, int nx) {
  const std::uintptr_t a = reinterpret_cast<std::uintptr_t>(rows[0]) % 64;
  for (int j = 1; j < kLanes; ++j)
    if (reinterpret_cast<std::uintptr_t>(rows[j]) % 64 != a) return nx;
  if (a % sizeof(float) != 0) return nx;
  return std::min(nx, static_cast<int>((64 - a) % 64 / sizeof(float)));
}

}  // namespace

void load_rows_transposed(const float* const* rows, int nx, const float* mul, float* dst) {
  const int x0 = has_avx512f() ? unaligned_head(rows, nx) : nx;
  const int x1 = x0 + (nx - x0) / 16 * 16;
  auto by8 = [&](int b, int e) {  // columns [b, e) by the 8×8 form
    if (b >= e) return;
    const float* part[kLanes];
    for (int j = 0; j < kLanes; ++j) part[j] = rows[j] + b;
    const std::size_t o = static_cast<std::size_t>(b) * kLanes;
    load_rows_transposed8(part, e - b, mul ? mul + o : nullptr, dst + o);
  };
  by8(0, x0);
#if DOFKIT_STRIP_AVX512
  if (x1 > x0) {
    const float* part[kLanes];
    for (int j = 0; j < kLanes; ++j) part[j] = rows[j] + x0;
    const std::size_t o = static_cast<std::size_t>(x0) * kLanes;
    load_rows_transposed16(part, x1 - x0, mul ? mul + o : nullptr, dst + o);
  }
#endif
  by8(x1, nx);
}

void store_rows_transposed(const float* src, int nx, float* const* rows, int nrows) {
  const int x0 = has_avx512f() && nrows == kLanes ? unaligned_head(rows, nx) : nx;
  const int x1 = x0 + (nx - x0) / 16 * 16;
  auto by8 = [&](int b, int e) {
    if (b >= e) return;
    float* part[kLanes];
    for (int j = 0; j < nrows; ++j) part[j] = rows[j] + b;
    store_rows_transposed8(src + static_cast<std::size_t>(b) * kLanes, e - b, part, nrows);
  };
  by8(0, x0);
#if DOFKIT_STRIP_AVX512
  if (x1 > x0) {
    float* part[kLanes];
    for (int j = 0; j < kLanes; ++j) part[j] = rows[j] + x0;
    store_rows_transposed16(src + static_cast<std::size_t>(x0) * kLanes, x1 - x0, part);
  }
#endif
  by8(x1, nx);
}

#undef SP_LOAD8
#undef SP_STORE8
#undef SP_LOAD
#undef SP_STORE

}  // namespace dofkit::core::strip
