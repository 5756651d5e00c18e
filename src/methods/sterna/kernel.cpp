// Sampling pattern of docs/methods/sterna.md.
//
// Sterna's rings are the Shirley–Chiu concentric map of a 7×7 grid: Chebyshev ring k of the
// grid (8k points) lands on the circle of radius k/3 with 8k equally spaced angles. Scaling
// by 6 half-res px gives rings of radius 2, 4, 6 with 8, 16, 24 taps, plus the centre.
//
// For a polygonal aperture Sousa keeps the angles and moves each tap radially onto the
// n-gon scaled to the tap's ring: a point at radius ρ and angle φ goes to ρ·P_n(φ − rot).
// P_n is the polar equation of a regular n-gon: within the sector of the edge whose midpoint
// direction is θ_m = (2π/n)·m, the edge is the line at distance cos(π/n) from the centre
// (circumradius 1), so the boundary lies at cos(π/n)/cos(φ − θ_m). The sector index m is
// the nearest edge midpoint, floor((nφ + π)/(2π)). The outer ring therefore lies exactly on
// the polygon's edges and every inner tap strictly inside.
//
// Orientation. A gather that reads source s = p + o into output p spreads each source over
// p = s − o: the bokeh is the tap set reflected through the centre. Behind the focus plane a
// thin lens images a point as the aperture itself (not reflected; in front of focus it is
// reflected). So the taps are placed on the aperture polygon rotated by a further π; the far
// field's bokeh then has the aperture's orientation: vertices at (2k+1)π/n + rotation, the
// convention of the ground-truth renderer. (Rings and even n are symmetric, so this only
// matters for 5, 7 and 9 blades; the near field shows the far orientation too, where a real
// lens would show it upside down.)
#include "methods/sterna/kernel.hpp"

#include <cmath>
#include <numbers>

namespace dofkit::detail::sterna {

double polygon_radius(int blades, double phi) {
  const double n = blades;
  const double two_pi = 2.0 * std::numbers::pi;
  const double m = std::floor((n * phi + std::numbers::pi) / two_pi);
  return std::cos(std::numbers::pi / n) / std::cos(phi - (two_pi / n) * m);
}

std::vector<Offset> make_offsets(const BokehShape& shape) {
  std::vector<Offset> out;
  out.reserve(kTaps);
  out.push_back({0.0f, 0.0f});
  const double sx = std::sqrt(shape.anamorphic), sy = 1.0 / sx;
  const double rot = shape.rotation_deg * std::numbers::pi / 180.0;
  for (int ring = 1; ring <= kRings; ++ring) {
    const int n = 8 * ring;
    const double rho = kRingSpacing * ring;
    for (int j = 0; j < n; ++j) {
      const double phi = 2.0 * std::numbers::pi * j / n;
      double r = rho;
      if (shape.polygon) r *= polygon_radius(shape.blades, phi - rot - std::numbers::pi);
      out.push_back({static_cast<float>(r * std::cos(phi) * sx), static_cast<float>(r * std::sin(phi) * sy)});
    }
  }
  return out;
}

}  // namespace dofkit::detail::sterna
