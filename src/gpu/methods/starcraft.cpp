// starcraft on the GPU: the passes of src/methods/starcraft/ (plain forms) as compute shaders,
// src/gpu/shaders/starcraft/*.comp, with the Gaussians as core/box.comp extended-box passes
// (the CPU's cascade: same radii and end weights, x passes then y passes). Settings and level
// geometry come from the CPU's code (starcraft::read_settings, make_geometry).
//
// Precision (docs/gpu.md): float32 buffers. The chapter does not say which formats it used;
// the blurred 1/z decides rule 3 by a hard comparison with a 1e-5 relative tolerance, and
// the medium and large levels are ratios of blurred sums whose denominators can be tiny, so
// none of them can be half floats without changing which level a pixel takes.
#include <cstdint>
#include <cstring>
#include <variant>

#include "core/filters.hpp"
#include "gpu/methods/common.hpp"
#include "methods/starcraft/starcraft.hpp"

namespace dofkit::gpu {

namespace {

namespace sc = detail::starcraft;

// src/gpu/shaders/starcraft/params.glsl, member for member.
struct Params {
  std::int32_t W, H, lw, lh;
  std::int32_t native, keep_own, reduce_max, pad0;
  float vs, vm, vl, focus;
  float full_range, range, amount, pad1;
};
static_assert(sizeof(Params) == 16 * 4);

class Starcraft final : public GraphRenderer {
 public:
  void render(const detail::MethodContext& ctx, Image& out) override {
    const sc::Settings s = sc::read_settings(ctx);
    const sc::LevelGeometry g = sc::make_geometry(ctx, s);
    const int W = ctx.frame.width(), H = ctx.frame.height();
    const int lw = sc::down_size(W), lh = sc::down_size(H);
    Params p{};
    p.W = W;
    p.H = H;
    p.lw = lw;
    p.lh = lh;
    const StarCraft* cam = std::get_if<StarCraft>(&ctx.camera.model);
    p.native = cam != nullptr;
    if (cam) {
      p.focus = static_cast<float>(cam->focus_distance_m);
      p.full_range = static_cast<float>(cam->full_focus_range_m);
      p.range = static_cast<float>(cam->no_focus_range_m - cam->full_focus_range_m);
      p.amount = static_cast<float>(cam->amount);
    }
    p.keep_own = s.keep_own_blur;
    p.reduce_max = s.coc_reduce_max;
    // LevelGeometry::level_of_radius's breakpoints, computed as it computes them.
    p.vs = g.r_small * g.r_small - 0.25f;
    p.vm = g.r_medium * g.r_medium - 0.25f;
    p.vl = g.r_large * g.r_large - 0.25f;

    const std::size_t N = static_cast<std::size_t>(W) * H, m = static_cast<std::size_t>(lw) * lh;
    graph_.begin_frame(6 * N, 4 * N);
    int colour, coc;
    upload_colour_coc(ctx, colour, coc);
    const int depth = graph_.buffer("depth", N);
    const float* z = ctx.frame.depth.plane(0);
    graph_.upload(depth, &z, 1, N);
    const int level = graph_.buffer("level", N);
    const int medium = graph_.buffer("medium", 5 * N), medium_tmp = graph_.buffer("medium_tmp", 5 * N);
    const int large = graph_.buffer("large", 5 * m), large_tmp = graph_.buffer("large_tmp", 5 * m);
    const int inv_depth = graph_.buffer("inv_depth", m), depth_tmp = graph_.buffer("inv_depth_tmp", m);
    const int result = graph_.buffer("out", 4 * N);

    dispatch("starcraft/levels", {coc, depth, level}, p, W, H, "starcraft/levels");
    dispatch("starcraft/large_reduce", {colour, level, large}, p, lw, lh, "starcraft/large level");
    gaussian(large, large_tmp, lw, lh, 5, sc::quarter_res_sigma(g.sigma_large), 3, "starcraft/large level");
    // The blurred 1/z decides rule 3 by a hard comparison: in double, as on the CPU, where the
    // device has doubles (else float: a pixel near the tie may take the other level).
    const bool f64 = graph_.context().float64;
    dispatch(f64 ? "starcraft/depth_reduce_f64" : "starcraft/depth_reduce", {depth, inv_depth}, p, lw, lh,
             "starcraft/depth blur");
    gaussian(inv_depth, depth_tmp, lw, lh, 1, sc::quarter_res_sigma(g.sigma_depth), 3, "starcraft/depth blur", f64);
    dispatch("starcraft/medium_weight", {colour, level, medium}, p, W, H, "starcraft/medium level");
    gaussian(medium, medium_tmp, W, H, 5, g.sigma_medium, s.medium_boxes, "starcraft/medium level");
    dispatch("starcraft/final", {colour, depth, level, medium, large, inv_depth, result}, p, W, H, "starcraft/final");
    download_rgba(result, W, H, out);
    graph_.end_frame();
  }

 private:
  // core::gaussian_blur_plane_plain on `planes` planes of buf (w × h): `passes` extended-box
  // passes along x, then along y, ping-ponging through tmp (an even count: the result is in
  // buf). σ <= 0: no blur, as on the CPU.
  void gaussian(int buf, int tmp, int w, int h, int planes, float sigma, int passes, const std::string& pass,
                bool f64 = false) {
    if (!(sigma > 0)) return;
    int r;
    float alpha;
    core::extended_box_params(sigma, passes, r, alpha);
    BoxParams b = box_params(w, h, planes, r, alpha);
    int src = buf, dst = tmp;
    for (int axis = 0; axis < 2; ++axis)
      for (int i = 0; i < passes; ++i) {
        b.axis = axis;
        dispatch(f64 ? "core/box_f64" : "core/box", {src, dst}, b, w, h, pass);
        std::swap(src, dst);
      }
  }
};

}  // namespace

std::unique_ptr<MethodRenderer> make_starcraft(const RenderSettings&) { return std::make_unique<Starcraft>(); }

}  // namespace dofkit::gpu
