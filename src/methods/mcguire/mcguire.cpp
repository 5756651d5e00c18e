// `mcguire`: Bukowski, Hennessy, Osman & McGuire, "The Skylanders SWAP Force Depth-of-Field
// Shader" (GPU Pro 4), its 2013 web demo (VVDoF) and the G3D 10 version — docs/methods/mcguire.md.
//
// Three full-screen passes, two at reduced resolution: P1 packs colour and normalised
// signed CoC (coc_pack.cpp); P2/P3 blur horizontally then vertically, each producing a
// depth-ordered far/focus blur and a premultiplied near-field layer (blur.cpp); P4 lerps
// sharp ↔ blurry by |CoC| and lays the near field over it (composite.cpp).
//
// Deviations from the GPU sources (all documented in docs/methods/mcguire.md):
// * float buffers (no 8-bit CoC quantisation); colour is RGBA premultiplied, alpha is
//   blurred like a colour channel;
// * R_near / R_far come from the frame's CoC map (the largest near / far radius present)
//   unless near_radius_px is given, so any CoC model drives it;
// * |r| <= focus_px packs as exactly sharp (focus-field identity);
// * low-res buffers are sampled where their point-decimated texels really are;
// * guard band: taps may read into it; its output pixels are transparent black.
#include <algorithm>
#include <cmath>

#include "core/coc_range.hpp"
#include "core/pass_profile.hpp"
#include "methods/mcguire/fast.hpp"
#include "methods/mcguire/mcguire.hpp"
#include "methods/method.hpp"
#include "render/sanitize.hpp"

