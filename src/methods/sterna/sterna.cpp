// `sterna`: Sterna's gather-based bokeh depth of field (GPU Zen, 2017) with Sousa 2013's
// polygonal kernel and Karis 2013's firefly weighting — docs/methods/sterna.md.
//
// Data flow (one file per pass):
//   coc.cpp             P1   full-res near/far blend factors
//   downsample.cpp      P2   half-res colour, far-premultiplied colour, point-sampled CoC
//   near_coc_dilate.cpp P3-6 near CoC max ±r then box ±r (outward blur)
//   gather.cpp          P7   49-tap ring gather of the near and far fields (tiles early-out)
//   fill.cpp            P8   3×3 max fill
//   composite.cpp       P9   far (CoC-bilateral upsample) then near over the full-res colour
//   kernel.cpp               the ring pattern and the n-gon modifier
//
// Kernel size. Sterna's kernel has a fixed size: ring 3 at 6 half-res px = 12 full-res px
// times kernelScale; the CoC only decides how much of the blurred field is blended in. dofkit
// radii are given at the camera's reference width and scale with the rendered width, so a
// numeric kernel_scale means "ring radius 12·kernel_scale px at the reference width". The
// default kernel_scale=auto sizes the kernel to the camera instead: R = the largest far-field
// radius in the frame, or the largest near radius if nothing is behind focus (NearFarBlend:
// its max_radius_px at this width), kernelScale = R/12, and the
// blend factors become |r|/R (coc.cpp) — a pixel with the largest blur gets the full kernel,
// smaller blurs get a cross-fade (the technique's accepted artifact, §3.7).
//
// Deviations from the demo (§3.3 end): one 2×2 footprint for colour and CoC in the
// composite; near-CoC dilation radius scales with the kernel (6 at kernelScale 1).
#include <algorithm>
#include <cmath>
#include <optional>

#include "core/coc_range.hpp"
#include "dofkit/error.hpp"
#include "methods/method.hpp"
#include "methods/sterna/fast.hpp"
#include "methods/sterna/passes.hpp"
#include "render/sanitize.hpp"

