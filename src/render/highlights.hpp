// Highlight recovery (dofkit/aperture.hpp, HighlightRecovery): display-referred colour clips
// at 1, so a bright light keeps only the energy of a white pixel and blurs to a grey smudge.
// Before the blur, a pixel whose display value d = sRGB(max(R, G, B) / alpha) exceeds the
// threshold T gets its linear colour multiplied by 1 + boost·m²·w, m = (d − T)/(1 − T) clamped
// to [0, 1], where w weighs the 8-connected region of such pixels it belongs to: min(1, A0/area)
// (A0 = 0.02 % of the frame, at least 16 px: lights are small, a bright wall is not) times the
// region's contrast to its surround, clamp((0.5 − r)/0.3, 0, 1) with r the mean display value of
// the pixels around it (a light stands out of a darker surround, a speck on a bright surface
// does not). After the blur, `restore` maps each output pixel back through the inverse of
// v ↦ v·(1 + boost·m(v)²) on its largest channel (monotonic, so the inverse is unique; the
// region weights are not known any more, so the inverse is that of a full-weight pixel).
#pragma once
#include "dofkit/aperture.hpp"
#include "dofkit/image.hpp"

namespace dofkit::detail {

/// m² of one pixel (RGBA premultiplied) for threshold T; 0 below it. `linear_threshold` is
/// the linear value whose sRGB code is T (pixels below it are never boosted).
float highlight_mask(float r, float g, float b, float a, double threshold, float linear_threshold);

/// dst = src with every pixel boosted (dst may not alias src; resized to match). With `mask`
/// (resized to 1 plane), also writes m²·w per pixel (the `highlights` debug view). The same
/// result for any thread count (the regions are found in a fixed scan order).
void boost_highlights(const Image& src, const HighlightRecovery& h, Image& dst, Image* mask = nullptr);

/// In place: each pixel divided back by the gain of the boost curve at its own value.
void restore_highlights(Image& img, const HighlightRecovery& h);

}  // namespace dofkit::detail
