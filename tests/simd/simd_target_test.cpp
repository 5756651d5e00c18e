// core/simd_target: pinning a SIMD target reaches every dispatcher the tests rely on, so the
// @TARGET runs of the fast-versus-plain tests (tests/CMakeTests.cmake) really run that code.
#include <string>

#include <gtest/gtest.h>

#include "core/simd_target.hpp"

namespace dofkit::core {
namespace {

int lanes_of(const std::string& t) {
  if (t.rfind("AVX3", 0) == 0) return 16;
  if (t == "AVX2") return 8;
  if (t == "SCALAR") return 1;
  return 4;  // SSSE3, SSE4, EMU128 (and the 128-bit targets of other architectures)
}

SimdLevel level_of(const std::string& t) {
  if (t.rfind("AVX3", 0) == 0) return SimdLevel::avx512;
  return t == "AVX2" ? SimdLevel::avx2 : SimdLevel::baseline;
}

TEST(SimdTarget, PinningReachesTheDispatchTables) {
  const std::vector<std::string> all = simd_targets();
  ASSERT_FALSE(all.empty());
  const std::string was = simd_target();  // a DOFKIT_SIMD_TARGET run starts pinned
  for (const std::string& t : all) {
    SCOPED_TRACE(t);
    ASSERT_TRUE(pin_simd_target(t));
    EXPECT_EQ(simd_target(), t);
    EXPECT_EQ(simd_float_lanes(), lanes_of(t));
    EXPECT_EQ(simd_level_cap(), level_of(t));
  }
  // Unpinned: the widest target again, and the own dispatchers uncapped.
  ASSERT_TRUE(pin_simd_target(""));
  EXPECT_EQ(simd_target(), all.front());
  EXPECT_EQ(simd_float_lanes(), lanes_of(all.front()));
  EXPECT_EQ(simd_level_cap(), SimdLevel::avx512);
  // Names this machine cannot run change nothing.
  EXPECT_FALSE(pin_simd_target("NOT_A_TARGET"));
  EXPECT_EQ(simd_target(), all.front());
  ASSERT_TRUE(pin_simd_target(was == all.front() ? std::string() : was));
}

}  // namespace
}  // namespace dofkit::core
