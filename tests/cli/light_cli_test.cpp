// `dofkit scene lights --gbuffer` and `dofkit light` end to end (the built binary, tiny sizes):
// the files, world-space lights through camera.json's view matrix, the lit image against the
// tracer's lit.exr, per-light layers, and bad lights files — one line on stderr, exit 3, no
// output written.
#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "io/image_io.hpp"
#include "cli/cli_run.hpp"
#include "io/io_test_util.hpp"
#include "metrics/metrics.hpp"

using dofkit::test::channels_of;
using dofkit::test::CliRun;
using dofkit::test::dofkit_run;
using dofkit::test::ScratchDir;
namespace fs = std::filesystem;

namespace {

class LightCli : public ::testing::Test {
 protected:
  ScratchDir dir_;
  std::string scene_;
  void SetUp() override {
    scene_ = dir_ / "scene";
    const CliRun r =
        dofkit_run(dir_, "scene lights --out " + scene_ + " --size 96x54 --samples 16 --layers 0 --gbuffer");
    ASSERT_EQ(r.code, 0) << r.err;
  }
  std::string base(const std::string& lights) const {
    return "light --gbuffer " + scene_ + "/gbuffer.exr --camera " + scene_ + "/camera.json --lights " + lights;
  }
  void write(const std::string& path, const std::string& text) const {
    std::ofstream f(path);
    f << text;
  }
  // A failing call: the exit code, one line on stderr naming the file and field, no output.
  void expect_refused(const std::string& lights_text, const std::string& mentions) {
    const std::string lights = dir_ / "bad.json", out = dir_ / "refused.exr";
    write(lights, lights_text);
    const CliRun r = dofkit_run(dir_, base(lights) + " --output " + out);
    EXPECT_EQ(r.code, 3) << lights_text << "\n" << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_NE(r.err.find(mentions), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("bad.json"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out)) << lights_text;
  }
};

dofkit::Image rgb(const dofkit::Image& im) { return dofkit::test::rgb_planes(im); }

}  // namespace

TEST_F(LightCli, LightsTheSceneLikeTheTracer) {
  for (const char* f : {"gbuffer.exr", "camera.json", "lights.json", "lit.exr"})
    EXPECT_TRUE(fs::exists(scene_ + "/" + f)) << f;
  std::ifstream lf(scene_ + "/lights.json");
  const nlohmann::json lj = nlohmann::json::parse(lf);
  EXPECT_EQ(lj["space"], "world");  // turned back into camera space by the view matrix
  const std::string out = dir_ / "lit.exr", layers = dir_ / "layers.exr";
  const CliRun r =
      dofkit_run(dir_, base(scene_ + "/lights.json") + " --output " + out + " --layers-output " + layers + " --stats");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("tiles"), std::string::npos);
  const dofkit::Image lit = rgb(dofkit::io::read_color(out)), truth = rgb(dofkit::io::read_color(scene_ + "/lit.exr"));
  const double db = dofkit::metrics::psnr_linear(truth, lit);
  std::printf("dofkit light vs lit.exr at 96x54: %.2f dB\n", db);
  EXPECT_GE(db, 45.0);
  std::vector<std::string> names = channels_of(layers);
  EXPECT_EQ(names.size(), 3 * lj["lights"].size() + 3);
  EXPECT_NE(std::find(names.begin(), names.end(), "00_key__holds_the_camera_.R"), names.end());
  // brute gives the same file content as tiled.
  const std::string brute = dir_ / "brute.exr";
  ASSERT_EQ(dofkit_run(dir_, base(scene_ + "/lights.json") + " --impl brute --threads 1 --output " + brute).code, 0);
  const dofkit::Image b = rgb(dofkit::io::read_color(brute));
  EXPECT_EQ(b.data(), lit.data());
}

