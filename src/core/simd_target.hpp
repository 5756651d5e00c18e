// Which SIMD code paths run. A release build carries several copies of every hot loop (Highway
// kernels for AVX-512 / AVX2 / SSE4 / portable 128-bit code, plus a few hand-dispatched ones)
// and runs the widest one the CPU has. That leaves the narrower copies untested on the machine
// that runs the tests, yet a user's machine may take any of them. Tests therefore pin each
// target this machine can run in turn (DOFKIT_SIMD_TARGET, tests/simd_target_main.cpp) and
// compare the fast passes with the plain oracles again.
#pragma once
#include <string>
#include <vector>

namespace dofkit::core {

/// The x86 vector levels of dofkit's own run-time dispatchers (those not built on Highway).
enum class SimdLevel { baseline = 0, avx2 = 1, avx512 = 2 };

/// The widest level the own dispatchers may choose: the widest of the machine unless a test
/// pinned a narrower target.
SimdLevel simd_level_cap();

/// The Highway targets compiled into this build that this CPU can run, widest first
/// (e.g. "AVX3", "AVX2", "SSE4", "EMU128"). Not affected by pinning.
std::vector<std::string> simd_targets();

/// The Highway target that dispatch picks now (the widest, or the pinned one).
std::string simd_target();

/// Floats per vector of the kernels that Highway's dispatch runs now (16 AVX-512, 8 AVX2,
/// 4 SSE4 / EMU128, 1 scalar): how a test sees that pinning reached the dispatch tables.
int simd_float_lanes();

/// Makes Highway's dispatch and the own dispatchers use `name` (one of simd_targets()) until
/// called again; "" restores the default choice. Returns false, changing nothing, for any
/// other name. For tests and `dofkit bench --simd`; must not run concurrently with a render.
/// (The few loops compiled as GCC target_clones keep the widest copy: an ifunc is resolved
/// once, at load time. They compute the same bits on every target: core/clones.hpp.)
bool pin_simd_target(const std::string& name);

}  // namespace dofkit::core
