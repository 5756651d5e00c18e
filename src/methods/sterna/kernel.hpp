// Sterna's 49-tap sampling pattern (docs/methods/sterna.md) and Sousa's n-gon modifier, with the
// shape taken from the shared aperture model (core/aperture.hpp).
#pragma once
#include <vector>

#include "core/aperture.hpp"

namespace dofkit::detail::sterna {

/// One gather offset in half-resolution pixels (x right, y down), before kernel_scale.
struct Offset {
  float x = 0, y = 0;
};

/// Aperture shape of the gather kernel as sterna's own `--set` keys give it (kept for
/// compatibility; RenderSettings::aperture is the shared way).
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

/// The 49 offsets: the centre first, then ring i = 1..3 with 8i taps at radius 2i and angles
/// 2πj/(8i), each moved radially onto the model's far-field footprint reflected through the
/// centre (the bokeh of a gather is the reflected tap set, so the bokeh is the footprint), then
/// scaled by (scale_x, scale_y). The outer ring lies on the footprint's boundary.
std::vector<Offset> make_offsets(const core::ApertureModel& model, double scale_x = 1, double scale_y = 1);

/// The same for sterna's own keys: an n-gon with `rotation_deg` clockwise on screen (the
/// shared model's rotation is counter-clockwise), anamorphic x·sqrt(a), y/sqrt(a).
std::vector<Offset> make_offsets(const BokehShape& shape);

}  // namespace dofkit::detail::sterna
