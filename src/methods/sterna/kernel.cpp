// Sampling pattern of docs/methods/sterna.md.
//
// Sterna's rings are the Shirley–Chiu concentric map of a 7×7 grid: Chebyshev ring k of the
// grid (8k points) lands on the circle of radius k/3 with 8k equally spaced angles. Scaling
// by 6 half-res px gives rings of radius 2, 4, 6 with 8, 16, 24 taps, plus the centre.
//
// For another aperture Sousa keeps the angles and moves each tap radially onto the shape scaled
// to the tap's ring (the aperture model's unit_boundary_map: for a regular n-gon the polar
// equation cos(π/n) / cos(angle from the nearest edge midpoint)). The outer ring therefore lies
// exactly on the shape's boundary and every inner tap strictly inside.
//
// Orientation. A gather that reads source s = p + o into output p spreads each source over
// p = s − o: the bokeh is the tap set reflected through the centre. Behind the focus plane a
// thin lens images a point as the aperture itself (in front of focus, reflected). So the taps
// are the far-field footprint reflected; the far field's bokeh then has the aperture's
// orientation, the convention of the ground-truth renderer. (Rings and even n are symmetric,
// so this only matters for odd n; one tap set serves both fields, so the near field shows the
// far orientation too, where a real lens would show it upside down.)
#include "methods/sterna/kernel.hpp"

#include <cmath>
#include <numbers>

namespace dofkit::detail::sterna {

std::vector<Offset> make_offsets(const core::ApertureModel& model, double scale_x, double scale_y) {
  std::vector<Offset> out;
  out.reserve(kTaps);
  out.push_back({0.0f, 0.0f});
  for (int ring = 1; ring <= kRings; ++ring) {
    const int n = 8 * ring;
    const double rho = kRingSpacing * ring;
    for (int j = 0; j < n; ++j) {
      const double phi = 2.0 * std::numbers::pi * j / n;
      // The footprint point in the opposite direction, reflected back onto angle phi.
      double x, y;
      model.unit_boundary_map(-std::cos(phi), -std::sin(phi), x, y);
      out.push_back({static_cast<float>(-rho * x * scale_x), static_cast<float>(-rho * y * scale_y)});
    }
  }
  return out;
}

std::vector<Offset> make_offsets(const BokehShape& shape) {
  ApertureShape a;
  if (shape.polygon) {
    a.blades = shape.blades;
    a.rotation_deg = -shape.rotation_deg;
  }
  const double sx = std::sqrt(shape.anamorphic);
  return make_offsets(core::ApertureModel(a, 0, 0), sx, 1.0 / sx);
}

}  // namespace dofkit::detail::sterna
