// The validation the parity tests run under is real: a frame recorded without one of its
// barriers must be reported by synchronisation validation (lavapipe computes the right numbers
// without it, so only the layer can tell), and the render that caused it throws.
#include <gtest/gtest.h>

#include <algorithm>

#include "gpu_test_util.hpp"

namespace dofkit::test {
namespace {

RenderSettings mcguire_settings(const scene::SceneRender& s) {
  RenderSettings rs;
  rs.method = "mcguire";
  rs.camera = s.camera;
  rs.backend = Backend::vulkan;
  return rs;
}

TEST(GpuValidation, MissingBarrierIsCaught) {
  DOFKIT_REQUIRE_GPU();
  scene::SceneOptions opt;
  opt.width = 96;
  opt.height = 64;
  const scene::SceneRender s = scene::render_pinhole("occluder", opt);
  Renderer r(mcguire_settings(s));
  r.render(s.pinhole);  // clean
  // Dispatch 1 (the horizontal blur) reads what dispatch 0 (pack) wrote: without the barrier
  // in between that is a read-after-write hazard.
  gpu::testing::drop_barrier(1);
  std::string what;
  try {
    r.render(s.pinhole);
  } catch (const Error& e) {
    what = e.what();
  }
  gpu::testing::drop_barrier(-1);
  EXPECT_NE(what.find("SYNC-HAZARD-READ"), std::string::npos) << "message: " << what;
  r.render(s.pinhole);  // clean again: nothing left over
}

TEST(GpuValidation, UnsupportedMethodIsAUsageError) {
  DOFKIT_REQUIRE_GPU();
  const std::vector<MethodInfo> all = methods();
  if (std::none_of(all.begin(), all.end(), [](const MethodInfo& m) { return m.name == "reference"; }))
    GTEST_SKIP() << "built without the reference method (DOFKIT_ONLY_METHODS)";
  RenderSettings rs;
  rs.method = "reference";
  rs.backend = Backend::vulkan;
  try {
    Renderer r(rs);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::usage);
    EXPECT_NE(std::string(e.what()).find("no GPU shaders"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace dofkit::test
