// sterna on the GPU: the passes of src/methods/sterna/ (plain forms) as compute shaders,
// src/gpu/shaders/sterna/*.comp and the shared box pass core/box.comp. The per-frame
// settings come from the CPU's code (sterna::read_settings).
//
// Precision (docs/gpu.md): float32 buffers throughout. Sterna's demo keeps its half-res
// fields in RGBA16F; here the far field is a ratio Σ colourFar / Σ far whose denominator can
// be small at far/focus borders, and the blend factors decide the early-outs, so both stay
// float, and so do the fields the parity tests compare with the CPU's float sums.
#include <cstdint>
#include <variant>

#include "core/filters.hpp"
#include "gpu/methods/common.hpp"
#include "methods/sterna/passes.hpp"

namespace dofkit::gpu {

namespace {

namespace st = detail::sterna;

// src/gpu/shaders/sterna/params.glsl, member for member.
struct Params {
  std::int32_t W, H, w, h;
  std::int32_t native, per_pixel, bicubic, karis;
  std::int32_t r, axis, ntaps, pad0;
  float ramp, nb, ne, fb;
  float fe, ks, blend, radius_per_far_fill;
  float radius_per_far_comp, inv_taps, pad1, pad2;
};
static_assert(sizeof(Params) == 24 * 4);

class Sterna final : public GraphRenderer {
 public:
  void render(const detail::MethodContext& ctx, Image& out) override {
    const st::Settings s = st::read_settings(ctx);
    const int W = ctx.frame.width(), H = ctx.frame.height();
    const int w = (W + 1) / 2, h = (H + 1) / 2;
    Params p{};
    p.W = W;
    p.H = H;
    p.w = w;
    p.h = h;
    const NearFarBlend* nfb = std::get_if<NearFarBlend>(&ctx.camera.model);
    p.native = nfb != nullptr;
    if (nfb) {
      p.nb = static_cast<float>(nfb->near_begin_m);
      p.ne = static_cast<float>(nfb->near_end_m);
      p.fb = static_cast<float>(nfb->far_begin_m);
      p.fe = static_cast<float>(nfb->far_end_m);
    }
    p.per_pixel = s.per_pixel_scale;
    p.bicubic = s.bicubic_near;
    p.karis = s.karis;
    p.r = s.dilate_radius;
    p.ntaps = static_cast<std::int32_t>(s.offsets.size());
    p.ramp = std::max(s.blend_radius_px - 0.5f, 1e-3f);  // coc.cpp
    p.ks = s.kernel_scale;
    p.blend = s.composite_blend;
    p.radius_per_far_fill = st::kOuterRadius * s.kernel_scale;         // fill.cpp
    p.radius_per_far_comp = 2.0f * st::kOuterRadius * s.kernel_scale;  // composite.cpp
    p.inv_taps = 1.0f / static_cast<float>(s.offsets.size());
    offsets_.clear();
    for (const st::Offset& o : s.offsets) offsets_.insert(offsets_.end(), {o.x, o.y});

    const std::size_t N = static_cast<std::size_t>(W) * H, m = static_cast<std::size_t>(w) * h;
    graph_.begin_frame(6 * N + offsets_.size(), 4 * N);
    int colour, coc;
    upload_colour_coc(ctx, colour, coc);
    const int depth = graph_.buffer("depth", nfb ? N : 1);
    if (nfb) {
      const float* z = ctx.frame.depth.plane(0);
      graph_.upload(depth, &z, 1, N);
    }
    const int offsets = graph_.buffer("offsets", offsets_.size());
    const float* op = offsets_.data();
    graph_.upload(offsets, &op, 1, offsets_.size());
    const int full = graph_.buffer("full_coc", 2 * N);
    const int col_h = graph_.buffer("colour_h", 4 * m), far_h = graph_.buffer("colour_far_h", 4 * m);
    const int coc_h = graph_.buffer("coc_h", 2 * m);
    const int tmp = graph_.buffer("near_tmp", m), tmp2 = graph_.buffer("near_tmp2", m),
              nblur = graph_.buffer("near_blur", m);
    const int dof_near = graph_.buffer("dof_near", 4 * m), dof_far = graph_.buffer("dof_far", 4 * m);
    const int near_fill = graph_.buffer("near_fill", 4 * m), far_fill = graph_.buffer("far_fill", 4 * m);
    const int result = graph_.buffer("out", 4 * N);

    dispatch("sterna/coc", {coc, depth, full}, p, W, H, "sterna/coc");
    dispatch("sterna/downsample", {colour, full, col_h, far_h, coc_h}, p, w, h, "sterna/downsample");
    // P3-P6: max ±r along x then y (coc_h's near plane is its first), then the box ±r.
    p.axis = 0;
    dispatch("sterna/near_max", {coc_h, tmp}, p, w, h, "sterna/near coc");
    p.axis = 1;
    dispatch("sterna/near_max", {tmp, tmp2}, p, w, h, "sterna/near coc");
    BoxParams b = box_params(w, h, 1, s.dilate_radius, 0.0f);
    b.axis = 0;
    dispatch("core/box", {tmp2, tmp}, b, w, h, "sterna/near coc");
    b.axis = 1;
    b.flush_below = 1e-6f;  // near_coc_dilate.cpp: "nearBlur > 0" means a near texel within reach
    dispatch("core/box", {tmp, nblur}, b, w, h, "sterna/near coc");
    dispatch("sterna/gather", {col_h, far_h, coc_h, nblur, offsets, dof_near, dof_far}, p, w, h, "sterna/gather");
    dispatch("sterna/fill", {dof_near, dof_far, coc_h, nblur, near_fill, far_fill}, p, w, h, "sterna/fill");
    dispatch("sterna/composite", {colour, full, coc_h, nblur, near_fill, far_fill, result}, p, W, H,
             "sterna/composite");
    download_rgba(result, W, H, out);
    graph_.end_frame();
  }

 private:
  std::vector<float> offsets_;
};

}  // namespace

std::unique_ptr<MethodRenderer> make_sterna(const RenderSettings&) { return std::make_unique<Sterna>(); }

}  // namespace dofkit::gpu
