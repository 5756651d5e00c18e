// The vulkan backend against the CPU plain passes (the oracle), every technique and variant,
// on every built-in scene at small sizes (odd ones included), validation layers and
// synchronisation validation on (gpu_test_util.hpp).
#include <gtest/gtest.h>

#include <cstdio>

#include "gpu_test_util.hpp"

namespace dofkit::test {
namespace {

struct Case {
  const char* name;
  const char* method;
  std::map<std::string, std::string> params;
  double max_abs;  ///< bound on |gpu − cpu| (see each technique's comment)
};

void run_case(const Case& c, int w, int h) {
  for (const std::string& name : scene::scene_names()) {
    scene::SceneOptions opt;
    opt.width = w;
    opt.height = h;
    opt.threads = 2;
    const scene::SceneRender s = scene::render_pinhole(name, opt);
    RenderSettings rs;
    rs.method = c.method;
    rs.params = c.params;
    rs.camera = s.camera;
    const Parity p = cpu_vs_gpu(s.pinhole, rs);
    std::printf("%s %s %dx%d: %s\n", c.name, name.c_str(), w, h, describe(p).c_str());
    EXPECT_LE(p.max_abs, c.max_abs) << c.name << " on " << name << " " << w << "x" << h << ": " << describe(p);
    EXPECT_GE(p.psnr_db, 50.0) << c.name << " on " << name << " " << w << "x" << h << ": " << describe(p);
  }
}

class GpuParity : public ::testing::TestWithParam<Case> {
 protected:
  void SetUp() override { require_gpu(); }
};

TEST_P(GpuParity, SmallEven) { run_case(GetParam(), 160, 90); }
TEST_P(GpuParity, SmallOdd) { run_case(GetParam(), 161, 91); }

INSTANTIATE_TEST_SUITE_P(
    Methods, GpuParity,
    ::testing::Values(Case{"mcguire_demo", "mcguire", {}, 1e-5},
                      Case{"mcguire_book", "mcguire", {{"variant", "book"}}, 1e-5},
                      Case{"mcguire_g3d", "mcguire", {{"variant", "g3d"}}, 1e-5}, Case{"sterna", "sterna", {}, 1e-5},
                      Case{"sterna_polygon_bicubic",
                           "sterna",
                           {{"bokeh", "polygon"}, {"blades", "7"}, {"near_upsample", "bicubic"}},
                           1e-5},
                      Case{
                          "sterna_per_pixel_karis", "sterna", {{"per_pixel_scale", "on"}, {"firefly", "karis"}}, 1e-5}),
    [](const ::testing::TestParamInfo<Case>& i) { return std::string(i.param.name); });

}  // namespace
}  // namespace dofkit::test
