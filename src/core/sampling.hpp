// Sampling patterns shared by the methods and the ground-truth ray tracer.
#pragma once
#include <cmath>
#include <numbers>

namespace dofkit::core {

/// Shirley–Chiu concentric map [0,1)² → unit disc (area preserving, keeps strata compact).
inline void concentric_disc(double u, double v, double& x, double& y) {
  const double a = 2 * u - 1, b = 2 * v - 1;
  if (a == 0 && b == 0) {
    x = y = 0;
    return;
  }
  double r, phi;
  if (std::abs(a) > std::abs(b)) {
    r = a;
    phi = (std::numbers::pi / 4) * (b / a);
  } else {
    r = b;
    phi = std::numbers::pi / 2 - (std::numbers::pi / 4) * (a / b);
  }
  x = r * std::cos(phi);
  y = r * std::sin(phi);
}

}  // namespace dofkit::core
