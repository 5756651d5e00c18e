// The GPU backend as render() and the CLI see it: no Vulkan types here, so this header and
// gpu_off.cpp (the -DDOFKIT_VULKAN=OFF build) need no Vulkan at all. docs/gpu.md describes it.
#pragma once
#include <memory>
#include <string>
#include <vector>

#include "dofkit/render.hpp"
#include "methods/method.hpp"

namespace dofkit::gpu {

/// The device the backend runs on.
struct DeviceInfo {
  int index = -1;      ///< position in vkEnumeratePhysicalDevices
  std::string name;    ///< e.g. "NVIDIA H100 80GB HBM3", "llvmpipe (LLVM 15.0.6, 256 bits)"
  std::string type;    ///< discrete, integrated, virtual, cpu, other
  std::string driver;  ///< driver name and version text
  std::string api;     ///< Vulkan API version, e.g. "1.3.230"
};

/// GPU time of one frame from timestamp queries, ms. `passes` in execution order, named like
/// the CPU passes of `dofkit bench --passes` ("mcguire/horizontal").
struct FrameTimes {
  double upload_ms = 0;    ///< colour / CoC / depth from the staging buffer to the device
  double passes_ms = 0;    ///< the method's passes (sum of `passes`)
  double download_ms = 0;  ///< result (and debug view) to the staging buffer
  struct Pass {
    std::string name;
    double ms = 0;
  };
  std::vector<Pass> passes;
};

/// The GPU half of a Renderer with backend = vulkan.
class MethodRenderer {
 public:
  virtual ~MethodRenderer() = default;
  /// Renders ctx.frame (already validated and sanitised; ctx.coc holds the CoC map render()
  /// computed) into `out` (RGBA, frame size). A requested debug view goes to ctx.debug.
  virtual void render(const detail::MethodContext& ctx, Image& out) = 0;
  virtual const FrameTimes& last_times() const = 0;
  virtual DeviceInfo device() const = 0;
};

/// The methods the backend has shaders for.
std::vector<std::string> supported_methods();

/// A renderer for `settings.method` on the selected device. Throws Error(usage) for a method
/// without shaders, Error(internal) when this build has no Vulkan or no device can be used
/// (one line saying which).
std::unique_ptr<MethodRenderer> make_renderer(const RenderSettings& settings);

/// The device the backend would use (DOFKIT_VK_DEVICE=<index|name> overrides the choice of a
/// discrete, then integrated, then any GPU, the CPU implementation last). Throws like
/// make_renderer.
DeviceInfo selected_device();

/// GPU time of copying one W×H RGBA image once on the device (vkCmdCopyImage between two
/// device-local images; half: RGBA16F, else RGBA32F), one value per timed copy (ms), after
/// one untimed copy.
std::vector<double> time_frame_copy(int width, int height, bool half, int iterations);

/// Validation (DOFKIT_VK_VALIDATION=1, or set_validation(true) before the first GPU call of the
/// process): the Khronos validation layer with synchronisation validation; any message it
/// sends makes the render that caused it throw Error(internal) with the message.
void set_validation(bool on);
bool validation_enabled();

namespace testing {
/// Test hook: leaves out the barrier in front of dispatch number `index` (0-based, counted
/// per frame) of every later frame; -1 restores them. Exists so a test can show that the
/// synchronisation validation catches a missing barrier.
void drop_barrier(int index);
}  // namespace testing

}  // namespace dofkit::gpu

namespace dofkit::detail {
/// Render.cpp's door to a Renderer's GPU half (null for the CPU backend).
struct RendererAccess {
  static const gpu::MethodRenderer* gpu(const Renderer& r);
};
}  // namespace dofkit::detail
