// `lens`: the reference's picture (energy-normalised per-pixel disc scatter, depth-ordered
// soft occlusion, hidden-background estimate) at a small fraction of its cost — see
// docs/methods/lens.md.
#pragma once
#include <vector>

#include "dofkit/image.hpp"
#include "methods/lens/common.hpp"
#include "methods/lens/plan.hpp"

namespace dofkit::detail::lens {

/// The sources: one fragment per pixel (an RGB-D frame) or several front to back (deep /
/// multi-layer input; a missing fragment has alpha 0). Layer 0 is the visible surface.
struct Sources {
  std::vector<const Image*> colour, depth, coc;  // rgba premultiplied, z, signed CoC px
  int count() const { return static_cast<int>(colour.size()); }
};

/// The plain form: straightforward loops, the oracle of the fast path.
void render_plain(const Sources& src, const SlicePlan& plan, const LensOptions& opt, Image& out,
                  Image* cover = nullptr);

}  // namespace dofkit::detail::lens
