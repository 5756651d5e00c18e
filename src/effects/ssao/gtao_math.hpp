// The scalar arc cosine of gtao's oracle (gtao.cpp); gtao_simd.cpp computes the same
// polynomial with the same operations, so the two agree bit for bit.
#pragma once
#include <cmath>
#include <numbers>

namespace dofkit::detail::ao {

inline constexpr float kPiF = static_cast<float>(std::numbers::pi);
inline constexpr float kHalfPiF = static_cast<float>(std::numbers::pi / 2);
inline constexpr float kInvPi = static_cast<float>(1 / std::numbers::pi);

/// Coefficients of acos(a) ≈ √(1 − a) (c0 + c1 a + c2 a² + c3 a³) on [0, 1] (Abramowitz &
/// Stegun 4.4.45: |error| <= 6.7e-5 rad, below a 32-sector mask's 0.1 rad resolution and
/// 1e-4 of the visibility).
inline constexpr float kAcos0 = 1.5707288f, kAcos1 = -0.2121144f, kAcos2 = 0.0742610f, kAcos3 = -0.0187293f;

/// acos(x) for x in [−1, 1] (π − acos(−x) for x < 0).
inline float acos_poly(float x) {
  const float a = std::abs(x);
  const float p = ((kAcos3 * a + kAcos2) * a + kAcos1) * a + kAcos0;
  const float r = std::sqrt(1.0f - a) * p;
  return x < 0.0f ? kPiF - r : r;
}

}  // namespace dofkit::detail::ao
