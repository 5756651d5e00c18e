// mcguire on the GPU: the four passes of src/methods/mcguire/ (plain forms) as compute
// shaders, src/gpu/shaders/mcguire/{pack,horizontal,vertical,composite}.comp. The per-frame
// constants come from the same code as the CPU's (mcguire::frame_setup).
//
// Precision (docs/gpu.md): every buffer is float32. The chapter packs colour and CoC into
// RGBA8 / RGBA16F targets; here s stays float because the blur's table index and the near /
// far tests are thresholds on it, and the blur buffers stay float because they are averages of
// up to 2·R_max + 1 taps that the parity tests compare with the CPU's float sums.
#include <cstdint>

#include "dofkit/error.hpp"
#include "gpu/methods/common.hpp"
#include "methods/mcguire/mcguire.hpp"

namespace dofkit::gpu {

namespace {

// src/gpu/shaders/mcguire/params.glsl, member for member.
struct Params {
  std::int32_t W, H, src_x, src_y, src_w, src_h;
  std::int32_t inner_x, inner_y, inner_w, inner_h;
  std::int32_t ox, oy, wo, ho;
  std::int32_t variant, f, r_max, far_occlusion;
  std::int32_t double_coc, near_alpha_code, lowres_fix, identity;
  float r_near, inv_near, far_rescale, coverage_boost;
  float focus_px, g3d_fov, inv_rmax, rmax;
};
static_assert(sizeof(Params) == 30 * 4);

class Mcguire final : public GraphRenderer {
 public:
  void render(const detail::MethodContext& ctx, Image& out) override {
    const detail::mcguire::FrameSetup fs = detail::mcguire::frame_setup(ctx);
    const detail::mcguire::Constants& k = fs.st.k;
    const int W = ctx.frame.width(), H = ctx.frame.height();
    Params p{};
    p.W = W;
    p.H = H;
    p.src_x = fs.src.x;
    p.src_y = fs.src.y;
    p.src_w = fs.src.w;
    p.src_h = fs.src.h;
    p.inner_x = fs.inner.x;
    p.inner_y = fs.inner.y;
    p.inner_w = fs.inner.w;
    p.inner_h = fs.inner.h;
    p.ox = fs.ox;
    p.oy = fs.oy;
    p.wo = fs.wo;
    p.ho = fs.ho;
    p.variant = k.variant == detail::mcguire::Variant::book ? 0 : k.variant == detail::mcguire::Variant::demo ? 1 : 2;
    p.f = k.f;
    p.r_max = k.r_max;
    p.far_occlusion = k.far_occlusion;
    p.double_coc = k.double_coc;
    p.near_alpha_code = k.near_alpha_code;
    p.lowres_fix = k.lowres_offset_fix;
    p.identity = k.r_max == 0;
    p.r_near = k.r_near;
    p.inv_near = k.inv_near;
    p.far_rescale = k.far_rescale;
    p.coverage_boost = k.coverage_boost;
    p.focus_px = k.focus_px;
    p.g3d_fov = k.g3d_fov_rad;
    p.inv_rmax = k.r_max > 0 ? 1.0f / static_cast<float>(k.r_max) : 0.0f;
    p.rmax = static_cast<float>(k.r_max);

    const std::size_t n = static_cast<std::size_t>(W) * H, m = static_cast<std::size_t>(fs.src.w) * fs.src.h;
    graph_.begin_frame(5 * n, 4 * n);
    int colour, coc;
    upload_colour_coc(ctx, colour, coc);
    const int packed = graph_.buffer("packed", 5 * m);
    const int t_blur = graph_.buffer("t_blur", 5 * static_cast<std::size_t>(fs.wo) * fs.src.h);
    const int t_near = graph_.buffer("t_near", 5 * static_cast<std::size_t>(fs.wo) * fs.src.h);
    const int blur = graph_.buffer("blur", 4 * static_cast<std::size_t>(fs.wo) * fs.ho);
    const int near = graph_.buffer("near", 5 * static_cast<std::size_t>(fs.wo) * fs.ho);
    const int result = graph_.buffer("out", 4 * n);
    dispatch("mcguire/pack", {colour, coc, packed}, p, fs.src.w, fs.src.h, "mcguire/pack");
    if (k.r_max > 0) {
      dispatch("mcguire/horizontal", {packed, t_blur, t_near}, p, fs.wo, fs.src.h, "mcguire/horizontal");
      dispatch("mcguire/vertical", {t_blur, t_near, blur, near}, p, fs.wo, fs.ho, "mcguire/vertical");
    }
    dispatch("mcguire/composite", {packed, blur, near, result}, p, W, H, "mcguire/composite");
    download_rgba(result, W, H, out);
    graph_.end_frame();
  }
};

}  // namespace

std::unique_ptr<MethodRenderer> make_mcguire(const RenderSettings&) { return std::make_unique<Mcguire>(); }

}  // namespace dofkit::gpu
