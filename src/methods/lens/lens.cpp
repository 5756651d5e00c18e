// `lens`: see lens.hpp and docs/methods/lens.md.
#include "methods/lens/lens.hpp"

#include "core/coc_range.hpp"
#include "methods/method.hpp"

namespace dofkit::detail {

namespace {

void render_lens(const MethodContext& ctx, Image& out) {
  lens::LensOptions opt;
  opt.depth_softness = static_cast<float>(ctx.params.get_double("depth_softness", 0.05, 0.001, 1.0));
  opt.slice_px = static_cast<float>(ctx.params.get_double("slice_px", 1.0, 0.25, 64.0));
  opt.slice_rel = static_cast<float>(ctx.params.get_double("slice_rel", 0.15, 0.0, 4.0));
  opt.level_px = static_cast<float>(ctx.params.get_double("level_px", 4.0, 1.0, 1e6));
  opt.hidden = ctx.params.get_bool("hidden", true);
  opt.simd = ctx.params.get_choice("impl", "fast", {"fast", "plain"}) == "fast";
  const core::CocRange range = ctx.coc_range ? *ctx.coc_range : core::coc_range(ctx.coc);
  const lens::SlicePlan plan = lens::plan_slices(range.near_max, range.far_max, opt);
  Image cover;
  lens::render_plain(ctx.frame.color, ctx.frame.depth, ctx.coc, plan, opt, out,
                     ctx.debug.wants("coverage") ? &cover : nullptr);
  ctx.debug.offer("coverage", cover);
}

}  // namespace

const MethodDef& lens_method() {
  static const MethodDef def{
      "lens",
      "the reference's picture fast: depth slices of per-pixel discs scattered as row spans at reduced resolution "
      "for large blur, composited in depth order with the hidden-background estimate",
      {{"depth_softness", "0.05",
        "relative inverse-depth difference over which a source becomes 'in front' (0.001-1)"},
       {"slice_px", "1", "depth-slice spacing near focus, px of CoC (0.25-64)"},
       {"slice_rel", "0.15", "depth-slice spacing as a fraction of the CoC radius, beyond slice_px (0-4)"},
       {"level_px", "4",
        "a slice is scattered at 1/2^L resolution when its smallest radius is >= level_px * 2^L px (1-1e6; large = "
        "full resolution everywhere)"},
       {"hidden", "on", "hidden-background estimate behind blurred near objects: on/off"},
       {"impl", "fast", "fast (SIMD, tiled) or plain (the straightforward form, the test oracle)"}},
      {{"coverage", "R: front weight (sources in front of the pixel), G: back weight, B: uncovered share filled by the hidden-background estimate"}},
      render_lens};
  return def;
}

}  // namespace dofkit::detail
