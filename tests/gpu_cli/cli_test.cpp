// The vulkan backend through the CLI: render, bench rows, and the one-line errors of a machine
// without a (usable) Vulkan device. The commands run with DOFKIT_VK_VALIDATION=1 (any
// validation message fails them).
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "gpu/gpu_test_util.hpp"
#include "io/image_io.hpp"
#include "io/io_test_util.hpp"

namespace dofkit::test {
namespace {

struct CmdResult {
  int code = -1;
  std::string out, err;
};

CmdResult dofkit_cmd(const ScratchDir& dir, const std::string& env, const std::string& args) {
  const std::string out = (dir.path() / "stdout.txt").string(), err = (dir.path() / "stderr.txt").string();
  const std::string cmd = "DOFKIT_VK_VALIDATION=1 " + env + " " + std::string(DOFKIT_BINARY_DIR) + "/dofkit " + args +
                          " >" + out + " 2>" + err;
  CmdResult r;
  const int status = std::system(cmd.c_str());
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  auto slurp = [](const std::string& p) {
    std::ifstream f(p);
    std::stringstream ss;
    ss << f.rdbuf();
    return ss.str();
  };
  r.out = slurp(out);
  r.err = slurp(err);
  return r;
}

int lines(const std::string& s) {
  int n = 0;
  for (char c : s) n += c == '\n';
  return n;
}

// A small scene written as colour + depth EXRs.
void write_scene(const ScratchDir& dir) {
  scene::SceneOptions opt;
  opt.width = 97;
  opt.height = 61;
  const scene::SceneRender s = scene::render_pinhole("occluder", opt);
  io::write_image((dir.path() / "c.exr").string(), s.pinhole.color);
  io::WriteOptions d;
  d.channel_name = "Z";
  io::write_image((dir.path() / "z.exr").string(), s.pinhole.depth, d);
}

TEST(GpuCli, RenderMatchesTheCpu) {
  DOFKIT_REQUIRE_GPU();
  ScratchDir dir;
  write_scene(dir);
  const std::string p = dir.path().string();
  for (const char* method : {"mcguire", "sterna", "starcraft"}) {
    const std::string common = "render --color " + p + "/c.exr --depth " + p +
                               "/z.exr --focus 3 --blur-at-infinity 6 "
                               "--method " +
                               method + " --set impl=plain --bits 32 --output ";
    const CmdResult cpu = dofkit_cmd(dir, "", common + p + "/cpu.exr");
    ASSERT_EQ(cpu.code, 0) << cpu.err;
    const CmdResult gpu = dofkit_cmd(dir, "", common + p + "/gpu.exr --backend vulkan");
    ASSERT_EQ(gpu.code, 0) << gpu.err;
    const Parity q =
        parity(io::read_color((dir.path() / "cpu.exr").string()), io::read_color((dir.path() / "gpu.exr").string()));
    EXPECT_LE(q.max_abs, 1e-3) << method << ": " << describe(q);
  }
}

TEST(GpuCli, BenchRowsNameBackendAndDevice) {
  DOFKIT_REQUIRE_GPU();
  ScratchDir dir;
  const CmdResult r = dofkit_cmd(
      dir, "", "bench --backend vulkan --size 48x32 --methods mcguire,starcraft --iterations 1 --passes --json");
  ASSERT_EQ(r.code, 0) << r.err;
  const nlohmann::json rows = nlohmann::json::parse(r.out);
  ASSERT_EQ(rows.size(), 4u);  // RGBA16F copy, RGBA32F copy, mcguire, starcraft
  EXPECT_EQ(rows[0]["method"], "copy-rgba16f");
  EXPECT_EQ(rows[1]["method"], "copy-rgba32f");
  EXPECT_EQ(rows[2]["method"], "mcguire");
  for (const auto& row : rows) {
    EXPECT_EQ(row["backend"], "vulkan");
    EXPECT_EQ(row["device"], gpu::selected_device().name);
    EXPECT_GT(row["median_ms"].get<double>(), 0.0);
    EXPECT_LE(row["min_ms"].get<double>(), row["median_ms"].get<double>());
    EXPECT_TRUE(row.contains("ratio_to_copy"));
  }
  for (int i : {2, 3}) {
    ASSERT_TRUE(rows[i].contains("passes"));
    EXPECT_GE(rows[i]["passes"].size(), 4u);
    double sum = 0;
    for (const auto& pass : rows[i]["passes"]) sum += pass["median_ms"].get<double>();
    EXPECT_GT(sum, 0.0);
  }
}

TEST(GpuCli, NoDeviceIsAOneLineErrorAndTheCpuStillWorks) {
  DOFKIT_REQUIRE_GPU();
  ScratchDir dir;
  write_scene(dir);
  const std::string p = dir.path().string();
  const std::string args = "render --color " + p + "/c.exr --depth " + p +
                           "/z.exr --focus 3 --blur-at-infinity 6 "
                           "--method mcguire --output " +
                           p + "/out.exr";
  // No driver at all (the loader finds no ICD), and a device name that matches none.
  for (const char* env : {"VK_ICD_FILENAMES=/nonexistent/icd.json VK_DRIVER_FILES=/nonexistent/icd.json",
                          "DOFKIT_VK_DEVICE=no-such-device"}) {
    const CmdResult r = dofkit_cmd(dir, env, args + " --backend vulkan");
    EXPECT_EQ(r.code, 1) << env << ": " << r.err;
    EXPECT_EQ(lines(r.err), 1) << env << ": " << r.err;
    EXPECT_NE(r.err.find(std::string(env).find("DOFKIT") == 0 ? "DOFKIT_VK_DEVICE" : "no Vulkan device"),
              std::string::npos)
        << r.err;
    EXPECT_FALSE(std::filesystem::exists(p + "/out.exr"));
    const CmdResult cpu = dofkit_cmd(dir, env, args);
    EXPECT_EQ(cpu.code, 0) << env << ": " << cpu.err;
    std::filesystem::remove(p + "/out.exr");
  }
}

}  // namespace
}  // namespace dofkit::test
