// `lens`: see lens.hpp and docs/methods/lens.md.
#include "methods/lens/lens.hpp"

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <utility>

#include "core/coc_range.hpp"
#include "core/parallel.hpp"
#include "methods/method.hpp"

namespace dofkit::detail {

namespace {

void render_lens(const MethodContext& ctx, Image& out) {
  lens::LensOptions opt;
  opt.depth_softness = static_cast<float>(ctx.params.get_double("depth_softness"));
  opt.slice_px = static_cast<float>(ctx.params.get_double("slice_px"));
  opt.slice_rel = static_cast<float>(ctx.params.get_double("slice_rel"));
  opt.level_px = static_cast<float>(ctx.params.get_double("level_px"));
  opt.hidden = ctx.params.get_bool("hidden");
  opt.highlight_abs = static_cast<float>(ctx.params.get_double("highlight_abs"));
  opt.highlight_rel = static_cast<float>(ctx.params.get_double("highlight_rel"));
  opt.simd = ctx.params.get_choice("impl") == "fast";
  opt.progress = ctx.progress;
  opt.shape = lens::Shape(ctx.aperture);  // usage error for the cat's eye or an aperture image
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
  // Debug views come from the fast form (with impl=plain it runs once more for them).
  Image view;
  lens::Views views;
  for (const auto& [name, slot] :
       std::initializer_list<std::pair<const char*, Image * lens::Views::*>>{{"coverage", &lens::Views::coverage},
                                                                             {"front", &lens::Views::front},
                                                                             {"back", &lens::Views::back},
                                                                             {"estimate", &lens::Views::estimate},
                                                                             {"slices", &lens::Views::slices},
                                                                             {"direct", &lens::Views::direct},
                                                                             {"tiles", &lens::Views::tiles}})
    if (ctx.debug.wants(name)) views.*slot = &view;
  if (opt.simd) {
    lens::render_fast(src, plan, opt, ctx.workspace, out, views);
  } else {
    lens::render_plain(src, plan, opt, out);
    if (views.any()) {
      Image scratch;
      lens::render_fast(src, plan, opt, ctx.workspace, scratch, views);
    }
  }
  for (const char* name : {"coverage", "front", "back", "estimate", "slices", "direct", "tiles"})
    ctx.debug.offer(name, view);
}

}  // namespace

const MethodDef& lens_method() {
  static const MethodDef def{
      "lens",
      "the reference's picture fast: depth slices of per-pixel discs scattered as row spans at reduced resolution "
      "for large blur, composited in depth order with the hidden-background estimate",
      {depth_softness_param(),
       float_param("slice_px", 1.0, 0.25, 64.0, "px", "depth-slice spacing near focus, px of CoC"),
       float_param("slice_rel", 0.15, 0.0, 4.0, "",
                   "depth-slice spacing as a fraction of the CoC radius, beyond slice_px"),
       float_param("level_px", 3.0, 1.0, 1e6, "px",
                   "a slice is scattered at 1/2^L resolution when its smallest radius is >= level_px * 2^L px "
                   "(large = full resolution everywhere)"),
       float_param("highlight_abs", 1.0, 0.0, 1e30, "",
                   "a source brighter than this luminance (linear) and than highlight_rel times its neighbourhood "
                   "is scattered at full resolution"),
       float_param("highlight_rel", 4.0, 1.0, 1e30, "",
                   "see highlight_abs: times the mean luminance of the area its footprint covers"),
       bool_param("hidden", true, "hidden-background estimate behind blurred near objects"),
       choice_param("impl", "fast", {"fast", "plain"},
                    "fast (SIMD, tiled) or plain (the straightforward form, the test oracle)")},
      {{"coverage",
        "R: weight of the sources in front of each pixel (F), G: of its own surface and behind (B), B: the uncovered "
        "share filled by hidden fragments or the hidden-background estimate"},
       {"front", "F: what lies in front of each pixel, composited over it (premultiplied RGBA)"},
       {"back", "the pixel's own surface and what lies behind it, normalised, with the fill (premultiplied RGBA)"},
       {"estimate", "the hidden-background estimate where a pixel has one (premultiplied RGBA; 0 elsewhere)"},
       {"slices",
        "R: the pixel's depth slice (j + t) / (K - 1), near = 0; G: the slice's resolution level / the coarsest; "
        "B: 1 where the pixel is scattered directly at full resolution"},
       {"direct", "R: sources scattered directly for their small radius (in focus included), G: highlights"},
       {"tiles",
        "per tile of 256x16 px: R = slices read back / K, G = 1 if any direct source with a footprint reaches it, B = "
        "estimates read / K"}},
      render_lens,
      /*checks_colour=*/false,
      /*aperture=*/
      "blades, rotation, curvature, anamorphic (not the cat's eye or an aperture image: those go to reference)"};
  return def;
}

}  // namespace dofkit::detail
