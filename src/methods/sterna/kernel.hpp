// Sterna's 49-tap sampling pattern (docs/methods/sterna.md) and Sousa's n-gon modifier.
#pragma once
#include <vector>

namespace dofkit::detail::sterna {

/// One gather offset in half-resolution pixels (x right, y down), before kernel_scale.
struct Offset {
  float x = 0, y = 0;
};

/// Aperture shape of the gather kernel.
struct BokehShape {
  bool polygon = false;     ///< false: circle (Sterna's rings); true: regular n-gon (Sousa)
  int blades = 6;           ///< n, 5..9 (polygon only)
  double rotation_deg = 0;  ///< rotation of the n-gon, degrees, clockwise on screen (y down)
  double anamorphic = 1.0;  ///< bokeh width / height, 0.5..2; area preserving
};

/// Number of rings, their spacing and the outer radius of the pattern (half-res px).
inline constexpr int kRings = 3;
inline constexpr float kRingSpacing = 2.0f;
inline constexpr float kOuterRadius = kRings * kRingSpacing;  // 6 half-res px = 12 full-res px
inline constexpr int kTaps = 1 + 8 + 16 + 24;                 // 49

/// Sousa's polygon radius factor P_n(φ) = cos(π/n) / cos(φ − (2π/n)·floor((nφ + π)/(2π))):
/// the distance from the centre to the boundary of a regular n-gon of circumradius 1 along
/// direction φ, for an n-gon with a vertex at φ = π/n (edge midpoint at φ = 0).
double polygon_radius(int blades, double phi);

/// The 49 offsets: the centre first, then ring i = 1..3 with 8i taps at radius 2i and angles
/// 2πj/(8i). A polygon scales each tap's radius by P_n(φ − rotation − π) — the aperture
/// reflected through the centre, so that the *bokeh* (the reflected tap set) has vertices at
/// (2k+1)π/n + rotation; anamorphic then stretches x by sqrt(a) and y by 1/sqrt(a).
std::vector<Offset> make_offsets(const BokehShape& shape);

}  // namespace dofkit::detail::sterna
