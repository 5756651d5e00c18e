// `reference`: the most accurate result one RGB-D layer allows — an energy-normalised,
// depth-ordered disc scatter (see disc_scatter.cpp). Slow by design; the oracle the fast
// methods are compared with.
#include "methods/method.hpp"
#include "methods/reference/disc_scatter.hpp"

namespace dofkit::detail {

const MethodDef& reference_method() {
  static const MethodDef def{
      "reference",
      "exact single-layer scatter: every pixel spreads its disc of confusion, composited in depth order",
      {depth_softness_param()},
      {},
      [](const MethodContext& ctx, Image& out) {
        DiscScatterOptions opt;
        opt.depth_order = true;
        opt.depth_softness = static_cast<float>(ctx.params.get_double("depth_softness"));
        opt.max_work = ctx.max_work;
        opt.aperture = ctx.aperture;
        opt.progress = ctx.progress;
        disc_scatter(ctx.frame.color, ctx.frame.depth, ctx.coc, opt, out);
      },
      /*checks_colour=*/false,
      "all: blades, rotation, curvature, anamorphic, cat's eye, aperture image"};
  return def;
}

}  // namespace dofkit::detail
