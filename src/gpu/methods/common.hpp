// What every method's GPU renderer shares: the recorder, the per-frame uploads and the
// workgroup counts. One file per method beside this one (mcguire.cpp, sterna.cpp,
// starcraft.cpp), each recording the passes of src/gpu/shaders/<method>/.
#pragma once
#include <cstdint>
#include <cstring>
#include <string>

#include "gpu/gpu.hpp"
#include "gpu/vk.hpp"

namespace dofkit::gpu {

/// The constants of src/gpu/shaders/core/box.comp (one extended-box pass) and box_f64.comp
/// (the same with the double norm's two 32-bit halves in norm_lo / norm_hi).
struct BoxParams {
  std::int32_t w, h, planes, axis;
  std::int32_t r, norm_lo, norm_hi, pad2;
  float alpha, norm, flush_below, pad3;
};
/// A box pass over `planes` planes of w × h with radius r and end weight alpha (0: plain box),
/// norm = 1 / (2r + 1 + 2·alpha) as the CPU computes it (double); nothing flushed.
inline BoxParams box_params(int w, int h, int planes, int r, float alpha) {
  BoxParams b{};
  b.w = w;
  b.h = h;
  b.planes = planes;
  b.r = r;
  b.alpha = alpha;
  const double norm = 1.0 / (2.0 * r + 1.0 + 2.0 * alpha);
  b.norm = static_cast<float>(norm);
  std::uint64_t bits;
  std::memcpy(&bits, &norm, sizeof bits);
  b.norm_lo = static_cast<std::int32_t>(bits & 0xffffffffu);
  b.norm_hi = static_cast<std::int32_t>(bits >> 32);
  b.flush_below = -1.0f;
  return b;
}

class GraphRenderer : public MethodRenderer {
 public:
  GraphRenderer() : graph_(vk::Context::get()) {}
  const FrameTimes& last_times() const override { return graph_.times(); }
  DeviceInfo device() const override { return info_; }

 protected:
  /// 2-D workgroup counts for a w × h grid (shaders: 16 × 8 invocations, DOFKIT_LOCAL_2D).
  static std::uint32_t gx(int w) { return static_cast<std::uint32_t>((w + 15) / 16); }
  static std::uint32_t gy(int h) { return static_cast<std::uint32_t>((h + 7) / 8); }
  template <class P>
  void dispatch(const char* shader, const std::vector<int>& bufs, const P& params, int w, int h,
                const std::string& pass) {
    graph_.dispatch(shader, bufs, &params, sizeof(P), gx(w), gy(h), pass);
  }
  /// Uploads the frame's colour (4 planes) into buffer "colour" and the CoC map into "coc".
  void upload_colour_coc(const detail::MethodContext& ctx, int& colour, int& coc) {
    const Image& c = ctx.frame.color;
    colour = graph_.buffer("colour", 4 * c.plane_size());
    coc = graph_.buffer("coc", c.plane_size());
    const float* planes[4] = {c.plane(0), c.plane(1), c.plane(2), c.plane(3)};
    graph_.upload(colour, planes, 4, c.plane_size());
    const float* cp = ctx.coc.plane(0);
    graph_.upload(coc, &cp, 1, c.plane_size());
  }
  /// Downloads 4 planes of w × h from buffer `id` into `out` (resized).
  void download_rgba(int id, int w, int h, Image& out) {
    out.resize(w, h, 4);
    graph_.download(id, 0, 4 * out.plane_size(), out.plane(0));
  }

  vk::Graph graph_;
  DeviceInfo info_ = graph_.context().info;
};

std::unique_ptr<MethodRenderer> make_mcguire(const RenderSettings& s);
std::unique_ptr<MethodRenderer> make_sterna(const RenderSettings& s);
std::unique_ptr<MethodRenderer> make_starcraft(const RenderSettings& s);

}  // namespace dofkit::gpu
