// dofkit — the lens aperture (bokeh shape) and highlight recovery settings.
#pragma once
#include <memory>

#include "dofkit/image.hpp"

namespace dofkit {

/// The shape of the lens aperture, i.e. of the bokeh a point of light blurs to. Conventions
/// (Blender Cycles', so the same numbers give the same bokeh; docs/coc.md):
///  * a point behind the focus plane (far field, CoC r < 0) images to the aperture as it is;
///    a point in front of it (near field, r > 0) to the aperture turned by 180°;
///  * a polygon has its vertices on the circle of radius |r| (the disc it replaces), and at
///    rotation 0 one flat edge faces +x (the edge midpoint straight to the right of the
///    centre); rotation_deg turns it counter-clockwise as seen on screen.
/// Which fields a method honours: MethodInfo::aperture (the others draw their own kernel).
struct ApertureShape {
  /// 0 = circle; 3..16 = regular polygon with this many blades.
  int blades = 0;
  /// Counter-clockwise on screen, degrees (finite; any value, taken modulo 360).
  double rotation_deg = 0;
  /// Blade curvature 0..1: 0 = straight blades (the polygon), 1 = the circle; in between the
  /// edges bulge outward (vertices stay on the circle).
  double curvature = 0;
  /// Anamorphic squeeze 0.1..10: the bokeh's width is its height / anamorphic (Blender's
  /// aperture ratio; 1 = round, 2 = twice as tall as wide). Not area preserving.
  double anamorphic = 1;
  /// Optical vignetting ("cat's eye") 0..1: off-axis bokeh is clipped by a second circle of
  /// the same radius displaced toward the frame centre by cat_eye · (|r| − 0.5) · d, where d
  /// is the source's distance from the centre over the half diagonal (so 1 at the corners).
  /// 0 = off.
  double cat_eye = 0;
  /// Optional kernel image (1 plane grey, or 3–4 planes RGB: one kernel per colour channel,
  /// alpha ignored), at most 1024 × 1024, non-negative finite values, not all zero. Used in
  /// place of blades and curvature; rotation, anamorphic and cat_eye still apply. The image's
  /// longer side spans the bokeh's diameter 2|r|, its top row is the top of the far-field
  /// bokeh on screen, and each kernel is normalised to unit energy.
  std::shared_ptr<const Image> image;

  /// True for the plain circle (every method draws this one).
  bool is_circle() const noexcept {
    return !image && (blades == 0 || curvature >= 1.0) && anamorphic == 1.0 && cat_eye == 0.0;
  }
};

/// Throws Error(usage) naming the CLI flag (--blades, --blade-rotation, --blade-curvature,
/// --anamorphic, --cat-eye, --aperture-image) and the problem.
void validate(const ApertureShape& aperture);

/// Highlight recovery for display-referred colour (8/16-bit sRGB files clip at 1): before the
/// blur, a pixel whose display value (sRGB-encoded, largest of R, G, B, alpha divided out)
/// exceeds `threshold` has its linear colour multiplied by 1 + boost · m², where
/// m = (display − threshold) / (1 − threshold) in [0, 1] — a fully clipped pixel gets 1 + boost
/// times its energy back. With `restore`, the result is mapped back through the inverse of the
/// same curve (an output at the clip level returns to it; an HDR output stays scene-referred
/// without it).
struct HighlightRecovery {
  double threshold = 0.9;  ///< display value in [0, 1) above which a pixel counts as clipped
  double boost = 0.0;      ///< >= 0 and finite; 0 = off
  bool restore = false;    ///< map the result back through the inverse curve
  bool enabled() const noexcept { return boost > 0.0; }
};

/// Throws Error(usage) naming --highlight-threshold or --highlight-boost.
void validate(const HighlightRecovery& highlights);

}  // namespace dofkit
