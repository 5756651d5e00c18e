// The plain C++ row kernels of layered's fast passes (fast_*.cpp, fused_*.cpp), compiled for
// AVX-512 / AVX2 / baseline x86-64 and chosen at run time (DOFKIT_CLONES, without FMA
// contraction: every target rounds like the plain passes, bit for bit). Rows are blocks of at
// most kBlock = 256 columns; `float (*)[256]` arguments are 4 channel rows of a block. What
// each computes, and which plain arithmetic it repeats, is written at its definition
// (fast_kernels.cpp). The Highway kernels are in fused_simd.hpp.
#pragma once
#include <cstdint>

namespace dofkit::detail::layered::kern {

void up_pairs(const float* __restrict src, int i0, int i1, float* __restrict dst);
void up_quads(const float* __restrict src, int i0, int i1, float* __restrict dst);
void lerp_rows(const float* __restrict top, const float* __restrict bot, float t, int n, float* __restrict dst);
void lerp_rows4(const float* __restrict top, const float* __restrict bot, float t, int lo, int hi, bool plus_zero,
                float* __restrict dst);
void matte_row(const std::uint16_t* __restrict code, const float* __restrict w0, const float* const* in, int k, int lo,
               int hi, float (*o)[256]);
void hole_row(const std::uint16_t* __restrict code, int k, int lo, int n, std::uint8_t* __restrict hb);
void fill_row(const std::uint8_t* __restrict hb, float (*up)[256], bool opaque, bool under, int lo, int n,
              float (*o)[256]);
void over_rows(float (*c)[256], const float* const* a, bool layer_in_front, int n);
void down_pairs(const float* __restrict a, const float* __restrict b, int m, float* __restrict d);
bool any_tiny(const float* __restrict p, int n);
void code_summary(const std::uint16_t* __restrict code, const float* __restrict w0, const float* __restrict a, int n,
                  std::uint32_t* pres, std::uint32_t* hk, std::uint32_t* ne, std::uint32_t* __restrict cm,
                  std::uint32_t* __restrict ch);
void pull_sum(const float* __restrict z0, const float* __restrict z1, int m, const double* __restrict sw,
              const double* __restrict rw, float* __restrict d);
void pull_pairs(float (*r0)[256], float (*r1)[256], const std::uint8_t* __restrict h0,
                const std::uint8_t* __restrict h1, int m, int c0, int c1, float* const* cv, float* __restrict cw);
void pull_pairs_w(const float* const* f0, const float* const* f1, const float* __restrict w0,
                  const float* __restrict w1, int m, float* const* cv, float* __restrict cw);
void final_channel(const float* __restrict c, const float* __restrict t, const float* __restrict b,
                   const float* __restrict u, const float* __restrict f, int n, float* __restrict o);
void one_minus(const float* __restrict a, int n, float* __restrict t);
bool code_run16(const float* __restrict a, const float* __restrict r, std::uint32_t bits, std::uint16_t cd, float wv,
                std::uint16_t* __restrict code, float* __restrict w0);
bool any_byte(const std::uint8_t* __restrict b, int n);
bool any_below_one(const float* __restrict w, int n);
bool all_one(const float* __restrict w, int n);
bool any_bits(const float* __restrict p, int n);
void fill_rows(float* const* p, int rows, int n, float v);

}  // namespace dofkit::detail::layered::kern
