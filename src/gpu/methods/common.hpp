// What every method's GPU renderer shares: the recorder, the per-frame uploads and the
// workgroup counts. One file per method beside this one (mcguire.cpp, sterna.cpp,
// starcraft.cpp), each recording the passes of src/gpu/shaders/<method>/.
#pragma once
#include <cstdint>
#include <string>

#include "gpu/gpu.hpp"
#include "gpu/vk.hpp"

namespace dofkit::gpu {

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
