// `layered`: Schedl & Wimmer, "Simulating Partial Occlusion in Post-Processing Depth-of-Field
// Methods" (GPU Pro 4 ch. 2; docs/methods/layered.md). The fragments (one per pixel for an RGB-D
// frame, several front to back for deep / layered input) are matted into K layers at anchor
// CoCs; the layers are blurred with Gaussians recursively from the outermost layers toward
// the focus layer and composited front (F) over focus over back (B). Hidden fragments in the
// farther layers show through a blurred foreground: partial occlusion.
//
// Deviations from S4 and resolutions of its reconstructed parts (see docs/methods/layered.md):
//  * matting and anchors in signed-CoC space (anchors.hpp), which covers every CoC model;
//  * one matte family (anchors.cpp, LayerPlan::weight) instead of ω for visible and ω̂ for
//    hidden fragments: full weight in the farther of the two bracketing layers and a ramp in
//    the nearer one, so an unblurred stack reproduces the input and the blur is interpolated
//    linearly between anchors;
//  * single RGB-D input: each layer's disoccluded pixels (those covered by nearer layers) are
//    filled by push-pull inpainting from the layer's own content (inpaint.hpp); the farthest
//    layer is filled opaque so the result never turns transparent or black;
//  * step sizes are scaled per side so the outermost anchor sits on the scene's extreme CoC;
//  * psf=disc (the default for multi-layer input): each layer is blurred once by the disc of
//    its anchor radius (disc_blur.hpp) and composited with "over", and the matte ramp between
//    two anchors is narrowed to a quarter of the gap (LayerPlan::band) so that thin near
//    objects are not counted twice — measured against the ground truth, this is what makes
//    multi-layer input beat the reference at edges.
// Memory: the current layer, F, B and the focus layer (4 RGBA frames) whatever K is (the
// disc adds one plane of double prefix sums).
#include <cmath>
#include <string>

#include "core/filters.hpp"
#include "core/parallel.hpp"
#include "core/pass_profile.hpp"
#include "methods/layered/anchors.hpp"
#include "methods/layered/composite.hpp"
#include "methods/layered/disc_blur.hpp"
#include "methods/layered/fast.hpp"
#include "methods/layered/inpaint.hpp"
#include "methods/layered/matting.hpp"
#include "methods/method.hpp"