namespace dofkit::detail {

namespace mcguire {

Setup read_setup(const MethodContext& ctx, float max_near, float max_far) {
  const Params& p = ctx.params;
  Setup st;
  Constants& k = st.k;
  const std::string v = p.get_choice("variant");
  k.variant = v == "book" ? Variant::book : v == "demo" ? Variant::demo : Variant::g3d;
  const bool demo = k.variant == Variant::demo;
  k.f = p.get_int("reduction", v);
  // coverage_boost: 1.5 is the chapter's and the 2013 demo's value (book keeps it). The demo
  // default is 1: the box-blurred coverage of an opaque near object is already 0.5 on its
  // silhouette, as a thin lens gives it, and any gain > 1 moves the 50 % point outward and
  // makes the blurred rim opaque where the true image shows the background through it.
  // Measured on all six scenes (docs/methods/mcguire.md): 1 is best or equal on every one.
  k.coverage_boost = static_cast<float>(p.get_double("coverage_boost", v));
  k.far_occlusion = p.get_bool("far_occlusion_test", v);
  k.double_coc = p.get_bool("double_coc", v);  // demo: measured +0.8 dB mean on the six scenes (docs)
  k.near_alpha_code = p.get_choice("near_alpha") == "code";
  k.lowres_offset_fix = p.get_bool("lowres_offset_fix");
  k.focus_px = static_cast<float>(p.get_double("focus_px"));
  k.g3d_fov_rad = static_cast<float>(p.get_double("g3d_fov_deg") * M_PI / 180.0);
  const bool far_rescale = p.get_bool("far_rescale", v);
  st.guard = p.get_int("guard_band_px");
  st.guard_taps = p.get_bool("guard_band_taps");
  const double near_param = p.get_double("near_radius_px");

  // Radii (image px). R_n: the near blur radius — given, or the largest near radius in the
  // frame. R_f: the largest far radius in the frame. R_max bounds every tap loop and
  // normalises s, so it must cover the whole CoC map as well as R_n.
  const float r_n = near_param > 0 ? static_cast<float>(near_param) : max_near;
  const float r_f = max_far;
  k.r_max = static_cast<int>(std::ceil(std::max({r_n, max_near, max_far})));
  // Which pixels count as blurred at all: with focus_px the packed |s| is 0 below it.
  if (std::max(max_near, max_far) <= k.focus_px) k.r_max = 0;
  k.r_near = p.get_bool("near_field") ? std::ceil(r_n) : 0.0f;
  // A near radius too small to blur would show the decimated buffer unblurred: drop it
  // (demo: < 2 px; g3d: < f − 1 px).
  if (demo && k.r_near < 2) k.r_near = 0;
  if (k.variant == Variant::g3d && k.r_near < k.f - 1) k.r_near = 0;
  k.inv_near = 1.0f / std::max(k.r_near, 1e-4f);
  // farRescale: far |s| = |r| / R_max would reach only R_f / R_max at the largest far
  // radius; rescaling makes the farthest blur use the blurry buffer fully.
  k.far_rescale = far_rescale && r_f > 0 ? static_cast<float>(k.r_max) / std::max(r_f, 1e-4f) : 1.0f;
  return st;
}

FrameSetup frame_setup(const MethodContext& ctx) {
  const Image& colour = ctx.frame.color;
  const int W = colour.width(), H = colour.height();
  const int g_req = ctx.params.get_int("guard_band_px");
  if (2 * g_req >= std::min(W, H))
    throw_usage("--set guard_band_px=" + std::to_string(g_req) + ": leaves no inner image in a " + std::to_string(W) +
                "x" + std::to_string(H) + " frame (method mcguire)");
  const bool taps_req = ctx.params.get_bool("guard_band_taps");
  FrameSetup fs;
  // Region whose pixels the passes read: whole image, or the inner rect if the guard band
  // must not be read at all.
  fs.src = taps_req ? Rect{0, 0, W, H} : Rect{g_req, g_req, W - 2 * g_req, H - 2 * g_req};
  // render() took the whole map's range while writing it; a smaller `src` needs its own.
  const Rect& src = fs.src;
  const bool whole = src.x == 0 && src.y == 0 && src.w == W && src.h == H;
  const core::CocRange range =
      whole && ctx.coc_range ? *ctx.coc_range : core::coc_range(ctx.coc, src.x, src.y, src.w, src.h);
  fs.st = read_setup(ctx, range.near_max, range.far_max);
  const int g = fs.st.guard;
  fs.inner = Rect{g, g, W - 2 * g, H - 2 * g};
  fs.ox = fs.inner.x - src.x;
  fs.oy = fs.inner.y - src.y;
  fs.wo = std::max(1, fs.inner.w / fs.st.k.f);
  fs.ho = std::max(1, fs.inner.h / fs.st.k.f);
  return fs;
}

}  // namespace mcguire

namespace {

using mcguire::Constants;
using mcguire::Rect;
using mcguire::Variant;

void render_mcguire(const MethodContext& ctx, Image& out) {
  const Image& colour = ctx.frame.color;
  const mcguire::FrameSetup fs = mcguire::frame_setup(ctx);
  const Rect& src = fs.src;
  const Constants& k = fs.st.k;
  const int g = fs.st.guard;
  const Rect& inner = fs.inner;
  const int ox = fs.ox, oy = fs.oy;  // inner origin inside the packed buffer

  Workspace& ws = ctx.workspace;
  // impl=plain runs the obviously-correct passes (the test oracle); fast runs the SIMD /
  // box-sum passes for book/demo and the tap-bounded passes of blur.cpp for g3d.
  const bool plain = ctx.params.get_choice("impl") == "plain";
  const bool fast_blur = !plain && mcguire::fast_supported(k);
  const bool plain_composite = plain || ctx.debug.wants("weights");
  // render() left the colour check to this method (MethodContext::colour_dirty): the fast
  // horizontal pass makes it on each row it copies, which are all the samples any pass reads
  // (the rectangle `src`; guard band pixels outside it never reach the output). Every other
  // path checks that rectangle first.
  if (ctx.colour_dirty && (!fast_blur || k.r_max == 0) && !rect_is_sanitary(colour, src.x, src.y, src.w, src.h)) {
    ctx.colour_dirty->store(true);
    return;
  }
  // P1's packed copy: the plain passes (and g3d's blur) read it; the fast book/demo passes
  // compute s from the CoC as they read colour, so then it is never written.
  Image* packed = nullptr;
  if (!fast_blur || plain_composite) {
    packed = &ws.image("mcguire.packed", src.w, src.h, mcguire::kPacked);
    core::PassScope pass("pack");
    mcguire::pack_coc(colour, ctx.coc, src, k, *packed);
  }
  ctx.debug.offer("coc", [&] {
    // s·0.5 + 0.5 with s as pack_coc computes it.
    Image v(src.w, src.h, 1);
    const float inv_rmax = k.r_max > 0 ? 1.0f / static_cast<float>(k.r_max) : 0.0f;
    for (int y = 0; y < src.h; ++y)
      for (int x = 0; x < src.w; ++x) {
        const float r = ctx.coc.at(src.x + x, src.y + y);
        const float s = std::fabs(r) <= k.focus_px ? 0.0f : std::clamp(r * inv_rmax, -1.0f, 1.0f);
        v.at(x, y) = s * 0.5f + 0.5f;
      }
    return v;
  });

  // Guard band pixels are context, not picture: transparent black in the output.
  if (g > 0) std::fill(out.data().begin(), out.data().end(), 0.0f);

  const int wo = fs.wo, ho = fs.ho;
  Image& t_blur = ws.image("mcguire.t_blur", wo, src.h, 5);
  Image& t_near = ws.image("mcguire.t_near", wo, src.h, 5);
  Image& blur = ws.image("mcguire.blur", wo, ho, 4);
  Image& near = ws.image("mcguire.near", wo, ho, 5);
  if (k.r_max == 0) {
    // Everything is in the focus field: the composite would return the sharp input exactly.
    for (int c = 0; c < 4; ++c)
      for (int y = 0; y < inner.h; ++y)
        std::copy_n(colour.row(c, inner.y + y) + inner.x, inner.w, out.row(c, inner.y + y) + inner.x);
    ctx.debug.offer("near", [&] { return Image(wo, ho, 4, 0.0f); });
    ctx.debug.offer("far", [&] {
      Image v(inner.w, inner.h, 4);
      for (int c = 0; c < 4; ++c)
        for (int y = 0; y < inner.h; ++y) std::copy_n(colour.row(c, inner.y + y) + inner.x, inner.w, v.row(c, y));
      return v;
    });
    ctx.debug.offer("weights", [&] {
      Image v(inner.w, inner.h, 4, 0.0f);
      std::fill_n(v.plane(2), v.plane_size(), 1.0f);
      std::fill_n(v.plane(3), v.plane_size(), 1.0f);
      return v;
    });
    return;
  }
  if (plain) {
    {
      core::PassScope pass("horizontal");
      mcguire::blur_horizontal_plain(*packed, k, ox, wo, t_blur, t_near);
    }
    core::PassScope pass("vertical");
    mcguire::blur_vertical_plain(t_blur, t_near, k, oy, ho, blur, near);
  } else if (fast_blur) {
    // Per t_near row, the outputs outside which it is +0 (P3 skips those columns).
    int* near_span = ws.plane<int>("mcguire.fast.near_span", 2 * static_cast<std::size_t>(src.h));
    {
      core::PassScope pass("horizontal");
      mcguire::blur_horizontal_fast(colour, ctx.coc, src, k, ox, wo, t_blur, t_near, ws, ctx.colour_dirty, near_span);
    }
    if (ctx.colour_dirty && ctx.colour_dirty->load()) return;  // render() starts again from sanitised colour
    core::PassScope pass("vertical");
    mcguire::blur_vertical_fast(t_blur, t_near, k, oy, ho, blur, near, ws, near_span);
  } else {
    {
      core::PassScope pass("horizontal");
      mcguire::blur_horizontal(*packed, k, ox, wo, t_blur, t_near);
    }
    core::PassScope pass("vertical");
    mcguire::blur_vertical(t_blur, t_near, k, oy, ho, blur, near);
  }
  ctx.debug.offer("far", blur);
  ctx.debug.offer("near", [&] {
    // RGBA premultiplied by the near coverage; alpha = coverage.
    Image v(near.width(), near.height(), 4);
    for (int c = 0; c < 3; ++c) std::copy_n(near.plane(c), near.plane_size(), v.plane(c));
    std::copy_n(near.plane(4), near.plane_size(), v.plane(3));
    return v;
  });
  Image weights;
  core::PassScope pass("composite");
  if (plain_composite)
    mcguire::composite(*packed, ox, oy, blur, near, k, inner, out, ctx.debug.wants("weights") ? &weights : nullptr);
  else
    mcguire::composite_fast(colour, ctx.coc, src, ox, oy, blur, near, k, inner, out, ws);
  ctx.debug.offer("weights", weights);
}

}  // namespace

const MethodDef& mcguire_method() {
  static const MethodDef def{
      "mcguire",
      "McGuire et al. (Skylanders / VVDoF / G3D): dual separable near/far blur at reduced resolution, "
      "near-field inpainting, coverage-boosted composite",
      {
          choice_param("variant", "demo", {"book", "demo", "g3d"},
                       "book (GPU Pro 4: 2x, Gaussian far kernel, far occlusion test) | demo (2013 web demo: 4x, "
                       "disc-like far kernel, no far test, far-radius rescale) | g3d (G3D 10 rules, "
                       "docs/methods/mcguire.md)"),
          int_param("reduction", param_by("variant", {{"demo", 4}, {"book", 2}, {"g3d", 2}}), 1, 4, "",
                    "reduced-resolution factor per axis of the blur buffers"),
          float_param("coverage_boost", param_by("variant", {{"demo", 1.0}, {"book", 1.5}, {"g3d", 1.5}}), 1.0, 100.0,
                      "", "near-field alpha gain (book/demo only): > 1 makes near objects more solid than a lens does"),
          float_param("near_radius_px", 0.0, 0.0, 1e5, "px",
                      "fixed near-field blur radius in image px; 0 = the largest near CoC radius in the frame"),
          bool_param("near_field", true,
                     "off = no separate near-field layer (Gillham-style: blurry near objects keep hard silhouettes); "
                     "a baseline that shows what the near field buys"),
          bool_param("far_occlusion_test", param_by("variant", {{"book", true}, {"g3d", true}, {"demo", false}}),
                     "far taps count only if not meaningfully farther than the centre"),
          bool_param("far_rescale", param_by("variant", {{"demo", true}, {"g3d", true}, {"book", false}}),
                     "Sept-2013 fix: far |s| reaches 1 at the largest far radius instead of at R_max"),
          bool_param("double_coc", param_by("variant", {{"demo", true}, {"book", false}, {"g3d", false}}),
                     "composite doubles s, clamp(2s, -1, 1), as some 2013 ports do (book/demo)"),
          choice_param("near_alpha", "code", {"code", "book"},
                       "near coverage curve: code = saturate(4 r/R_near)^4, book = min(1, r/R_near)^4"),
          float_param("focus_px", 0.5, 0.0, 1e6, "px", "pixels with |CoC| <= this many px are exactly sharp"),
          bool_param("lowres_offset_fix", true,
                     "sample the point-decimated buffers where their texels came from (off = centred lookup, "
                     "shifts by (f-1)/2 px)"),
          float_param("g3d_fov_deg", 40.0, 1.0, 179.0, "deg", "g3d near coverage curve: field of view"),
          int_param("guard_band_px", 0, 0, 1 << 20, "px",
                    "border on every side that is read as context but not rendered: output there is transparent "
                    "black"),
          bool_param("guard_band_taps", true, "blur taps may read into the guard band (off = it is never read)"),
          choice_param("impl", "fast", {"fast", "plain"},
                       "fast = SIMD / box-sum passes (book, demo; g3d: tap-bounded passes), plain = the unoptimised "
                       "passes kept as the test oracle; both agree within float rounding"),
      },
      {
          {"coc", "packed signed CoC s*0.5+0.5 (0.5 = in focus, > 0.5 near), 1 plane, full size"},
          {"near", "near-field buffer, RGB premultiplied by its coverage, alpha = coverage (reduced size)"},
          {"far", "blurry far/focus buffer, RGBA (reduced size)"},
          {"weights", "composite weights: R = near coverage, G = blurry weight, B = sharp weight (full size)"},
      },
      render_mcguire,
      /*checks_colour=*/true,
      /*aperture=*/""};
  return def;
}

}  // namespace dofkit::detail
