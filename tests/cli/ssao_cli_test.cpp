// `dofkit scene --gbuffer`, `dofkit ssao`, `dofkit quality --effect ao` and `dofkit bench
// --effect ao` end to end (the built binary, tiny sizes): the files and their channels, and
// bad input — one line on stderr, exit 2 (usage) or 3 (bad input), no output written.
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

using dofkit::test::channels_of;
using dofkit::test::CliRun;
using dofkit::test::dofkit_run;
using dofkit::test::ScratchDir;
namespace fs = std::filesystem;

namespace {

// A tiny AO scene with its G-buffer, once per test binary.
class SsaoCli : public ::testing::Test {
 protected:
  ScratchDir dir_;
  std::string scene_;
  void SetUp() override {
    scene_ = dir_ / "scene";
    const CliRun r = dofkit_run(
        dir_, "scene ao_corner --out " + scene_ + " --size 64x36 --samples 1 --layers 0 --gbuffer --ao-rays 16");
    ASSERT_EQ(r.code, 0) << r.err;
  }
  std::string base() const {
    return "ssao --depth " + scene_ + "/gbuffer.exr --normals " + scene_ + "/gbuffer.exr --camera " + scene_ +
           "/camera.json --radius 0.5";
  }
  // A failing call: the exit code, one line on stderr, and no output file.
  void expect_refused(const std::string& args, int code, const std::string& mentions) {
    const std::string out = dir_ / "refused.exr";
    const CliRun r = dofkit_run(dir_, args + " --output " + out);
    EXPECT_EQ(r.code, code) << args << "\n" << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_NE(r.err.find(mentions), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out)) << args;
  }
};

}  // namespace

TEST_F(SsaoCli, SceneWritesTheGBufferCameraAndAo) {
  std::vector<std::string> names = channels_of(scene_ + "/gbuffer.exr");
  std::sort(names.begin(), names.end());
  EXPECT_EQ(names,
            (std::vector<std::string>{"N.X", "N.Y", "N.Z", "Z", "albedo.B", "albedo.G", "albedo.R", "emissive.B",
                                      "emissive.G", "emissive.R", "gloss", "specular.B", "specular.G", "specular.R"}));
  EXPECT_EQ(channels_of(scene_ + "/ao.exr"), (std::vector<std::string>{"Y"}));
  std::ifstream f(scene_ + "/camera.json");
  const nlohmann::json j = nlohmann::json::parse(f);
  EXPECT_EQ(j["width"], 64);
  EXPECT_EQ(j["height"], 36);
  EXPECT_NEAR(j["hfov_deg"].get<double>(), 55.0, 1e-12);
  EXPECT_NEAR(j["f_px"].get<double>(), 32 / std::tan(27.5 * M_PI / 180), 1e-9);
  EXPECT_EQ(j["ao_radius_m"], 0.5);
  for (const char* key : {"clip_near_m", "clip_far_m", "pixel_centre", "normal_space", "depth"})
    EXPECT_TRUE(j.contains(key)) << key;
}

