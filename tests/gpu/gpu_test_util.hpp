// Helpers of the GPU backend tests: the CPU oracle against the vulkan backend on one frame.
#pragma once
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "dofkit/error.hpp"
#include "dofkit/render.hpp"
#include "gpu/gpu.hpp"
#include "metrics/metrics.hpp"
#include "scene/scene.hpp"

namespace dofkit::test {

/// Every GPU test runs with the Khronos validation layer and synchronisation validation on:
/// any message fails the render that caused it (gpu::set_validation). Built with
/// -DDOFKIT_VULKAN=OFF the tests are skipped (visibly); built with Vulkan they need a device
/// (CI: Mesa's lavapipe, installed by scripts/deps) and fail without one. A macro, so that the
/// skip ends the test itself (in a test body or SetUp).
#define DOFKIT_REQUIRE_GPU()                                                                          \
  do {                                                                                                \
    if (::dofkit::gpu::supported_methods().empty()) GTEST_SKIP() << "built with -DDOFKIT_VULKAN=OFF"; \
    ::dofkit::gpu::set_validation(true);                                                              \
    ::dofkit::gpu::selected_device(); /* throws (fails the test) without a usable device */           \
  } while (0)

struct Parity {
  double max_abs = 0;          ///< largest |gpu − cpu| over every sample
  double max_rel = 0;          ///< largest |gpu − cpu| / max(1, |cpu|)
  double psnr_db = 0;          ///< metrics::psnr (clipped sRGB, peak 1)
  int x = -1, y = -1, c = -1;  ///< where max_abs is
};

inline Parity parity(const Image& cpu, const Image& gpu) {
  Parity p;
  EXPECT_TRUE(cpu.same_size(gpu) && cpu.channels() == gpu.channels());
  for (int c = 0; c < cpu.channels(); ++c)
    for (int y = 0; y < cpu.height(); ++y)
      for (int x = 0; x < cpu.width(); ++x) {
        const double a = cpu.at(x, y, c), b = gpu.at(x, y, c);
        const double d = std::isfinite(b) ? std::fabs(a - b) : INFINITY;
        if (d > p.max_abs || std::isnan(d)) {
          p.max_abs = std::isnan(d) ? INFINITY : d;
          p.x = x, p.y = y, p.c = c;
        }
        p.max_rel = std::max(p.max_rel, d / std::max(1.0, std::fabs(a)));
      }
  p.psnr_db = metrics::psnr(cpu, gpu);
  return p;
}

/// Renders `frame` with the CPU's plain passes (impl=plain, the oracle) and with the vulkan
/// backend, same settings otherwise.
inline Parity cpu_vs_gpu(const Frame& frame, RenderSettings s) {
  s.params["impl"] = "plain";
  s.backend = Backend::cpu;
  const RenderResult cpu = render(frame, s);
  s.backend = Backend::vulkan;
  const RenderResult gpu = render(frame, s);
  return parity(cpu.image, gpu.image);
}

inline std::string describe(const Parity& p) {
  char buf[200];
  std::snprintf(buf, sizeof buf, "max abs %.3g at (%d, %d, plane %d), max rel %.3g, PSNR %.1f dB", p.max_abs, p.x, p.y,
                p.c, p.max_rel, p.psnr_db);
  return buf;
}

}  // namespace dofkit::test
