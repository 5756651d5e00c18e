// Highway kernels of the fused Gaussian stack (fused*.cpp, render_gaussian_fused), with run-time
// dispatch (fused_simd.cpp; AVX-512 / AVX2 / SSE4 / baseline). Each computes what the row
// kernels it replaces computed, operation for operation (no contraction: the file is built
// with -ffp-contract=off), so the output stays bit-identical to impl=plain.
#pragma once
#include <cstddef>
#include <cstdint>

namespace dofkit::detail::layered {

/// One row (of a 256-column block) of a composite pass: layer k's matte (0 + w_k·I, w_k from
/// the per-pixel code), its push-pull fill at hole pixels (k >= code >> 6: +0·matte + the
/// vertical lerp of the fill level's cached rows, then inpaint.cpp's opaque / under rules),
/// and "over" with the accumulator's row (the vertical lerp of its cached rows, or +0).
///
/// The four channels of the fill's and the accumulator's rows (ft, fb, at, ab) and of the
/// output c lie kRowStride floats apart (channel ch of ft at ft + ch·kRowStride: the row
/// caches' and the scratch rows' layout), so one pointer serves all four: 5 base pointers
/// instead of 20 keep the kernel's loop in registers.
constexpr int kRowStride = 256;
struct CrowRow {
  const std::uint16_t* code;
  const float* w0;
  const float* in[4];  // colour rows
  int k;
  const float* ft;  // fill level: horizontally up-sampled coarse rows (top, bottom), 4 channels
  const float* fb;
  float fty;
  bool opaque, under;
  int am;  // accumulator: 0 none (the row is the layer), 1 rows of +0, 2 lerp of at / ab by aty
  const float* at;
  const float* ab;
  float aty;
  bool front;  // layer in front of the accumulator (L over A), else behind (A over L)
};

/// Columns [0, n) of c (4 rows of 256): the matte in [lo, hi), the fill in [a0, a1) (empty
/// ranges: none), "over" the accumulator everywhere.
void crow_row_simd(const CrowRow& r, int n, int lo, int hi, int a0, int a1, float (*c)[256]);

/// Two fine rows of layer k (row 2·yc and 2·yc + 1 of a row block) for its push-pull level 1.
struct PullRows {
  const std::uint16_t* code[2];
  const float* w0[2];
  const float* in[2][4];
  int k;
};

/// inpaint.cpp's pull_level for the coarse pixels [0, m) of a block whose 2×2 children all
/// lie in the image: cw = min(1, Σ w / 4) with w = 0 at a hole (k >= code >> 6), else 1; cv =
/// Σ w·v / Σ w in double (0 where Σ w = 0), v = the matte 0 + w_k·I. Values only for the pairs
/// [p0, p1) (the caller guarantees that the matte is +0 in both rows outside them, where the
/// value is +0: what the full sum gives), +0 elsewhere.
void pull_pairs_simd(const PullRows& r, int m, int p0, int p1, float* const* cv, float* cw);

/// One row of the final composite (I = F over L_focus over B): c = the focus layer's row;
/// B and F each absent (mode 0), given as rows (1: b / f, e.g. +0 rows or a full-resolution
/// accumulator) or as the vertical lerp of two cached up-sampled rows (2: top, bottom, ty).
/// out = f + (1 − f.a)·(c + (1 − c.a)·b), with the absent steps left out.
/// c, bt, bb, ft, fb: 4 channels kRowStride floats apart (as in CrowRow).
struct FinalRow {
  const float* c;
  int bm, fm;
  const float* bt;
  const float* bb;
  float bty;
  const float* ft;
  const float* fb;
  float fty;
  bool exact = false;  // the multiplies through double (same bits; for rows with subnormal tails)
};
void final_row_simd(const FinalRow& r, int n, float* const* out);

/// One fine row of composite.cpp's 4×4 box over rows given as the vertical lerp of two cached
/// up-sampled rows (top, bottom: 4 channels kRowStride floats apart; v = t + (b − t)·ty, as
/// lerp_rows): acc[ch][x] (+)= v[4x] + v[4x + 1] + v[4x + 2] + v[4x + 3] in that order, from
/// +0 if first (acc: 4 channels kRowStride / 4 apart), for the outputs [0, m). Four calls,
/// one per fine row in order, leave acc = what down_quads_simd sums before its 0.0625 ·.
/// exact: the multiplies through double (the same bits, no subnormal assists; for rows of an
/// accumulator with subnormal tails).
void lerp_quads_acc_simd(const float* top, const float* bot, float ty, int m, bool first, float* acc,
                         bool exact = false);

/// composite.cpp's 2×2 box of two fine rows given as such lerps (rows a: ta, ba, tya; b: tb,
/// bb, tyb): d[ch][x] = 0.25 · (a[2x] + a[2x + 1] + b[2x] + b[2x + 1]) for x in [0, m).
void lerp_pairs_box_simd(const float* ta, const float* ba, float tya, const float* tb, const float* bb, float tyb,
                         int m, float* const* d, bool exact = false);

/// composite.cpp's 4×4 box for the outputs [0, m) (all 16 taps in range): d[x] = 0.0625 ·
/// (0 + r0[4x] + r0[4x + 1] + … + r3[4x + 3]), summed in that order.
void down_quads_simd(const float* r0, const float* r1, const float* r2, const float* r3, int m, float* d);

/// fast_kernels.cpp's kern::up_pairs / kern::up_quads (the 2× / 4× horizontal up-sampling of the
/// coarse pairs / quads [i0, i1)) with the multiplies through double: the same bits, no
/// subnormal assists (for coarse rows with tiny samples).
void up_pairs_exact_simd(const float* src, int i0, int i1, float* dst);
void up_quads_exact_simd(const float* src, int i0, int i1, float* dst);

/// fast_push_pull.cpp's push at a pyramid level for columns [0, n) of one block (n <= 256), four
/// channels: v + c·ps ← w v + (1 − w) up where w < 1 (w > 0; +0 + up where w <= 0), with up =
/// top + (bot − top)·t from the cached rows top / bot + c·kRowStride. Vectors where every w >= 1 are
/// neither read nor stored (the push keeps them).
void push_rows4_simd(const float* wr, const float* top, const float* bot, float t, int n, float* v, std::size_t ps);

}  // namespace dofkit::detail::layered