namespace dofkit::detail {

namespace sterna {

namespace {

// Pixel radius (full res, this width) that a blend factor of 1 stands for, and the kernel
// scale that gives that ring radius: 12 full-res px per unit of kernel_scale.
void choose_kernel(const MethodContext& ctx, Settings& s) {
  const Params& p = ctx.params;
  const std::optional<double> ks_user = p.get_double_or_auto("kernel_scale");
  double radius_px;
  if (ks_user) {
    radius_px = 2.0 * kOuterRadius * *ks_user * ctx.coc_of.scale();
  } else if (const auto* nfb = std::get_if<NearFarBlend>(&ctx.camera.model)) {
    radius_px = nfb->max_radius_px * ctx.coc_of.scale();
    radius_px = std::min(radius_px, ctx.coc_of.max_coc_px());
  } else {
    // The far field usually covers most of the frame and is where the bokeh shows, so the
    // kernel takes the largest far radius; nearer pixels with larger radii saturate (near = 1)
    // and get this kernel too. Only a frame without far field sizes it by its near field.
    const core::CocRange range = ctx.coc_range ? *ctx.coc_range : core::coc_range(ctx.coc);
    const float far_max = range.far_max, near_max = range.near_max;
    radius_px = far_max > 0.5f ? far_max : near_max;
  }
  // A kernel below one full-res px would only resample; keep the ramp well defined.
  radius_px = std::max(radius_px, 1.0);
  s.blend_radius_px = static_cast<float>(radius_px);
  const double ks_base = radius_px / (2.0 * kOuterRadius);
  // Strength split of docs/methods/sterna.md: shrink the kernel down to ¼, then fade the blend.
  const double strength = p.get_double("strength");
  double ks_mul = strength, blend = 1.0;
  if (strength < 0.25) {
    ks_mul = 0.25;
    blend = 4.0 * strength;
  }
  s.kernel_scale = static_cast<float>(ks_base * ks_mul);
  s.composite_blend = static_cast<float>(blend);
  s.dilate_radius = std::max(1, static_cast<int>(std::lround(kOuterRadius * s.kernel_scale)));
}

}  // namespace

Settings read_settings(const MethodContext& ctx) {
  const Params& p = ctx.params;
  Settings s;
  choose_kernel(ctx, s);
  s.bicubic_near = p.get_choice("near_upsample") == "bicubic";
  s.per_pixel_scale = p.get_bool("per_pixel_scale");
  s.karis = p.get_choice("firefly") == "karis";
  BokehShape shape;
  shape.polygon = p.get_choice("bokeh") == "polygon";
  shape.blades = p.get_int("blades");
  shape.rotation_deg = p.get_double("rotation_deg");
  shape.anamorphic = p.get_double("anamorphic");
  // The shared aperture (RenderSettings::aperture) or sterna's own keys, not both. Its fixed
  // 49 taps take the shape (blades, rotation, curvature, anamorphic); an aperture image or the
  // cat's eye (per pixel) cannot be drawn by one tap set and is left out.
  static const core::ApertureModel circle;
  const core::ApertureModel& model = ctx.aperture ? *ctx.aperture : circle;
  const bool shared = !model.is_circle() && !model.has_image();
  if (shared && (p.has("bokeh") || p.has("blades") || p.has("rotation_deg") || p.has("anamorphic")))
    throw_usage(
        "sterna: give the aperture either with --blades/--blade-rotation/--anamorphic or with --set bokeh=polygon "
        "blades=... rotation_deg=... anamorphic=..., not both");
  if (shared) {
    ApertureShape plain = model.shape();
    plain.cat_eye = 0;
    s.offsets = make_offsets(core::ApertureModel(plain, 0, 0));
  } else {
    s.offsets = make_offsets(shape);
  }
  return s;
}

}  // namespace sterna

namespace {

using namespace sterna;

Image plane_copy(const Image& img, int c) {
  Image out(img.width(), img.height(), 1);
  std::copy(img.plane(c), img.plane(c) + img.plane_size(), out.plane(0));
  return out;
}

void render_sterna(const MethodContext& ctx, Image& out) {
  const Params& p = ctx.params;
  const Settings s = read_settings(ctx);
  const bool fast = p.get_choice("impl") == "fast";

  const bool want_view = ctx.debug.wants("near_coc") || ctx.debug.wants("far_coc") ||
                         ctx.debug.wants("near_coc_dilated") || ctx.debug.wants("near") || ctx.debug.wants("far") ||
                         ctx.debug.wants("near_fill") || ctx.debug.wants("far_fill");
  const bool strength_zero = s.composite_blend <= 0.0f && !want_view;
  // impl=fast (default) runs the optimised passes of fast_*.cpp, which give the same output
  // as the plain passes below (the oracle, impl=plain); settings they do not cover run plain.
  const bool fast_path = !strength_zero && fast && !want_view;
  // checks_colour: when render() leaves the sanitation check to us (ctx.colour_dirty), the
  // fast path makes it inside its downsample; every other path scans the colour first.
  if (ctx.colour_dirty && !fast_path && !color_is_sanitary(ctx.frame.color)) {
    ctx.colour_dirty->store(true);
    return;
  }
  if (strength_zero) {
    out = ctx.frame.color;  // strength 0: the input, exactly
    return;
  }
  if (fast_path) {
    sterna::fast::render(ctx, s, out);
    return;
  }
  FullCoc full;
  HalfRes h;
  compute_full_coc(ctx, s, full);
  ctx.debug.offer("near_coc", [&] { return plane_copy(full.coc, 0); });
  ctx.debug.offer("far_coc", [&] { return plane_copy(full.coc, 1); });
  downsample(ctx.frame.color, full, s, h);
  dilate_near_coc(s, h);
  ctx.debug.offer("near_coc_dilated", h.near_blur);
  gather(s, h);
  ctx.debug.offer("near", h.dof_near);
  ctx.debug.offer("far", h.dof_far);
  fill(s, h);
  ctx.debug.offer("near_fill", h.near_fill);
  ctx.debug.offer("far_fill", h.far_fill);
  composite(ctx.frame.color, full, s, h, out);
}

}  // namespace

const MethodDef& sterna_method() {
  static const MethodDef def{
      "sterna",
      "Sterna's gather-based bokeh: half-res 49-tap ring gather (circle or n-gon), separate near/far fields, "
      "max fill, CoC-bilateral composite",
      {
          float_param("strength", 1.0, 0.0, 1.0, "",
                      "effect strength: >= 0.25 scales the kernel, below fades the blend out (0 = input)"),
          float_or_auto_param("kernel_scale", 0.01, 50.0, "",
                              "auto (kernel radius = largest far CoC of the frame, else largest near CoC) or a "
                              "number: ring radius 12 px x this at the camera's reference width"),
          choice_param("near_upsample", "bilinear", {"bilinear", "bicubic"},
                       "near-field upsampling: bilinear or bicubic (cubic B-spline)"),
          bool_param("per_pixel_scale", false, "scale the far kernel by each pixel's far CoC (S2 §3.5)"),
          choice_param("bokeh", "circle", {"circle", "polygon"},
                       "kernel shape (sterna's own keys; the shared --blades, --blade-rotation, --blade-curvature, "
                       "--anamorphic flags work too, not both)"),
          int_param("blades", 6, 5, 9, "", "polygon sides (bokeh=polygon)"),
          float_param("rotation_deg", 0.0, -360.0, 360.0, "deg",
                      "polygon rotation, clockwise on screen; 0 = edge midpoint at +x"),
          float_param("anamorphic", 1.0, 0.5, 2.0, "", "bokeh width/height ratio (area preserving)"),
          choice_param("firefly", "off", {"off", "karis"},
                       "HDR firefly suppression in the downsample: off or karis (weights 1/(1+luma))"),
          choice_param("impl", "fast", {"fast", "plain"},
                       "fast (optimised passes; debug views use plain) or plain (the reference passes, the test "
                       "oracle); same output"),
      },
      {
          {"near_coc", "full-res near blend factor 0-1 (1 plane)"},
          {"far_coc", "full-res far blend factor 0-1 (1 plane)"},
          {"near_coc_dilated", "half-res near CoC after max + box (1 plane, W/2 x H/2)"},
          {"near", "half-res near field after the gather (RGBA, W/2 x H/2)"},
          {"far", "half-res far field after the gather (RGBA, W/2 x H/2)"},
          {"near_fill", "half-res near field after the 3x3 max fill (RGBA, W/2 x H/2)"},
          {"far_fill", "half-res far field after the 3x3 max fill (RGBA, W/2 x H/2)"},
      },
      render_sterna,
      /*checks_colour=*/true,
      /*aperture=*/
      "blades, rotation, curvature, anamorphic (its 49 taps moved onto the shape; not the cat's eye or an aperture "
      "image)"};
  return def;
}

}  // namespace dofkit::detail
