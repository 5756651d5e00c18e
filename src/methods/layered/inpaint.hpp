// Push-pull (pyramid) inpainting of a layer's disoccluded pixels from the layer's own content.
#pragma once
#include <cstdint>
#include <vector>

#include "dofkit/image.hpp"

namespace dofkit::detail::layered {

/// Replaces the pixels of `layer` (premultiplied RGBA) where hole != 0 by a smooth
/// extrapolation of the known pixels (Gortler et al. 1996 push-pull): "pull" builds a
/// pyramid of weight-normalised 2×2 averages of the known pixels, "push" fills each level's
/// unknown part from the bilinearly upsampled coarser level. Known pixels include
/// transparent ones, so a filled pixel's alpha is the share of this layer's content around
/// the hole (a hole bordered by this layer on one side only is filled half-transparent and
/// lets the farther layers show). `opaque` = true un-premultiplies the fill to alpha 1
/// (used for the farthest layer, the backstop that keeps the result opaque).
/// `under` = true keeps what the layer already holds at a hole pixel (hidden fragments of
/// multi-layer input) in front of the fill: layer = layer over fill there.
void push_pull_fill(Image& layer, const std::vector<std::uint8_t>& hole, bool opaque, bool under = false);

}  // namespace dofkit::detail::layered
