#include "core/simd_target.hpp"

#include <atomic>
#include <cstdint>

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "core/simd_target.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace dofkit::core {
namespace HWY_NAMESPACE {
int FloatLanes() { return static_cast<int>(hwy::HWY_NAMESPACE::Lanes(hwy::HWY_NAMESPACE::ScalableTag<float>())); }
}  // namespace HWY_NAMESPACE
}  // namespace dofkit::core
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace dofkit::core {

HWY_EXPORT(FloatLanes);

namespace {

std::atomic<int> g_cap{static_cast<int>(SimdLevel::avx512)};

SimdLevel level_of(std::int64_t target) {
#if HWY_ARCH_X86
  if (target == HWY_AVX2) return SimdLevel::avx2;
  // Every AVX-512 target of this Highway (AVX3, AVX3_DL; better targets have lower bits).
  if (target < HWY_AVX2) return SimdLevel::avx512;
#else
  (void)target;
#endif
  return SimdLevel::baseline;
}

// The runnable compiled targets, taken once before any pinning.
const std::vector<std::int64_t>& runnable() {
  static const std::vector<std::int64_t> targets = hwy::SupportedAndGeneratedTargets();
  return targets;
}

}  // namespace

SimdLevel simd_level_cap() { return static_cast<SimdLevel>(g_cap.load(std::memory_order_relaxed)); }

std::vector<std::string> simd_targets() {
  std::vector<std::string> names;
  for (const std::int64_t t : runnable()) names.emplace_back(hwy::TargetName(t));
  return names;
}

std::string simd_target() {
  const std::vector<std::int64_t> now = hwy::SupportedAndGeneratedTargets();
  return now.empty() ? std::string() : std::string(hwy::TargetName(now.front()));
}

int simd_float_lanes() { return HWY_DYNAMIC_DISPATCH(FloatLanes)(); }

bool pin_simd_target(const std::string& name) {
  const std::vector<std::int64_t>& all = runnable();
  if (name.empty()) {
    hwy::SetSupportedTargetsForTest(0);
    g_cap.store(static_cast<int>(SimdLevel::avx512));
    return true;
  }
  for (const std::int64_t t : all)
    if (name == hwy::TargetName(t)) {
      hwy::SetSupportedTargetsForTest(t);
      g_cap.store(static_cast<int>(level_of(t)));
      return true;
    }
  return false;
}

}  // namespace dofkit::core
#endif  // HWY_ONCE
