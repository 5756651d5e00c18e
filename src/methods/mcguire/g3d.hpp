// SIMD kernels of the g3d dual blur (docs/methods/mcguire.md), used by blur_horizontal /
// blur_vertical (blur.cpp) for Variant::g3d; blur_horizontal_plain / blur_vertical_plain
// stay the oracle (tests/mcguire: G3dPassesMatchPlain, FastPathMatchesPlain).
//
// The g3d far weight of tap B at offset δ, exp(−2δ²/(0.01 + |r_B|)²) (a Gaussian of
// σ = |r_B|/2 around B, "stretched" to B's own radius), never reaches exactly 0 in the tap
// window for a strongly blurred B, so unlike book/demo there is no small data-independent
// reach; each (output, tap) pair costs one exponential. The kernels (g3d_simd.cpp) therefore
//  * evaluate the far taps for 4–16 adjacent outputs at once (Highway, run-time dispatch),
//    with a short exp2 (argument reduction + degree-5 polynomial, relative error ≈ 2e-7)
//    on per-source precomputed −2·log2(e)/(0.01 + |r_B|)²;
//  * skip a tap for the whole vector when every lane's exponent is below kG3dExp2Min: the
//    kernel returns exactly 0 there, so a skipped tap is an exact zero of the kernel itself
//    (the plain pass's std::exp gives at most e^(−100·ln 2) ≈ 8e-31 there, far below the
//    1e-4 tolerance). This is what makes in-focus and mildly blurred regions cheap: a tap
//    of radius r reaches only |δ| < 5.9·(0.01 + r);
//  * replace the Gaussian-weighted sum by the plain box sum for outputs whose centre is in
//    the near field (nearness 1: every tap weight is wn + (1 − wn) = 1 up to rounding);
//  * skip near-field taps whose sources all have α = 0 (exact zeros).
#pragma once
#include <vector>

#include "dofkit/image.hpp"

namespace dofkit::detail::mcguire {

/// Exponents (base 2) below this give weight exactly 0 in the SIMD kernels.
constexpr float kG3dExp2Min = -100.0f;

/// Constants shared by both passes (derived from mcguire::Constants by blur.cpp).
struct G3dParams {
  int R = 0;              ///< tap half-width R_max, px
  int f = 1;              ///< reduction factor (output spacing), px
  float rmax = 0;         ///< R_max as float: r = s·rmax, px
  bool occlusion = true;  ///< far occlusion test: w ·= saturate(max(r_B − r_A + 1, (0.01 − r_A)/(0.01 + |r_B|)))
  float inv_near = 0;     ///< 1 / R_near, 1/px (near coverage α = saturate(r_B / R_near)²)
  float near_inv = 0;     ///< 1 / Σ_δ near_box(δ), the near sums' normaliser
  const float* near_tab = nullptr;  ///< near_box(δ) at index δ + R (2R + 1 values); null = no near field
  const float* d2_tab = nullptr;    ///< δ² at index δ + R (2R + 1 values)
  float fov_rad = 0.7f;             ///< g3d coverage curve parameter, radians
};

/// P2 for one row. src: the packed row's 5 planes (W floats each); output i is centred on
/// packed pixel ox + f·i; t_blur / t_near: the 5 output planes' rows (wo floats each).
struct G3dRowJob {
  const float* src[5] = {};
  int W = 0, ox = 0, wo = 0;
  float* t_blur[5] = {};
  float* t_near[5] = {};
};
void g3d_horizontal_row(const G3dParams& p, const G3dRowJob& job, std::vector<float>& scratch);

/// P3 for output rows [j0, j1) × columns [x0, x1): output row j is centred on input row
/// oy + f·j (inputs: t_blur, t_near as written by P2; outputs blur (4 planes), near (5
/// planes)). x0 must be a multiple of 16 (the widest vector) so that outputs do not depend on
/// how the caller splits the columns; blocks of about 64 rows keep the halo copies cheap.
void g3d_vertical_block(const G3dParams& p, const Image& t_blur, const Image& t_near, int oy, int j0, int j1, int x0,
                        int x1, Image& blur, Image& near, std::vector<float>& scratch);

}  // namespace dofkit::detail::mcguire
