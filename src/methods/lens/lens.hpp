// `lens`: the reference's picture (energy-normalised per-pixel disc scatter, depth-ordered
// soft occlusion, hidden-background estimate) at a small fraction of its cost — see
// docs/methods/lens.md.
#pragma once
#include <vector>

#include "dofkit/image.hpp"
#include "methods/lens/common.hpp"
#include "methods/lens/plan.hpp"
#include "methods/method.hpp"

namespace dofkit::detail::lens {

/// The plain form: straightforward loops, the oracle of the fast path.
void render_plain(const Sources& src, const SlicePlan& plan, const LensOptions& opt, Image& out,
                  Image* cover = nullptr);

/// The fast form (lens_fast.cpp): the same model, equal to the plain form within float
/// rounding; buffers from `ws` (kept from frame to frame).
void render_fast(const Sources& src, const SlicePlan& plan, const LensOptions& opt, Workspace& ws, Image& out,
                 Image* cover = nullptr);

}  // namespace dofkit::detail::lens
