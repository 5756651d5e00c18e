// SIMD kernels of the final pass (final.cpp), the C1 levels (coc.cpp) and the large level's 4×4 reduction
// (large_blur.cpp), Highway with run-time dispatch (final_simd.cpp). Each processes whole vectors from `x0` and returns
// the first column it did not process; the caller finishes the row with the scalar form of the same arithmetic.
#pragma once

namespace dofkit::detail::starcraft {

/// Per-pixel level decision and level weights of one row (see final.cpp step 2 and 4):
/// ws/wm/wl = small/medium/large weights, wsrc = 1 − alpha (the source's share).
/// `any` is set when some processed pixel has alpha != 0.
struct WeightRow {
  const float* cown;      ///< own level c (C1), full res
  const float* z;         ///< depth (m; +inf allowed)
  const float* inv_blur;  ///< blurred 1/z, up-sampled to full res
  const float* cb;        ///< blurred level (C3 plane 4), up-sampled
  bool keep_own_blur;
  float* ws;
  float* wm;
  float* wl;
  float* wsrc;
  /// Set on opaque frames (every source alpha 1, so the medium and large levels' alpha is 1
  /// too, see final.cpp): the output's alpha row, written here from the weights as the mix
  /// would write it, ((ws·(16·(1/17)) + wm) + wl) + wsrc, or 1 where wsrc = 1.
  float* alpha_out = nullptr;
};
int final_weights_simd(const WeightRow& r, int x0, int x1, bool& any);

/// Mix of one channel of one row: the 17-tap small blur from the block sums of the five source
/// rows rows[0..4] = y−2 … y+2 (x−2 … x+2 must be valid columns; rows are for the scalar form), the medium level, the
/// large numerator `num` over the up-sampled blurred level `cb`, blended over `src`. With `mwt` set, `med` is the
/// medium level's blurred c·colour and mwt its blurred weight c: the level is med / mwt where mwt > 1e-6, else the
/// source (the division of the normalised convolution, made here only for the pixels that are mixed).
struct MixRow {
  const float* rows[5];
  /// The 2×2 block sums (block_sums in final.cpp) of the source row pairs starting at y − 2,
  /// y − 1, y + 1 and y: the pinwheel's taps at columns x, x − 2, x − 1 and x + 1.
  const float* blocks[4];
  const float* med;
  const float* mwt;
  const float* num;
  const float* cb;
  const float* ws;
  const float* wm;
  const float* wl;
  const float* wsrc;
  const float* src;
  float* out;
};
int final_mix_simd(const MixRow& r, int x0, int x1);
/// Orders the non-temporal stores final_mix_simd made on this thread before later stores
/// (a store fence): every task that calls final_mix_simd calls it before it ends.
void flush_streams();

/// Horizontal up-sampling of one quarter-res row `v` to full res: cell i writes columns
/// 4i … 4i + 3 (see final.cpp). Reads v[i − 1 … i + 1]: valid for 1 <= i < lw − 1.
int final_hlerp_simd(const float* v, float* out, int i0, int i1);

/// Bilinear up-sampling of the quarter-res rows a (row ya) and b (row yb) to full res, cell i
/// writing columns 4i … 4i + 3, in final_pass_plain's arithmetic (quarter_bilerp in final.cpp:
/// ((w00·a + w01·a') + w10·b) + w11·b' with w00 = (1 − tx)(1 − ty), … ), so bit for bit its
/// values. ty: the row's vertical weight. Reads a, b at i − 1 … i + 1: valid for 1 <= i < lw − 1.
int final_bilerp_simd(const float* a, const float* b, float* out, int i0, int i1, float ty);

/// C1 levels of one row: c[x] = LevelGeometry::level_of_radius(r[x]) (the same formulas, each
/// segment's operands selected and one division; measured: equal to the scalar form or 1 ulp apart);
/// vs, vm, vl = r_small² − 0.25, r_medium² − 0.25, r_large² − 0.25.
int levels_row_simd(const float* r, float* c, int x0, int x1, float vs, float vm, float vl);

/// Large level, 4×4 reduction of the full blocks i in [i0, i1) of block row j (4 source rows
/// rows[k][ch], ch 0-3 colour, 4 the level c, all inside the image): planes out[0..3] get
/// c_block · (c-weighted block colour), out[4] c_block (mean, or max if reduce_max). Float
/// sums (the plain form sums in double). Clears alpha_one if some alpha (rows[k][3]) read is
/// not exactly 1. sanitary set: also clears *sanitary if some colour sample read fails
/// render/sanitize.hpp's sample_is_sanitary.
int large_reduce_simd(const float* const rows[4][5], bool reduce_max, float* const out[5], int i0, int i1,
                      bool& alpha_one, bool* sanitary = nullptr);

}  // namespace dofkit::detail::starcraft
