#include "dofkit/error.hpp"
#include "gpu/methods/common.hpp"
namespace dofkit::gpu {
std::unique_ptr<MethodRenderer> make_starcraft(const RenderSettings&) {
  throw_internal("starcraft: not yet on the GPU");
}
}  // namespace dofkit::gpu
