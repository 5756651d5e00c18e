// `starcraft`: StarCraft II depth of field (Filion & McNaughton 2008; docs/methods/starcraft.md).
// Pass order: C1 levels → C2 medium → C3 large + blurred CoC → C4 blurred depth → C5 final.
// See starcraft.hpp for the rules and the deviations, docs/methods/starcraft.md for the
// parameters' measured effect.
#include <cmath>
#include <limits>

#include "core/pass_profile.hpp"
#include "methods/method.hpp"
#include "methods/starcraft/starcraft.hpp"

namespace dofkit::detail {

starcraft::Settings starcraft::read_settings(const MethodContext& ctx) {
  Settings s;
  s.large_radius_px = ctx.params.get_double("large_radius_px");
  s.medium_fraction = ctx.params.get_double("medium_fraction");
  s.sigma_per_radius = ctx.params.get_double("sigma_per_radius");
  s.depth_blur = ctx.params.get_double("depth_blur");
  s.medium_boxes = ctx.params.get_int("medium_boxes");
  s.keep_own_blur = ctx.params.get_bool("keep_own_blur");
  s.coc_reduce_max = ctx.params.get_choice("coc_reduce") == "max";
  s.plain = ctx.params.get_choice("impl") == "plain";
  return s;
}

namespace {

using namespace starcraft;

Image quarter_plane(const Image& src, int plane) {
  Image out(src.width(), src.height(), 1);
  std::copy(src.plane(plane), src.plane(plane) + src.plane_size(), out.plane(0));
  return out;
}

void render_starcraft(const MethodContext& ctx, Image& out) {
  const Settings s = read_settings(ctx);

  const LevelGeometry g = make_geometry(ctx, s);
  const Image& color = ctx.frame.color;

  const int w = ctx.frame.width(), h = ctx.frame.height();
  const int lw = down_size(w), lh = down_size(h);
  // Intermediate buffers live in the renderer's workspace: no allocation per frame.
  Image& level = ctx.workspace.image("starcraft.level", w, h, 1);
  {
    core::PassScope pass("levels");
    compute_levels(ctx, g, level, s.plain);
  }
  ctx.debug.offer("coc", level);

  Image& large = ctx.workspace.image("starcraft.large", lw, lh, 5);
  bool opaque = false;  // every alpha exactly 1 (found by the large level's reduction)
  // The large level's reduction is the first pass that reads the colour, and it reads every
  // sample once: it also makes render()'s sanitation check when render() left it to us.
  bool clean;
  {
    core::PassScope pass("large level");
    clean =
        large_blur(color, level, g.sigma_large, s.coc_reduce_max, large, s.plain, &opaque, ctx.colour_dirty != nullptr);
  }
  if (!clean) {
    ctx.colour_dirty->store(true);
    return;
  }
  ctx.debug.offer("blurred_coc", [&] { return quarter_plane(large, 4); });
  ctx.debug.offer("large", [&] {
    Image img(large.width(), large.height(), 4);
    for (std::size_t i = 0; i < large.plane_size(); ++i) {
      const float den = large.plane(4)[i];
      for (int ch = 0; ch < 4; ++ch) img.plane(ch)[i] = den > 1e-6f ? large.plane(ch)[i] / den : 0.0f;
    }
    return img;
  });

  Image& inv_depth = ctx.workspace.image("starcraft.inv_depth", lw, lh, 1);
  {
    core::PassScope pass("depth blur");
    depth_blur(ctx.frame.depth, g.sigma_depth, inv_depth, s.plain);
  }
  ctx.debug.offer("blurred_depth", [&] {
    Image img(inv_depth.width(), inv_depth.height(), 1);
    for (std::size_t i = 0; i < img.plane_size(); ++i) {
      const float v = inv_depth.plane(0)[i];
      img.plane(0)[i] = v > 0 ? 1.0f / v : std::numeric_limits<float>::infinity();
    }
    return img;
  });

  // Fast form without intermediate debug views: the medium level is streamed straight into
  // the final pass (no full-resolution medium planes).
  const bool fused = !s.plain && !ctx.debug.wants("medium") && !ctx.debug.wants("used_coc") &&
                     !ctx.debug.wants("small") && !ctx.debug.wants("weights");
  if (fused) {
    core::PassScope pass("medium + final");
    medium_and_final(color, ctx.frame.depth, level, g.sigma_medium, s.medium_boxes, opaque, large, inv_depth,
                     s.keep_own_blur, out);
    return;
  }
  Image& medium = ctx.workspace.image("starcraft.medium", w, h, 4);
  Image& medium_weight = ctx.workspace.image("starcraft.medium_weight", w, h, 1);
  {
    core::PassScope pass("medium level");
    medium_blur(color, level, g.sigma_medium, s.medium_boxes, medium, medium_weight, s.plain, &large);
  }
  ctx.debug.offer("medium", medium);

  Image used, small, weights;
  FinalDebug dbg;
  if (ctx.debug.wants("used_coc")) dbg.used_level = &used;
  if (ctx.debug.wants("small")) dbg.small = &small;
  if (ctx.debug.wants("weights")) dbg.weights = &weights;
  core::PassScope pass("final");
  if (s.plain)
    final_pass_plain(color, ctx.frame.depth, level, medium, large, inv_depth, s.keep_own_blur, out, dbg);
  else
    final_pass(color, ctx.frame.depth, level, medium, large, inv_depth, s.keep_own_blur, out, dbg);
  if (dbg.used_level) ctx.debug.offer("used_coc", used);
  if (dbg.small) ctx.debug.offer("small", small);
  if (dbg.weights) ctx.debug.offer("weights", weights);
}

}  // namespace

const MethodDef& starcraft_method() {
  const starcraft::Settings d;  // the defaults (starcraft.hpp)
  static const MethodDef def{
      "starcraft",
      "StarCraft II (2008): sharp/small/medium/large blur levels mixed by CoC, CoC-weighted blurs, "
      "blurred CoC, blurred-depth ordering",
      {
          float_param("large_radius_px", d.large_radius_px, 0.0, 4096.0, "px",
                      "disc radius (px at the camera's reference width) the large level stands for; 0 = auto: the "
                      "camera's characteristic radius (thin lens: K, the blur at infinity; artist models: their "
                      "maximum radius; StarCraft: max_radius_px). Radii beyond it saturate at the large level"),
          float_param("medium_fraction", d.medium_fraction, 0.05, 0.95, "",
                      "radius of the medium level as a fraction of the large level's"),
          float_param("sigma_per_radius", d.sigma_per_radius, 0.1, 2.0, "",
                      "Gaussian sigma per disc radius for the medium and large levels; 0.5 would match the disc's "
                      "variance, 0.6 measured best against the ground truth"),
          int_param("medium_boxes", d.medium_boxes, 1, 3, "",
                    "box passes per axis of the medium level's Gaussian (the variance is the same for any count): "
                    "2 measured as good as 3 against the ground truth (mean PSNR 29.86 vs 29.85 dB, SSIM 0.902 vs "
                    "0.901 over the built-in scenes at 320x180) at two thirds of the medium level's blur cost; 1 is "
                    "a plain box"),
          float_param("depth_blur", d.depth_blur, 0.1, 4.0, "",
                      "sigma of the depth blur of the ordering test relative to the CoC blur"),
          bool_param("keep_own_blur", d.keep_own_blur,
                     "on: a pixel is never sharper than its own CoC (max of own and blurred level); off: the "
                     "chapter's rule (blurred level when the neighbourhood is in front)"),
          choice_param("coc_reduce", d.coc_reduce_max ? "max" : "mean", {"mean", "max"},
                       "how a 4x4 block's CoC is reduced to the quarter-res map"),
          choice_param("impl", d.plain ? "plain" : "fast", {"fast", "plain"},
                       "fast: SIMD/cache-blocked passes; plain: the straightforward passes (double-sum Gaussians, "
                       "per-pixel final pass), kept as the test oracle of the fast form (equal within 1e-4)"),
      },
      {
          {"coc", "blur level c in [0,1] per pixel (full resolution)"},
          {"blurred_coc", "blurred level map, W/4 x H/4 (rule 2)"},
          {"blurred_depth", "blurred depth z of the ordering test, W/4 x H/4 (blurred as 1/z)"},
          {"used_coc", "level after the depth test, the one that selects the weights (full resolution)"},
          {"small", "small level: 17-tap pinwheel incl. the centre (RGBA)"},
          {"medium", "medium level: CoC-weighted full-resolution Gaussian (RGBA)"},
          {"large", "large level: CoC-weighted Gaussian, W/4 x H/4 (RGBA, normalised)"},
          {"weights", "level weights: planes source, small, medium, large (sum 1)"},
      },
      render_starcraft,
      /*checks_colour=*/true,
      /*aperture=*/""};
  return def;
}

}  // namespace dofkit::detail