namespace dofkit::detail {

namespace {

constexpr int kMaxLayers = 16;

std::size_t plane_bytes(int w, int h) { return static_cast<std::size_t>(w) * static_cast<std::size_t>(h); }

std::vector<DebugViewInfo> debug_views() {
  std::vector<DebugViewInfo> v;
  for (int k = 0; k < kMaxLayers; ++k) {
    v.push_back({"layer_" + std::to_string(k) + "_matted",
                 "layer k (0 = nearest) after matting (and hole filling for single-layer input), RGBA premultiplied"});
    v.push_back({"layer_" + std::to_string(k) + "_blurred",
                 "layer k alone blurred by its effective sigma (what it contributes to the stack)"});
  }
  v.push_back({"front", "front accumulator F: the near layers composited and recursively blurred"});
  v.push_back({"back", "back accumulator B: the far layers composited and recursively blurred"});
  return v;
}

void render_layered(const MethodContext& ctx, Image& out) {
  using namespace layered;
  const int cap = ctx.params.get_int("layers");
  const double c = ctx.params.get_double("sigma_per_radius");
  const double unit = ctx.params.get_double("step_px");
  const bool half_res = ctx.params.get_bool("half_res");
  const bool quarter_res = half_res && ctx.params.get_bool("quarter_res");
  const std::string fill = ctx.params.get_choice("fill");
  const std::string psf = ctx.params.get_choice("psf");
  // fast: the same arithmetic as plain in the same order (bit-identical, tests/layered/
  // fast_test.cpp) with fused passes and workspace buffers (fast.hpp); plain is the oracle.
  const bool fast = ctx.params.get_choice("impl") == "fast";
  const Frame& frame = ctx.frame;
  const bool multi = frame.has_layers();
  // auto: the disc for multi-layer input (it beats every single-layer method there, see
  // docs/methods/layered.md), the O(1)-per-pixel recursive Gaussian for one RGB-D frame.
  const bool disc = psf == "disc" || (psf == "auto" && multi);
  // auto: push-pull for every input. A hole is a pixel whose fragments all lie in front of the
  // layer (matting.cpp): nothing there is known, so for multi-layer input too it is filled
  // rather than left transparent (a deep file holds hidden fragments only where something hid
  // them; left transparent, the holes behind an in-focus subject blurred into a halo around it).
  const bool fill_under = fill == "under";
  const bool do_fill = fill != "off";

  Fragments frags;
  std::vector<Image> owned_coc;
  if (multi) {
    owned_coc.resize(frame.layer_depth.size());
    for (std::size_t i = 0; i < frame.layer_depth.size(); ++i) {
      const Image& z = frame.layer_depth[i];
      Image& r = owned_coc[i];
      r.resize(z.width(), z.height(), 1);
      core::parallel_for(
          z.height(),
          [&](int y0, int y1) {
            for (int y = y0; y < y1; ++y)
              for (int x = 0; x < z.width(); ++x) r.row(0, y)[x] = ctx.coc_of(z.row(0, y)[x]);
          },
          8);
    }
    for (std::size_t i = 0; i < frame.layer_color.size(); ++i) {
      frags.color.push_back(&frame.layer_color[i]);
      frags.coc.push_back(&owned_coc[i]);
    }
  } else {
    frags.color.push_back(&frame.color);
    frags.coc.push_back(&ctx.coc);
  }

  double near_px, far_px;
  // The first pass over the fragments, and one that reads every alpha anyway: it also makes
  // render()'s colour check when render() left it to us (ctx.colour_dirty; single RGB-D
  // frames), before anything at all is derived from the colour (the plan's extremes count
  // only fragments with alpha > 0). On failure render() renders again from a sanitised copy.
  bool clean;
  {
    core::PassScope pass("colour check + coc extremes");
    clean = coc_extremes(frags, near_px, far_px, ctx.colour_dirty != nullptr);
  }
  if (!clean) {
    ctx.colour_dirty->store(true);
    return;
  }
  LayerPlan plan = plan_layers(near_px, far_px, cap, c, unit);
  // Matte ramp: S&W's full-gap ramp for the Gaussian; a quarter of the gap for the disc
  // (measured, docs/methods/layered.md: 0 leaves seams on continuous surfaces, wider bands
  // count thin near objects up to 1 + u times).
  plan.band = ctx.params.get_double("matte_band", disc ? "disc" : "gaussian");

  // The fused Gaussian stack (one fragment per pixel, no debug view): no layer is stored.
  if (fast && !disc) {
    core::PassScope pass("fused stack");
    if (render_gaussian_fused(ctx, frags, plan, half_res, quarter_res, do_fill, fill_under, out)) return;
  }
  core::PassScope pass("layer by layer");

  const int w = frame.width(), h = frame.height();
  Image plain_layer, plain_focus;
  std::vector<std::uint8_t> plain_hole;
  Image& layer = fast ? ctx.workspace.image("layered.layer", w, h, 4) : plain_layer;
  Image& focus_layer = fast ? ctx.workspace.image("layered.focus", w, h, 4) : plain_focus;
  // The fast hole mask: w·h bytes.
  std::uint8_t* fast_hole =
      fast && do_fill ? ctx.workspace.plane<std::uint8_t>("layered.hole", plane_bytes(w, h)) : nullptr;
  auto offer_layer = [&](int k, const Image& img) {
    const std::string m = "layer_" + std::to_string(k) + "_matted";
    const std::string b = "layer_" + std::to_string(k) + "_blurred";
    ctx.debug.offer(m.c_str(), img);
    ctx.debug.offer(b.c_str(), std::function<Image()>([&] {
                      Image copy = img;
                      if (disc)
                        disc_blur(copy, plan.anchor[k], ctx.aperture);
                      else
                        core::gaussian_blur(copy, static_cast<float>(plan.total_sigma[k]));
                      return copy;
                    }));
  };
  // Mattes layer k into `dst` and fills its disocclusions; returns false if it is empty.
  auto make_layer = [&](int k, Image& dst, bool opaque_fill) {
    if (fast) {
      const MatteStats s = matte_layer_fast(frags, plan, k, dst, fast_hole);
      if (do_fill && !s.empty && s.holes) push_pull_fill_fast(dst, fast_hole, opaque_fill, fill_under, ctx.workspace);
      offer_layer(k, dst);
      return !s.empty;
    }
    const MatteStats s = matte_layer(frags, plan, k, dst, do_fill ? &plain_hole : nullptr);
    if (do_fill && !s.empty && s.holes) push_pull_fill(dst, plain_hole, opaque_fill, fill_under);
    offer_layer(k, dst);
    return !s.empty;
  };

  // The stack, for either accumulator type (plain Accumulator or FastAccumulator).
  auto run_stack = [&](auto& back, auto& front) {
    bool focus_full;
    if (!disc) {
      // Back: B = H(σ_{K−1}) L_{K−1}; B = H(σ_k)(L_k over B) for k = K−2 … k_focus+1.
      for (int k = plan.count - 1; k > plan.focus; --k) {
        if (make_layer(k, layer, !back.has_content())) back.composite_front(layer);
        back.blur(plan.step_sigma[k]);
      }
      // Focus layer, unblurred; the opaque backstop if nothing lies behind it.
      focus_full = make_layer(plan.focus, focus_layer, !back.has_content());
      // Front: F = H(σ_0) L_0; F = H(σ_k)(F over L_k) for k = 1 … k_focus−1.
      for (int k = 0; k < plan.focus; ++k) {
        if (make_layer(k, layer, false)) front.composite_back(layer);
        front.blur(plan.step_sigma[k]);
      }
    } else {
      // psf=disc, the non-recursive form: every layer is blurred once, by the disc of its own
      // anchor radius |a_k| (a disc blurred by a disc is no disc, so there is no semigroup to
      // recurse with), and composited with "over": B = D_{K−1} L_{K−1}, B = D_k L_k over B;
      // F = D_0 L_0, F = F over D_k L_k. A fragment between two anchors is still split by the
      // matte (u in the nearer layer over 1 in the farther), so its blur is the u-weighted
      // mix of the two discs.
      for (int k = plan.count - 1; k > plan.focus; --k) {
        if (!make_layer(k, layer, !back.has_content())) continue;
        disc_blur(layer, plan.anchor[k], ctx.aperture);
        back.composite_front(layer);
      }
      focus_full = make_layer(plan.focus, focus_layer, !back.has_content());
      for (int k = 0; k < plan.focus; ++k) {
        if (!make_layer(k, layer, false)) continue;
        disc_blur(layer, plan.anchor[k], ctx.aperture);
        front.composite_back(layer);
      }
    }
    return focus_full;
  };

  // Views of layers the plan does not use (k >= K) and of empty accumulators are transparent.
  const std::function<Image()> transparent = [&] { return Image(w, h, 4, 0.0f); };
  auto offer_rest = [&](auto& back, auto& front) {
    for (int k = plan.count; k < kMaxLayers; ++k) {
      ctx.debug.offer(("layer_" + std::to_string(k) + "_matted").c_str(), transparent);
      ctx.debug.offer(("layer_" + std::to_string(k) + "_blurred").c_str(), transparent);
    }
    if (!back.has_content()) ctx.debug.offer("back", transparent);
    if (!front.has_content()) ctx.debug.offer("front", transparent);
  };

  if (fast) {
    FastAccumulator back(ctx.workspace, "layered.back", half_res, quarter_res),
        front(ctx.workspace, "layered.front", half_res, quarter_res);
    const bool focus_full = run_stack(back, front);
    offer_rest(back, front);
    if (back.has_content() && ctx.debug.wants("back")) ctx.debug.offer("back", back.resolved());
    if (front.has_content() && ctx.debug.wants("front")) ctx.debug.offer("front", front.resolved());
    // I = F over L_focus over B (S4 Eq. 2.7), one pass.
    final_composite(front, focus_full ? &focus_layer : nullptr, back, w, h, out);
    return;
  }

  Accumulator back(half_res, quarter_res), front(half_res, quarter_res);
  const bool focus_full = run_stack(back, front);
  offer_rest(back, front);

  // I = F over L_focus over B (S4 Eq. 2.7).
  if (focus_full)
    out = focus_layer;
  else
    out = Image(w, h, 4, 0.0f);
  if (back.has_content()) {
    const Image& b = back.resolved();
    ctx.debug.offer("back", b);
    over(out, b, out);
  }
  if (front.has_content()) {
    const Image& f = front.resolved();
    ctx.debug.offer("front", f);
    over(f, out, out);
  }
}

}  // namespace

const MethodDef& layered_method() {
  static const MethodDef def{
      "layered",
      "Schedl & Wimmer layered DoF: depth layers blurred recursively and composited; partial occlusion from "
      "deep/multi-layer input",
      {int_param("layers", 9, 3, kMaxLayers, "",
                 "maximum number of depth layers K; fewer are used when the CoC range needs fewer"),
       float_param("sigma_per_radius", 0.6, 0.1, 2.0, "",
                   "Gaussian sigma per px of CoC radius; S4 d_pix = 4 sigma gives 0.5, 0.6 measured best against the "
                   "ground truth"),
       float_param("step_px", 1.0, 0.1, 8.0, "px",
                   "unit of the per-step sigma sigma_k = unit * |k - k_focus| before fitting the scene's CoC range; "
                   "smaller = more, finer layers"),
       bool_param("half_res", true,
                  "blur steps of sigma >= 4 px at half resolution (same variance, about 4x less blur work)"),
       bool_param("quarter_res", true,
                  "with half_res, blur steps of sigma >= 8 px at quarter resolution (same variance, 4x less blur "
                  "work again)"),
       choice_param("fill", "auto", {"auto", "on", "off", "under"},
                    "inpaint disoccluded layer pixels by push-pull: auto (single-layer input only), on, off, under "
                    "(the fill goes behind what the layer holds there: hidden fragments of multi-layer input stay in "
                    "front)"),
       choice_param("psf", "auto", {"auto", "gaussian", "disc"},
                    "layer blur: auto (disc for multi-layer input, gaussian for one RGB-D frame), gaussian (S&W's "
                    "recursive Gaussians, O(1) per pixel) or disc (each layer blurred once by the anti-aliased disc "
                    "of its anchor CoC radius and composited with over, O(R) per pixel)"),
       choice_param("impl", "fast", {"fast", "plain"},
                    "fast (fused passes, workspace buffers; same arithmetic) or plain (the straightforward form, the "
                    "test oracle)"),
       float_param("matte_band", param_by("psf", {{"gaussian", 1.0}, {"disc", 0.25}}), 0.0, 1.0, "",
                   "width of the matte ramp between two anchors as a fraction of the gap: 1 = S&W (u in the nearer "
                   "layer over 1 in the farther, blur interpolated), 0 = each fragment wholly in its nearest "
                   "anchor's layer (counted once); the default follows the psf in use")},
      debug_views(),
      render_layered,
      /*checks_colour=*/true,
      /*aperture=*/
      "psf=disc: blades, rotation, curvature, anamorphic, aperture image (not the cat's eye: one kernel per layer)"};
  return def;
}

}  // namespace dofkit::detail