TEST_F(SsaoCli, WritesTheAoAndADebugView) {
  for (const char* method : {"sc2", "gtao"}) {
    const std::string out = dir_ / "ao.exr", dbg = dir_ / "raw.exr";
    const CliRun r = dofkit_run(
        dir_, base() + " --method " + method + " --output " + out + " --debug-view raw " + "--debug-output " + dbg);
    ASSERT_EQ(r.code, 0) << r.err;
    const dofkit::Image ao = dofkit::io::read_mask(out);
    EXPECT_EQ(ao.width(), 64);
    for (float v : ao.data()) {
      EXPECT_GE(v, 0.0f);
      EXPECT_LE(v, 1.0f);
    }
    EXPECT_TRUE(fs::exists(dbg));
  }
  // Without normals the tool says it reconstructs them.
  const CliRun r = dofkit_run(dir_, "ssao --depth " + scene_ +
                                        "/depth.exr --fov-deg 55 --radius 0.5 --preset tuned "
                                        "--output " +
                                        (dir_ / "ao2.png"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("reconstructed"), std::string::npos);
}

TEST_F(SsaoCli, BadInputGetsOneLineAndNoOutput) {
  const std::string depth = "ssao --depth " + scene_ + "/gbuffer.exr";
  // Missing normals file, and normals of another size.
  expect_refused(depth + " --normals " + (dir_ / "none.exr") + " --fov-deg 55 --radius 0.5", 3, "none.exr");
  const CliRun small = dofkit_run(
      dir_, "scene ao_corner --out " + (dir_ / "small") + " --size 32x18 --samples 1 --layers 0 --gbuffer --ao-rays 1");
  ASSERT_EQ(small.code, 0) << small.err;
  expect_refused(depth + " --normals " + (dir_ / "small/gbuffer.exr") + " --fov-deg 55 --radius 0.5", 3,
                 "does not match");
  // Non-finite or missing radius; field of view given twice or not at all.
  for (const char* r : {"inf", "nan", "0", "-1"}) expect_refused(depth + " --fov-deg 55 --radius " + r, 2, "--radius");
  expect_refused(depth + " --fov-deg 55", 2, "--radius");
  expect_refused(depth + " --radius 0.5", 2, "field of view");
  expect_refused(depth + " --fov-deg 55 --camera " + scene_ + "/camera.json --radius 0.5", 2, "only one");
  // A camera file without a field of view, or for another size.
  {
    std::ofstream f(dir_ / "nofov.json");
    f << R"({"width": 64, "height": 36})";
  }
  expect_refused(depth + " --camera " + (dir_ / "nofov.json") + " --radius 0.5", 3, "field of view");
  {
    std::ofstream f(dir_ / "other.json");
    f << R"({"hfov_deg": 55, "width": 640, "height": 360})";
  }
  expect_refused(depth + " --camera " + (dir_ / "other.json") + " --radius 0.5", 3, "does not match");
  // Unknown parameter, preset with gtao, output folder missing.
  expect_refused(depth + " --fov-deg 55 --radius 0.5 --set nope=1", 2, "nope");
  expect_refused(depth + " --fov-deg 55 --radius 0.5 --method gtao --preset tuned", 2, "preset");
  const CliRun r = dofkit_run(dir_, depth + " --fov-deg 55 --radius 0.5 --output " + (dir_ / "no/such/ao.exr"));
  EXPECT_EQ(r.code, 3) << r.err;
  // A failing run leaves an existing output untouched.
  {
    std::ofstream f(dir_ / "keep.exr");
    f << "old";
  }
  const CliRun k = dofkit_run(
      dir_, depth + " --normals " + (dir_ / "none.exr") + " --fov-deg 55 --radius 0.5 --output " + (dir_ / "keep.exr"));
  EXPECT_EQ(k.code, 3);
  std::ifstream kept(dir_ / "keep.exr");
  std::string content;
  kept >> content;
  EXPECT_EQ(content, "old");
}

TEST_F(SsaoCli, QualityAndBenchRunTheAoMethods) {
  const CliRun q = dofkit_run(dir_, "quality --effect ao --scenes ao_corner --size 48x27 --ao-rays 8 --out " +
                                        (dir_ / "q") + " --methods sc2,gtao:slices=2");
  ASSERT_EQ(q.code, 0) << q.err;
  EXPECT_TRUE(fs::exists(dir_ / "q/ao_quality.md"));
  std::ifstream f(dir_ / "q/ao_quality.json");
  const nlohmann::json j = nlohmann::json::parse(f);
  int rows = 0;
  for (const auto& r : j["rows"]) rows += r["scene"] == "ao_corner r=0.5" ? 1 : 0;
  EXPECT_EQ(rows, 3);  // mean AO, sc2, gtao:slices=2
  const CliRun b = dofkit_run(dir_, "bench --effect ao --size 40x24 --iterations 1 --threads 1 --json");
  ASSERT_EQ(b.code, 0) << b.err;
  const nlohmann::json rowsb = nlohmann::json::parse(b.out);
  ASSERT_EQ(rowsb.size(), 3u);
  EXPECT_EQ(rowsb[0]["method"], "copy");
  EXPECT_EQ(rowsb[1]["method"], "sc2");
  EXPECT_EQ(rowsb[2]["method"], "gtao");
}
