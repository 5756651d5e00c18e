// `lens`: see lens.hpp and docs/methods/lens.md.
#include "methods/lens/lens.hpp"

#include <algorithm>
#include <cmath>

#include "core/coc_range.hpp"
#include "core/parallel.hpp"
#include "methods/method.hpp"

namespace dofkit::detail {

namespace {

void render_lens(const MethodContext& ctx, Image& out) {
  lens::LensOptions opt;
  opt.depth_softness = static_cast<float>(ctx.params.get_double("depth_softness", 0.05, 0.001, 1.0));
  opt.slice_px = static_cast<float>(ctx.params.get_double("slice_px", 1.0, 0.25, 64.0));
  opt.slice_rel = static_cast<float>(ctx.params.get_double("slice_rel", 0.15, 0.0, 4.0));
  opt.level_px = static_cast<float>(ctx.params.get_double("level_px", 3.0, 1.0, 1e6));
  opt.hidden = ctx.params.get_bool("hidden", true);
  opt.hidden_samples = ctx.params.get_int("hidden_samples", 64, 16, 64);
  opt.simd = ctx.params.get_choice("impl", "fast", {"fast", "plain"}) == "fast";
  core::CocRange range = ctx.coc_range ? *ctx.coc_range : core::coc_range(ctx.coc);
  lens::Sources src;
  std::vector<Image> layer_coc;
  const Frame& frame = ctx.frame;
  if (frame.has_layers()) {
    // Deep / multi-layer input: every fragment is a source, with the CoC of its own depth.
    layer_coc.resize(frame.layer_depth.size());
    for (std::size_t f = 0; f < frame.layer_depth.size(); ++f) {
      const Image& z = frame.layer_depth[f];
      layer_coc[f].resize(z.width(), z.height(), 1);
      core::parallel_for(z.height(), [&](int y0, int y1) {
        for (int y = y0; y < y1; ++y) ctx.coc_of.evaluate(z.row(0, y), layer_coc[f].row(0, y), z.width());
      });
      const core::CocRange r = core::coc_range(layer_coc[f]);
      range.near_max = std::max(range.near_max, r.near_max);
      range.far_max = std::max(range.far_max, r.far_max);
      src.colour.push_back(&frame.layer_color[f]);
      src.depth.push_back(&z);
      src.coc.push_back(&layer_coc[f]);
    }
  } else {
    src.colour.push_back(&frame.color);
    src.depth.push_back(&frame.depth);
    src.coc.push_back(&ctx.coc);
  }
  const lens::SlicePlan plan = lens::plan_slices(range.near_max, range.far_max, opt);
  Image cover;
  if (opt.simd)
    lens::render_fast(src, plan, opt, ctx.workspace, out, ctx.debug.wants("coverage") ? &cover : nullptr);
  else
    lens::render_plain(src, plan, opt, out, ctx.debug.wants("coverage") ? &cover : nullptr);
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
       {"level_px", "3",
        "a slice is scattered at 1/2^L resolution when its smallest radius is >= level_px * 2^L px (1-1e6; large = "
        "full resolution everywhere)"},
       {"hidden", "on", "hidden-background estimate behind blurred near objects: on/off"},
       {"hidden_samples", "64", "(experiment) 16 or 64"},
       {"impl", "fast", "fast (SIMD, tiled) or plain (the straightforward form, the test oracle)"}},
      {{"coverage", "R: front weight (sources in front of the pixel), G: back weight, B: uncovered share filled by the hidden-background estimate"}},
      render_lens};
  return def;
}

}  // namespace dofkit::detail
