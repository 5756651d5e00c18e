// The SIMD far/focus gather of the McGuire dual blur (book/demo tap weights), shared by the
// fast horizontal and vertical passes (fast.cpp). One call sums, for n adjacent outputs at
// once, the taps listed in the job; every tap supplies contiguous per-output arrays, so the
// caller decides the geometry (phase-split rows for the horizontal pass, rows for the
// vertical pass).
#pragma once
#include <cstddef>
#include <cstdint>

namespace dofkit::detail::mcguire {

/// Per tap: pointers to the first output's source values; output o reads element o. The
/// planes of one tap lie at fixed strides (GatherJob), so a tap costs two pointer loads:
///   col + c·col_stride   premultiplied RGBA of tap B, c = 0..3
///   aux                  1 / den, correctly rounded, with den = 0.001 + c·|r_B| (c = 0.5
///                        book, 0.8 demo) computed exactly as blur_weights.hpp; +∞ for a
///                        near-field B (its far weight is 0: d5·∞ = ∞ indexes the table's 0)
///   aux + aux_stride     den itself (0 for a near-field B), for the exact index (below)
///   aux + 2·aux_stride   |r_B| px (read only with the far occlusion test)
/// d5 of the centre tap: positive so that a near source gives ∞ → weight 0, and so small
/// that a far source (den >= 0.001) still gives index ⌊1e-30 / den⌋ = 0, as δ = 0 does.
constexpr float kCentreD5 = 1e-30f;

struct GatherTap {
  const float* col;
  const float* aux;
  float d5;  ///< 5·|δ|; the centre tap uses kCentreD5 instead of 0 (0/0 would be NaN)
};

struct GatherJob {
  int n = 0;  ///< outputs (n >= 1)
  int ntaps = 0;
  const GatherTap* taps = nullptr;
  int tap_offset = 0;  ///< added to every tap pointer (the first output's index)
  std::ptrdiff_t col_stride = 0, aux_stride = 0;
  const float* r_a = nullptr;       ///< centre radius px, n values
  const float* nearness = nullptr;  ///< saturate(4 r_A), n values
  const float* table = nullptr;     ///< 16 floats: the 7-entry weight table, then zeros
  bool occlusion = false;           ///< book far occlusion test: w ·= saturate(|r_A| − |r_B| + 1.5)
  /// false: every nearness is 0 or 1, and the outputs with nearness 1 are not used (the
  /// caller writes them from its box sums), so w = wn is summed for every lane.
  bool frac = true;
  float* out[4] = {};  ///< blur = Σ w·col / Σ w, n values per channel
};

/// out[c][o] = Σ_t w_t,o·col_t[c][o] / Σ_t w_t,o with w = wn + (1 − wn)·nearness_o and
/// wn = table[min(6, ⌊5|δ| / den⌋)] (× occlusion term; 0 for a near source): the formula of
/// far_weight() for book/demo. The quotient is d5·(1/den); where that lies so close to an
/// integer that it and the correctly rounded d5/den could floor differently, the kernel
/// divides, so the table index is exactly far_weight()'s.
void far_gather_simd(const GatherJob& job);

/// One output row of the composite (composite.cpp's arithmetic): top/bot are two low-res
/// rows already interpolated horizontally (9 planes of w: near α·RGBA, α, blurry RGBA).
struct CompositeRowJob {
  const float* top = nullptr;
  const float* bot = nullptr;
  float wy = 0;  ///< vertical bilinear weight of bot
  int w = 0;
  const float* col[4] = {};    ///< sharp premultiplied RGBA
  const float* coc = nullptr;  ///< signed CoC px; s = clamp(r / R_max, −1, 1), 0 where |r| <= focus_px (pack_coc)
  float inv_rmax = 0, focus_px = 0;
  float far_rescale = 1, coverage_boost = 1;
  bool g3d = false, double_coc = false;
  float* out[4] = {};
  bool stream = false;  ///< non-temporal stores where the output rows allow (then composite_flush_streams())
};
void composite_row_simd(const CompositeRowJob& job);
/// Orders the composite's non-temporal stores (sfence) before the calling task ends.
void composite_flush_streams();

/// One low-res row of the composite interpolated horizontally: for each of `nc` channels,
/// dst[c][x] = a[c][i0[x]] + (a[c][i1[x]] − a[c][i0[x]])·w1[x] for x < w.
struct InterpRowJob {
  int nc = 0, w = 0;
  const float* src[9] = {};
  float* dst = nullptr;  ///< channel c at dst + c·w
  const int* i0 = nullptr;
  const int* i1 = nullptr;
  const float* w1 = nullptr;
  int f_pattern = 0;  ///< f if i0[x] = x / f and i1 = i0 + 1 below the row end (offset fix), else 0
  int n_low = 0;      ///< floats in each src row
};
void interp_row_simd(const InterpRowJob& job);

/// Row set-up of the fast horizontal pass, read straight from the source row (no padded
/// copy): padded x = source x + R, clamped to the row, for x < P = W + 2R, is split by phase
/// (x = f·m + p) into planes ph[q·plane + p·M + m] (plane = f·M), the layout the gather's
/// taps point into:
///   q = 0..3 colour, 4 1/den (+∞ for a near source), 5 den (0.001 + dc·|r_B| as
///   far_weight(), 0 for a near source), 6 |r_B| (only with `abs_r`), 7 near α, 8 near box
///   half-width h (int; 7 and 8 only with `near`, see below)
/// with s exactly as pack_coc computes it and r_B = s·R_max. Per m (index of the f-pixel
/// group x = f·m … f·m + f − 1): reach[m] = the largest ⌊1.2·den⌋ + 1 of the group's far
/// sources (0 if none), and of the pixel of phase p0 (the outputs' centres): rc[m] = r_B,
/// sc[m] = s, nc[m] = saturate(4·r_B).
/// Rows are set up in pieces (prep_row_simd(job, m0, m1): groups m0 … m1 − 1, and up to one
/// vector more, written again with the same values by the next piece), so a caller can use
/// the first part of a row while it is still in L1. The pieces of a row must cover
/// [0, prep_groups(P, f)) once each, in any order (the statistics count each group once).
struct PrepRowJob {
  const float* src[5] = {};  ///< R, G, B, A, r of the source row (W floats each)
  /// render()'s colour check (render/sanitize.hpp, sample_is_sanitary) made on the colour
  /// vectors as they are loaded, every sample of the row being in one of them: `dirty` is
  /// set if one fails (then the outputs are meaningless).
  bool check_colour = false;
  bool dirty = false;
  int W = 0, R = 0, f = 1;
  int M = 0;  ///< phase length (>= ⌈P/f⌉ + 2 rounded up to whole vectors)
  float* ph = nullptr;
  int p0 = 0;
  float* rc = nullptr;
  float* sc = nullptr;
  float* nc = nullptr;
  int* reach = nullptr;
  float inv_rmax = 0, rmax = 0, focus_px = 0, dc = 0.8f;
  bool abs_r = false;
  // Near-field sources (with `near`): h = r_B > 0 ? min(⌊r_B⌋, hbox) : −1, α =
  // near_alpha_horizontal(k, 0, r_B) where r_B > 0 (same float operations), else 0.
  bool near = false;
  int hbox = 0;
  float inv_near = 0;
  bool alpha_code = true;  ///< saturate(4 r·inv_near)^4 (code) vs min(1, r·inv_near)^4 (prose)
  // Out, summed over the calls since reset_stats() (x < P only): any r_B > 0; with `near`
  // the count of sources with h >= 0, their smallest and largest h, and groups m before and
  // after which there is none (finish_near_stats() turns those into x).
  bool any_near = false;
  int near_count = 0, near_hmin = 0, near_hmax = -1, near_first = 0, near_last = -1;
  int first_m = -1, last_m = -1;
  void reset_stats() {
    any_near = false;
    near_count = 0;
    near_hmin = 1 << 30;
    near_hmax = -1;
    first_m = last_m = -1;
    near_first = 0;
    near_last = -1;
  }
};
/// Groups needed for padded x < P (+ 2, for block sums that read a group past the last
/// output's reach).
inline int prep_groups(int P, int f) { return (P + f - 1) / f + 2; }
/// With `near` and near_count > 0: near_first / near_last = the first and last x < P with
/// h >= 0 (found from first_m / last_m).
void finish_near_stats(PrepRowJob& job);

/// Per t_blur row of the fast vertical pass, GatherTap's aux planes from s (plane 4):
/// r = s·R_max, den = 0.001 + dc·|r| as far_weight() (0 for a near source, r > 0.25),
/// inv = 1/den (+∞ for a near source), absr = |r|, for i < w (the three rows may be written
/// up to one vector past w); and per block of `block` columns (a multiple of the lane
/// count) the largest far reach ⌊1.2·den⌋ + 1 (0 if none), as a float.
struct AuxRowJob {
  const float* s = nullptr;
  int w = 0, block = 32;
  float rmax = 0, dc = 0.8f;
  float* inv = nullptr;
  float* den = nullptr;
  float* absr = nullptr;
  float* blk_reach = nullptr;
};
void aux_row_simd(const AuxRowJob& job);

/// Sliding row sum update of the fast vertical pass: dst[i] += Σ_k plus[k][i] − Σ_k minus[k][i]
/// for i < n, in double (the float rows are exact in double, so the only rounding is that of
/// the double additions).
struct SlideRowsJob {
  double* dst = nullptr;
  int n = 0;
  int nplus = 0, nminus = 0;
  const float* plus[8] = {};
  const float* minus[8] = {};
};
void slide_rows_simd(const SlideRowsJob& job);
void prep_row_simd(PrepRowJob& job, int m0, int m1);

/// Block sums of one padded plane for the near-centre box of the fast horizontal pass:
/// G[j] = Σ_{t<f} v[x0 + f·j + t] and Rm[j] = Σ_{t<rem} v[x0 + f·j + t] in double, j < nb,
/// read from the plane's phase split (ph_plane[p·M + m] = v[f·m + p]).
struct BlockSumsJob {
  const float* ph_plane = nullptr;
  int M = 0, f = 1, x0 = 0, rem = 0, nb = 0;
  double* G = nullptr;
  double* Rm = nullptr;
};
void block_sums_simd(const BlockSumsJob& job);

/// Block sums of one near-field level of the fast horizontal pass (f = 2 or 4), read from
/// PrepRowJob's phase planes (`ph`, `M`): for the sources x with h[x] == level,
/// v = (α[x]·col_c[x] (float product), α[x]), and for j < nb
///   G[c][j] = Σ_{t<f} v_c(x0 + f·j + t),  Rm[c][j] = Σ_{t<rem} v_c(x0 + f·j + t)   (double).
/// Reads up to x0 + f·nb (exclusive).
struct LevelBlocksJob {
  const float* ph = nullptr;
  int M = 0;
  int level = 0, x0 = 0, f = 4, rem = 0, nb = 0;
  double* G[5] = {};
  double* Rm[5] = {};
};
void level_blocks_simd(const LevelBlocksJob& job);

/// The per-output scans of the fast passes, for outputs [0, n) (the arrays may be read up to
/// one vector past n). Nearness per output: the first and last output with nearness 1 (−1
/// if none; a near centre: its far/focus output is the caller's box sum), whether some output
/// has nearness < 1 (it needs the far gather) and whether one has 0 < nearness < 1 (the
/// generic weight, no tap bound); with `reach`, the largest reach[g] for g in [g0, g1]
/// (0 if none).
struct ScanBlockJob {
  const float* nearness = nullptr;
  int n = 0;
  const int32_t* reach = nullptr;
  int g0 = 0, g1 = -1;
  int first_one = -1, last_one = -1, max_reach = 0;
  bool any_far = false, any_frac = false;
};
void scan_block_simd(ScanBlockJob& job);

/// Box outputs of the near centres: for i < n with nearness[i] == 1,
/// out[c][i] = float((a[c][i] − b[c][i]) + c[c][i]) / w (double, then float; b, c optional:
/// absent terms are left out), for the channels c < nc; the other outputs are not written.
struct BoxOutJob {
  int nc = 4, n = 0;
  const double* a[4] = {};
  const double* b[4] = {};
  const double* c[4] = {};
  const float* nearness = nullptr;
  float w = 1;
  float* out[4] = {};
};
void box_out_simd(const BoxOutJob& job);

/// dst[i] += (a[i] − b[i]) + c[i] for i < n (double): a near level's window sums.
void window_add_simd(double* dst, const double* a, const double* b, const double* c, int n);

/// dst[i] = float((a[i] − b[i]) + c[i]) · k for i < n: the outputs of a row's only near level.
void window_scale_simd(float* dst, const double* a, const double* b, const double* c, float k, int n);

/// dst[i] = float(src[i]) · k for i < n.
void scale_row_simd(float* dst, const double* src, float k, int n);

/// dst[j] = max over rows y in [y0, y1] of base[y·stride + j], for j < n (floats; n is a
/// few lanes: one column-block reach per lane).
void max_rows_simd(float* dst, const float* base, std::ptrdiff_t stride, int y0, int y1, int n);

}  // namespace dofkit::detail::mcguire
