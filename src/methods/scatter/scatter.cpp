// `scatter`: the depth-blind baseline — the same energy-normalised disc scatter as the
// reference, but every contribution is summed and normalised together, ignoring depth
// order (what common lens-blur filters do). Kept to show what depth ordering buys.
#include "methods/method.hpp"
#include "methods/reference/disc_scatter.hpp"

namespace dofkit::detail {

const MethodDef& scatter_method() {
  static const MethodDef def{
      "scatter",
      "baseline: normalised disc scatter that ignores depth order (like common lens-blur filters)",
      {},
      {},
      [](const MethodContext& ctx, Image& out) {
        DiscScatterOptions opt;
        opt.depth_order = false;
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
