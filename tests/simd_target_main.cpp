// main() of the test executables. With DOFKIT_SIMD_TARGET=NAME (a Highway target name such as
// AVX2, SSE4 or EMU128) every run-time dispatcher is pinned to that target first, so the same
// tests check a narrower code path than the machine would take (core/simd_target.hpp). CTest
// runs the fast-versus-oracle tests that way once per target name in DOFKIT_TEST_SIMD_TARGETS
// (tests/CMakeTests.cmake); on a machine that cannot run a target, or where it is already
// the default, those runs are reported as skipped.
#include <cstdio>
#include <cstdlib>
#include <string>

#include <gtest/gtest.h>

#include "core/simd_target.hpp"

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  const char* env = std::getenv("DOFKIT_SIMD_TARGET");
  const std::string want = env ? env : "";
  if (!want.empty()) {
    const std::vector<std::string> all = dofkit::core::simd_targets();
    std::string list;
    for (const std::string& t : all) list += (list.empty() ? "" : ", ") + t;
    // The line CTest reads as "skipped" (gtest_discover_tests' SKIP_REGULAR_EXPRESSION); no
    // test runs then.
    std::string skip;
    if (!all.empty() && all.front() == want)
      skip = "DOFKIT_SIMD_TARGET=" + want + " is this machine's default target: the unpinned run covers it";
    else if (!dofkit::core::pin_simd_target(want))
      skip = "DOFKIT_SIMD_TARGET=" + want + ": not a target this build can run here (" + list + ")";
    if (!skip.empty()) {
      std::printf("[  SKIPPED ] %s\n", skip.c_str());
      return 0;
    }
    std::printf("dofkit tests: SIMD dispatch pinned to %s (this machine runs %s)\n", want.c_str(), list.c_str());
  }
  return RUN_ALL_TESTS();
}
