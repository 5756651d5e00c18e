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

/// The debug views (docs/methods/lens.md); null: not wanted.
struct Views {
  Image* coverage = nullptr;  ///< F weight, B weight, uncovered share that was filled
  Image* front = nullptr;     ///< what lies in front, composited over (rgba)
  Image* back = nullptr;      ///< the receiver's own surface and what lies behind, normalised (rgba)
  Image* estimate = nullptr;  ///< the hidden-background estimate where a receiver has one (rgba)
  Image* slices = nullptr;    ///< slice position (j + t) / (K − 1), level / max level, direct
  Image* direct = nullptr;    ///< direct sources: in focus / small radius, highlight
  Image* tiles = nullptr;     ///< per tile: slices read back, direct sources, estimates read
  bool any() const { return coverage || front || back || estimate || slices || direct || tiles; }
};

/// The plain form: straightforward loops, the oracle of the fast path. (Views: coverage only.)
void render_plain(const Sources& src, const SlicePlan& plan, const LensOptions& opt, Image& out,
                  Image* cover = nullptr);

/// The fast form (lens_fast.cpp): the same model, equal to the plain form within float
/// rounding; buffers from `ws` (kept from frame to frame).
void render_fast(const Sources& src, const SlicePlan& plan, const LensOptions& opt, Workspace& ws, Image& out,
                 const Views& views = {});

}  // namespace dofkit::detail::lens
