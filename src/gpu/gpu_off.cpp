// The GPU backend in a build configured with -DDOFKIT_VULKAN=OFF: every entry point says so.
#include "dofkit/error.hpp"
#include "gpu/gpu.hpp"

namespace dofkit::gpu {

namespace {
[[noreturn]] void no_vulkan() {
  throw_internal("--backend vulkan: this dofkit was built without the Vulkan backend (-DDOFKIT_VULKAN=OFF)");
}
}  // namespace

std::vector<std::string> supported_methods() { return {}; }
std::unique_ptr<MethodRenderer> make_renderer(const RenderSettings&) { no_vulkan(); }
DeviceInfo selected_device() { no_vulkan(); }
std::vector<double> time_frame_copy(int, int, bool, int) { no_vulkan(); }
void set_validation(bool) {}
bool validation_enabled() { return false; }
namespace testing {
void drop_barrier(int) {}
}  // namespace testing

}  // namespace dofkit::gpu
