// Highlight recovery (dofkit/aperture.hpp, HighlightRecovery): display-referred colour clips
// at 1, so a bright light keeps only the energy of a white pixel and blurs to a grey smudge.
// Before the blur, a pixel whose display value d = sRGB(max(R, G, B) / alpha) exceeds the
// threshold T gets its linear colour multiplied by g(d) = 1 + boost·m², m = (d − T)/(1 − T)
// clamped to [0, 1]; after it, `restore` maps each output pixel back through the inverse of
// v ↦ v·g(sRGB(v)) on its largest channel (monotonic, so the inverse is unique).
#pragma once
#include "dofkit/aperture.hpp"
#include "dofkit/image.hpp"

namespace dofkit::detail {

/// m² of one pixel (RGBA premultiplied) for threshold T; 0 below it. `linear_threshold` is
/// the linear value whose sRGB code is T (pixels below it are never boosted).
float highlight_mask(float r, float g, float b, float a, double threshold, float linear_threshold);

/// dst = src with every pixel boosted (dst may not alias src; resized to match). With `mask`
/// (resized to 1 plane), also writes m² per pixel (the `highlights` debug view).
void boost_highlights(const Image& src, const HighlightRecovery& h, Image& dst, Image* mask = nullptr);

/// In place: each pixel divided back by the gain of the boost curve at its own value.
void restore_highlights(Image& img, const HighlightRecovery& h);

}  // namespace dofkit::detail