TEST_F(LightCli, RefusesBadLightsFiles) {
  const std::string ok = R"("type": "point", "position_m": [0, 0, -2], "radius_m": 1)";
  expect_refused("{\"lights\": [{" + ok + "}, {\"type\": \"point\", \"position_m\": [0, 0, -2], \"radius_m\": -1}]}",
                 "lights[1].radius_m");
  expect_refused(R"({"lights": [{"type": "point", "position_m": [0, "x", -2], "radius_m": 1}]})",
                 "lights[0].position_m");
  expect_refused(
      R"({"lights": [{"type": "spot", "position_m": [0, 0, 0], "direction": [0, 0, -1], "radius_m": 2, "inner_deg": 30, "outer_deg": 20}]})",
      "lights[0].inner_deg/outer_deg");
  expect_refused(R"({"lights": [{"type": "point", "position_m": [0, 0, -2], "radius_m": 1, "colour": [1, 1, 1]}]})",
                 "unknown key \"colour\"");
  expect_refused(R"({"lights": [{"type": "lamp"}]})", "lights[0].type");
  expect_refused(R"({"lights": [{"type": "point", "position_m": [0, 0, -2], "radius_m": 1e999}]})", "not valid JSON");
  expect_refused(R"({"space": "world", "view_matrix": [2,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1], "lights": []})",
                 "view_matrix");
  std::string many = "{\"lights\": [";
  for (int k = 0; k < 1025; ++k) many += std::string(k ? "," : "") + "{" + ok + "}";
  expect_refused(many + "]}", "more than the limit of 1024");
}

TEST_F(LightCli, WorldLightsNeedAViewMatrix) {
  const std::string lights = dir_ / "world.json", out = dir_ / "out.exr";
  write(lights, R"({"space": "world", "lights": [{"type": "point", "position_m": [0, 0, -2], "radius_m": 1}]})");
  const CliRun r = dofkit_run(
      dir_, "light --gbuffer " + scene_ + "/gbuffer.exr --fov-deg 60 --lights " + lights + " --output " + out);
  EXPECT_EQ(r.code, 3) << r.err;
  EXPECT_NE(r.err.find("view_matrix"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out));
}

TEST_F(LightCli, PipelineWritesEachStage) {
  const std::string lights = scene_ + "/lights.json", stages = dir_ / "stages";
  const std::string args = "pipeline --gbuffer " + scene_ + "/gbuffer.exr --camera " + scene_ +
                           "/camera.json --lights " + lights + " --focus 3.5 --blur-at-infinity 5 --threads 2";
  // --stop-after light with AO off is `dofkit light`'s image, bit for bit.
  const std::string lit = dir_ / "lit.exr", light_only = dir_ / "light_only.exr";
  ASSERT_EQ(dofkit_run(dir_, args + " --ao-method none --stop-after light --output " + lit).code, 0);
  ASSERT_EQ(dofkit_run(dir_, base(lights) + " --output " + light_only).code, 0);
  EXPECT_EQ(rgb(dofkit::io::read_color(lit)).data(), rgb(dofkit::io::read_color(light_only)).data());
  // The whole chain with its stages.
  const std::string final_out = dir_ / "final.exr";
  const CliRun r = dofkit_run(dir_, args + " --output " + final_out + " --debug-dir " + stages);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(fs::exists(final_out));
  EXPECT_TRUE(fs::exists(stages + "/ao.exr"));
  EXPECT_TRUE(fs::exists(stages + "/lit.exr"));
  // AO multiplies only the ambient light: the lit stage is darker than without AO, never brighter.
  const dofkit::Image with_ao = rgb(dofkit::io::read_color(stages + "/lit.exr")),
                      no_ao = rgb(dofkit::io::read_color(lit));
  double sum_with = 0, sum_without = 0;
  for (std::size_t i = 0; i < with_ao.data().size(); ++i) {
    EXPECT_LE(with_ao.data()[i], no_ao.data()[i] * (1 + 1e-6) + 1e-7);
    sum_with += with_ao.data()[i];
    sum_without += no_ao.data()[i];
  }
  EXPECT_LT(sum_with, sum_without);
  // The final image against the lit thin-lens ground truth: a sanity floor.
  const double db = dofkit::metrics::psnr(dofkit::io::read_color(scene_ + "/lit_ground_truth.exr"),
                                          dofkit::io::read_color(final_out));
  std::printf("pipeline (sc2 AO, lens) vs lit_ground_truth at 96x54: %.2f dB\n", db);
  EXPECT_GT(db, 25.0);
  // Without a camera model the dof stage is refused before anything is read or written.
  const CliRun bad = dofkit_run(dir_, "pipeline --gbuffer " + scene_ + "/gbuffer.exr --camera " + scene_ +
                                          "/camera.json --lights " + lights + " --output " + (dir_ / "x.exr"));
  EXPECT_EQ(bad.code, 2);
  EXPECT_FALSE(fs::exists(dir_ / "x.exr"));
}
