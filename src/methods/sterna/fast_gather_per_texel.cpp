// per_pixel_scale's far field (impl=fast; oracle: gather.cpp's per-texel loop, the same sums
// in the same order, bit for bit; tests/sterna). Inputs: the padded far planes (colourFar_h,
// far_h) and the tap offsets; output: dof_far, each texel's taps scaled by kernel_scale ·
// far_h, so every texel has its own bilinear splits. Scalar, and with AVX2 gathers eight
// texels at a time (the same operations lane by lane, no FMA).
#include <cmath>
#include <immintrin.h>

#include "core/parallel.hpp"
#include "core/simd_target.hpp"
#include "methods/sterna/fast_gather.hpp"

namespace dofkit::detail::sterna::fast {

namespace {

// gather.cpp's bilinear lookup of padded plane `plane` at (x, y) (texel units, centres at
// integer + ½), the position's split given: the same operations in the same order.
struct Lookup {
  std::ptrdiff_t off;  // row y0, column x0 of the padded plane, from the origin
  float tx, ty;
};
inline Lookup lookup_at(float x, float y, std::ptrdiff_t pitch) {
  const float fx = x - 0.5f, fy = y - 0.5f;
  const float x0 = std::floor(fx), y0 = std::floor(fy);
  return {static_cast<std::ptrdiff_t>(y0) * pitch + static_cast<std::ptrdiff_t>(x0), fx - x0, fy - y0};
}
inline float bilinear_at(const float* origin, const Lookup& l, std::ptrdiff_t pitch) {
  const float* r0 = origin + l.off;
  const float* r1 = r0 + pitch;
  const float tx = l.tx, ty = l.ty;
  return (1 - ty) * ((1 - tx) * r0[0] + tx * r0[1]) + ty * ((1 - tx) * r1[0] + tx * r1[1]);
}

// per_pixel_scale (docs/methods/sterna.md, gather.cpp): the far field of texel p with its offsets
// scaled by kernel_scale · far_h(p), so every texel has its own bilinear splits. gather.cpp's
// per-texel loop with the same sums in the same order (Σ over taps of each channel's lookup,
// then num / den), except that a tap's position is split once for the five planes instead of
// once per plane (the same values). Texels with far_h = 0 get the early-out 0.
// far_texels does texels x0 … x1 − 1 of row y one at a time; far_texels_avx2 eight at a time
// (the lookups by AVX2 gathers, the arithmetic lane by lane the same operations: multiplies and
// adds stay separate, AVX2 without FMA).
struct PerTexel {
  const float* origin[5];  // far_src planes at texel (0, 0)
  float* out[4];           // dof_far row y
  const float* fr;         // far_h row y
  std::ptrdiff_t pitch;
  float ks;
  const std::vector<Offset>* off;
};

void far_texels(const PerTexel& P, int y, int x0, int x1) {
  const std::ptrdiff_t pitch = P.pitch;
  const float ks = P.ks;
  const float* fr = P.fr;
  for (int x = x0; x < x1; ++x) {
    if (!(fr[x] > 0.0f)) {
      for (int c = 0; c < 4; ++c) P.out[c][x] = 0.0f;
      continue;
    }
    const float sc = ks * fr[x];
    const float cx = x + 0.5f, cy = y + 0.5f;
    float num[4] = {0, 0, 0, 0}, den = 0.0f;
    for (const Offset& o : *P.off) {
      const Lookup l = lookup_at(cx + o.x * sc, cy + o.y * sc, pitch);
      for (int c = 0; c < 4; ++c) num[c] += bilinear_at(P.origin[c], l, pitch);
      den += bilinear_at(P.origin[4], l, pitch);
    }
    for (int c = 0; c < 4; ++c) P.out[c][x] = num[c] / den;
  }
}

#if !defined(__clang__)
// row[idx] and row[idx + 1] for the 8 lanes of idx (idx_lo, idx_hi: lanes 0–3, 4–7): the two
// neighbours as one 64-bit element per lane, two 4-lane gathers instead of two 8-lane ones
// (Zen 3 gathers cost per element), then de-interleaved.
__attribute__((target("avx2"), always_inline)) inline void gather_pairs(const float* row, __m128i idx_lo,
                                                                        __m128i idx_hi, __m256& left, __m256& right) {
  const double* base = reinterpret_cast<const double*>(row);
  // (The masked form with every lane on: the unmasked intrinsic's undefined source trips
  // GCC 12's -Wmaybe-uninitialized.)
  const __m256d all = _mm256_castsi256_pd(_mm256_set1_epi64x(-1)), zero = _mm256_setzero_pd();
  const __m256 g0 =
      _mm256_castpd_ps(_mm256_mask_i32gather_pd(zero, base, idx_lo, all, 4));  // l0 r0 l1 r1 | l2 r2 l3 r3
  const __m256 g1 =
      _mm256_castpd_ps(_mm256_mask_i32gather_pd(zero, base, idx_hi, all, 4));  // l4 r4 l5 r5 | l6 r6 l7 r7
  // l0 l1 l4 l5 | l2 l3 l6 l7, then the 64-bit lanes in the order 0, 2, 1, 3: l0 … l7
  left = _mm256_castpd_ps(_mm256_permute4x64_pd(_mm256_castps_pd(_mm256_shuffle_ps(g0, g1, 0x88)), 0xd8));
  right = _mm256_castpd_ps(_mm256_permute4x64_pd(_mm256_castps_pd(_mm256_shuffle_ps(g0, g1, 0xdd)), 0xd8));
}

// Returns the first texel it left to far_texels (the tail of the row).
__attribute__((target("avx2"))) int far_texels_avx2(const PerTexel& P, int y, int w) {
  const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.0f), half = _mm256_set1_ps(0.5f);
  const __m256 ks = _mm256_set1_ps(P.ks), cy = _mm256_set1_ps(y + 0.5f);
  const __m256i pitch = _mm256_set1_epi32(static_cast<int>(P.pitch));
  int x = 0;
  for (; x + 8 <= w; x += 8) {
    const __m256 fr = _mm256_loadu_ps(P.fr + x);
    const __m256 on = _mm256_cmp_ps(fr, zero, _CMP_GT_OQ);
    if (_mm256_movemask_ps(on) == 0) {
      for (int c = 0; c < 4; ++c) _mm256_storeu_ps(P.out[c] + x, zero);
      continue;
    }
    const __m256 sc = _mm256_mul_ps(ks, fr);
    // x + 0.5f per lane: the integer column converted exactly, then the same add.
    const __m256 cx = _mm256_add_ps(
        _mm256_cvtepi32_ps(_mm256_add_epi32(_mm256_set1_epi32(x), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7))), half);
    __m256 num[4] = {zero, zero, zero, zero}, den = zero;
    for (const Offset& o : *P.off) {
      const __m256 px = _mm256_add_ps(cx, _mm256_mul_ps(_mm256_set1_ps(o.x), sc));
      const __m256 py = _mm256_add_ps(cy, _mm256_mul_ps(_mm256_set1_ps(o.y), sc));
      const __m256 fx = _mm256_sub_ps(px, half), fy = _mm256_sub_ps(py, half);
      const __m256 x0 = _mm256_floor_ps(fx), y0 = _mm256_floor_ps(fy);
      const __m256 tx = _mm256_sub_ps(fx, x0), ty = _mm256_sub_ps(fy, y0);
      const __m256 ux = _mm256_sub_ps(one, tx), uy = _mm256_sub_ps(one, ty);
      const __m256i idx = _mm256_add_epi32(_mm256_mullo_epi32(_mm256_cvttps_epi32(y0), pitch), _mm256_cvttps_epi32(x0));
      const __m128i idx_lo = _mm256_castsi256_si128(idx), idx_hi = _mm256_extracti128_si256(idx, 1);
      for (int c = 0; c < 5; ++c) {
        const float* r0 = P.origin[c];
        __m256 a, bb, cc, d;
        gather_pairs(r0, idx_lo, idx_hi, a, bb);
        gather_pairs(r0 + P.pitch, idx_lo, idx_hi, cc, d);
        // (1 − ty)·((1 − tx)·a + tx·b) + ty·((1 − tx)·c + tx·d), as bilinear_at
        const __m256 top = _mm256_add_ps(_mm256_mul_ps(ux, a), _mm256_mul_ps(tx, bb));
        const __m256 bot = _mm256_add_ps(_mm256_mul_ps(ux, cc), _mm256_mul_ps(tx, d));
        const __m256 v = _mm256_add_ps(_mm256_mul_ps(uy, top), _mm256_mul_ps(ty, bot));
        if (c < 4)
          num[c] = _mm256_add_ps(num[c], v);
        else
          den = _mm256_add_ps(den, v);
      }
    }
    for (int c = 0; c < 4; ++c) _mm256_storeu_ps(P.out[c] + x, _mm256_and_ps(on, _mm256_div_ps(num[c], den)));
  }
  return x;
}
#endif

}  // namespace

void far_per_texel(const Settings& s, Buffers& b) {
  const int w = b.w, h = b.h;
#if !defined(__clang__)  // (clang, the fuzz build: far_texels only)
  static const bool cpu_avx2 = __builtin_cpu_supports("avx2");
  const bool avx2 = cpu_avx2 && core::simd_level_cap() >= core::SimdLevel::avx2;
#endif
  core::parallel_for(
      h,
      [&](int y0, int y1) {
        PerTexel P;
        for (int c = 0; c < 5; ++c) P.origin[c] = b.src_row(*b.far_src, c, 0);
        P.pitch = b.far_src->width();
        P.ks = s.kernel_scale;
        P.off = &s.offsets;
        for (int y = y0; y < y1; ++y) {
          P.fr = b.far_h_row(y);
          for (int c = 0; c < 4; ++c) P.out[c] = b.dof_far->row(c, y);
          int x = 0;
#if !defined(__clang__)
          if (avx2) x = far_texels_avx2(P, y, w);
#endif
          far_texels(P, y, x, w);
        }
      },
      4);
}

}  // namespace dofkit::detail::sterna::fast
