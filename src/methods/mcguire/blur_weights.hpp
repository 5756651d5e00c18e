// Tap weights of the McGuire dual blur (docs/methods/mcguire.md), shared by the plain
// and the fast blur passes so both evaluate exactly the same formulas.
#pragma once
#include <algorithm>
#include <cmath>

#include "methods/mcguire/mcguire.hpp"

namespace dofkit::detail::mcguire {

inline float saturate(float x) { return std::clamp(x, 0.0f, 1.0f); }

/// r > 0.25 px counts as near field (nearFieldThreshold).
inline bool in_near(float r) { return r > 0.25f; }

/// book: an 11-tap normalised Gaussian (σ ≈ 3.3 taps) sampled at 6 distances, plus 0 for
/// "outside the radius". demo: a flatter, disc-like profile.
constexpr float kGaussianTable[7] = {0.13425804976814f,
                                     0.12815541114232f,
                                     0.11143948794984f,
                                     0.08822292796029f,
                                     0.06352050813141f,
                                     0.04153263993208f,
                                     0.0f};
constexpr float kDiscTable[7] = {1.00f, 1.00f, 0.90f, 0.75f, 0.60f, 0.50f, 0.00f};

/// Far/focus weight of tap B (offset d px, radius r_b) for a centre of radius r_a, before
/// the near-centre lerp. The table index 5·|d| / (c·|r_b|) reaches the zero entry at
/// |d| = 1.2·c·|r_b|: c = 0.5 (book) → taps reach 0.6·|r_b|; c = 0.8 (demo) → 0.96·|r_b|.
/// g3d uses a Gaussian of σ = |r_b| / 2 instead.
inline float far_weight(const Constants& k, float d, float r_a, float r_b) {
  if (in_near(r_b)) return 0.0f;
  const float abs_b = std::fabs(r_b);
  if (k.variant == Variant::g3d) {
    const float inv_b = 1.0f / (0.01f + abs_b);
    float w = std::exp(-2.0f * d * d * inv_b * inv_b);
    // Second term: two strongly blurred far pixels may mix even if B is a little farther.
    if (k.far_occlusion) w *= saturate(std::max(r_b - r_a + 1.0f, (0.01f - r_a) * inv_b));
    return w;
  }
  const bool book = k.variant == Variant::book;
  const float t = 5.0f * std::fabs(d) / (0.001f + (book ? 0.5f : 0.8f) * abs_b);
  const int idx = t >= 6.0f ? 6 : static_cast<int>(t);
  float w = (book ? kGaussianTable : kDiscTable)[idx];
  if (k.far_occlusion) w *= saturate(std::fabs(r_a) - abs_b + 1.5f);
  return w;
}

/// Near coverage α of tap B in the horizontal pass.
inline float near_alpha_horizontal(const Constants& k, float d, float r_b) {
  if (k.variant == Variant::g3d) {
    const float a = saturate(r_b * k.inv_near);
    return a * a;
  }
  if (!(std::fabs(d) <= r_b)) return 0.0f;  // B's disc does not reach A
  float a = k.near_alpha_code ? saturate(4.0f * r_b * k.inv_near) : std::min(1.0f, r_b * k.inv_near);
  a *= a;
  return a * a;
}

/// Near-field box weight at offset d (both passes): [|d| < R_near], or exp(−(d/R_near)²) in g3d.
inline float near_box(const Constants& k, float d) {
  if (k.variant == Variant::g3d) {
    const float t = d * k.inv_near;
    return k.r_near > 0 ? std::exp(-t * t) : 0.0f;
  }
  return std::fabs(d) < k.r_near ? 1.0f : 0.0f;
}

/// 1 / Σ near_box over the taps δ = −R … R (R = k.r_max), summed in that order (every pass,
/// fast and plain, normalises its near box by this same value).
inline float near_box_inverse_norm(const Constants& k) {
  float norm = 0;
  for (int d = -k.r_max; d <= k.r_max; ++d) norm += near_box(k, static_cast<float>(d));
  return 1.0f / std::max(norm, 1e-5f);
}

/// g3d, end of the vertical pass: smoothstep boost of the near coverage,
/// t = saturate(1 − 0.025 / (fov·α)), α' = t²(3 − 2t), colour ×= α'/α.
/// n = (α·R, α·G, α·B, α·A, α). G3D clamps α' to >= 1e-6 only to keep a later division
/// finite; we keep α' = 0 for α = 0 so an empty near field adds exactly nothing.
inline void g3d_coverage_curve(const Constants& k, float* n) {
  const float a = n[4];
  const float fa = k.g3d_fov_rad * a;
  const float t = fa > 0 ? saturate(1.0f - 0.025f / fa) : 0.0f;
  const float a2 = std::min(t * t * (3.0f - 2.0f * t), 1.0f);
  const float g = a > 0 ? a2 / a : 0.0f;
  for (int c = 0; c < 4; ++c) n[c] *= g;
  n[4] = a2;
}

}  // namespace dofkit::detail::mcguire
