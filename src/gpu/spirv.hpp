// The SPIR-V modules compiled from src/gpu/shaders/ at build time (generated table).
#pragma once
#include <cstddef>
#include <cstdint>

namespace dofkit::gpu {

struct SpirvModule {
  const char* name;  ///< path under src/gpu/shaders/ without ".comp", e.g. "mcguire/horizontal"
  const std::uint32_t* words;
  std::size_t count;  ///< number of 32-bit words
};

/// The module of that name, or null.
const SpirvModule* find_spirv(const char* name);

}  // namespace dofkit::gpu
