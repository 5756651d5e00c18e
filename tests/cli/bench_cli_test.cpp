// `dofkit bench --json`: the keys issue 8 names, the copy baseline row, and the ratio.
// (Spawns the binary: bench re-invokes itself for every measurement. No timing is asserted.)
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <sys/wait.h>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/simd_target.hpp"
#include "io/image_io.hpp"
#include "io/io_test_util.hpp"
#include "scene/bench_frame.hpp"

using dofkit::test::ScratchDir;

namespace {

// `dofkit bench ARGS --json` (stderr dropped), parsed; an empty list, with a failure recorded,
// if the command fails.
nlohmann::json bench_json(const ScratchDir& dir, const std::string& args) {
  const std::string out = (dir.path() / "bench.json").string();
  const std::string cmd = std::string(DOFKIT_BINARY_DIR) + "/dofkit bench " + args + " --json >" + out + " 2>/dev/null";
  if (std::system(cmd.c_str()) != 0) {
    ADD_FAILURE() << "failed: " << cmd;
    return nlohmann::json::array();
  }
  std::ifstream f(out);
  std::stringstream ss;
  ss << f.rdbuf();
  return nlohmann::json::parse(ss.str());
}

}  // namespace

TEST(BenchCli, JsonListsOneRowPerMethodAndSizeWithTheCopyBaseline) {
  ScratchDir dir;
  const nlohmann::json rows =
      bench_json(dir, "--size 48x32 --size 40x24 --methods sterna,mcguire:variant=book --threads 1 --iterations 1");
  ASSERT_TRUE(rows.is_array());
  ASSERT_EQ(rows.size(), 6u);  // per size: copy, sterna, mcguire:variant=book
  const char* sizes[2][2] = {{"48", "32"}, {"40", "24"}};
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const nlohmann::json& r = rows[i];
    for (const char* key : {"method", "width", "height", "threads", "median_ms", "min_ms", "mpix_per_s", "peak_rss_mb",
                            "ratio_to_copy", "cpu_ms"})
      ASSERT_TRUE(r.contains(key)) << "row " << i << " lacks " << key;
    EXPECT_EQ(std::to_string(r["width"].get<int>()), sizes[i / 3][0]);
    EXPECT_EQ(std::to_string(r["height"].get<int>()), sizes[i / 3][1]);
    EXPECT_EQ(r["threads"].get<int>(), 1);
    EXPECT_LE(r["min_ms"].get<double>(), r["median_ms"].get<double>());
    EXPECT_GT(r["median_ms"].get<double>(), 0.0);
    EXPECT_GT(r["peak_rss_mb"].get<double>(), 0.0);
    EXPECT_GE(r["cpu_ms"].get<double>(), 0.0);
    EXPECT_FALSE(r.contains("passes")) << "row " << i << ": passes without --passes";
  }
  for (int s = 0; s < 2; ++s) {
    const nlohmann::json& copy = rows[3 * s];
    EXPECT_EQ(copy["method"], "copy");
    EXPECT_EQ(copy["ratio_to_copy"].get<double>(), 1.0);
    EXPECT_EQ(rows[3 * s + 1]["method"], "sterna");
    EXPECT_EQ(rows[3 * s + 2]["method"], "mcguire:variant=book");
    for (int k = 1; k <= 2; ++k) {
      const nlohmann::json& r = rows[3 * s + k];
      EXPECT_NEAR(r["ratio_to_copy"].get<double>(), r["median_ms"].get<double>() / copy["median_ms"].get<double>(),
                  1e-9 * r["ratio_to_copy"].get<double>());
    }
  }
}

TEST(BenchCli, RejectsAnUnknownMethodWithOneLine) {
  ScratchDir dir;
  const std::string err = (dir.path() / "err.txt").string();
  const std::string cmd = std::string(DOFKIT_BINARY_DIR) +
                          "/dofkit bench --size 16x16 --methods nosuch --iterations 1 2>" + err + " >/dev/null";
  const int status = std::system(cmd.c_str());
  EXPECT_NE(status, 0);
  std::ifstream f(err);
  std::string line;
  std::getline(f, line);
  EXPECT_NE(line.find("nosuch"), std::string::npos) << line;
}

// --simd: the rows name the target their kernels ran; one the machine does not run is a usage
// error that lists those it does.
TEST(BenchCli, SimdPinsTheTargetAndNamesItInEveryRow) {
  const std::vector<std::string> targets = dofkit::core::simd_targets();
  ASSERT_FALSE(targets.empty());
  ScratchDir dir;
  for (const std::string& want : {std::string(), targets.back()}) {
    SCOPED_TRACE(want);
    const nlohmann::json rows =
        bench_json(dir, "--size 40x24 --methods mcguire,sterna " + (want.empty() ? "" : "--simd " + want + " ") +
                            "--threads 1 --iterations 1");
    ASSERT_EQ(rows.size(), 3u);
    for (const nlohmann::json& r : rows) EXPECT_EQ(r["simd"], want.empty() ? targets.front() : want) << r.dump();
  }
  const std::string err = (dir.path() / "err.txt").string();
  const std::string cmd = std::string(DOFKIT_BINARY_DIR) +
                          "/dofkit bench --size 16x16 --methods mcguire --simd NEON4 " + "--iterations 1 2>" + err +
                          " >/dev/null";
  const int status = std::system(cmd.c_str());
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 2);
  std::ifstream f(err);
  std::string line, rest;
  std::getline(f, line);
  EXPECT_NE(line.find("--simd NEON4"), std::string::npos) << line;
  EXPECT_NE(line.find(targets.front()), std::string::npos) << line;
  EXPECT_FALSE(std::getline(f, rest)) << "more than one line: " << rest;
}

// --passes: every method row carries its passes (render()'s steps, the method, its passes under
// its name), each inside the frame it was timed in; the copy row carries none (and rows of runs
// without the flag none either: JsonListsOneRowPerMethodAndSizeWithTheCopyBaseline).
TEST(BenchCli, PassesListEachMethodsPassesWithinItsFrame) {
  ScratchDir dir;
  const nlohmann::json rows =
      bench_json(dir, "--size 64x36 --methods mcguire,sterna --threads 1 --iterations 3 --passes");
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_FALSE(rows[0].contains("passes"));  // copy
  for (const auto& [i, pass] : {std::pair<int, const char*>{1, "mcguire/horizontal"}, {2, "sterna/gather"}}) {
    const nlohmann::json& r = rows[i];
    ASSERT_TRUE(r.contains("passes")) << r.dump();
    const std::string method = r["method"];
    std::vector<std::string> names;
    for (const nlohmann::json& p : r["passes"]) {
      names.push_back(p["pass"]);
      EXPECT_GE(p["min_ms"].get<double>(), 0.0);
      EXPECT_LE(p["min_ms"].get<double>(), p["median_ms"].get<double>());
      // Each pass is timed inside its frame, so its median cannot exceed the frame's.
      EXPECT_LE(p["median_ms"].get<double>(), r["median_ms"].get<double>()) << p.dump();
    }
    for (const std::string want : {std::string("coc map"), method, std::string(pass)})
      EXPECT_NE(std::find(names.begin(), names.end(), want), names.end()) << want << " in " << r["passes"].dump();
  }
}

TEST(BenchCli, WriteFrameWritesTheTimedFrameAndItsCameraFlags) {
  ScratchDir dir;
  const std::string out = (dir.path() / "flags.txt").string();
  const std::string cmd = std::string(DOFKIT_BINARY_DIR) + "/dofkit bench --size 64x36 --write-frame " +
                          (dir.path() / "f").string() + " >" + out + " 2>/dev/null";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  std::ifstream f(out);
  std::string line;
  std::getline(f, line);
  // K = 1.5 % and the clamp 3 % of the width.
  EXPECT_EQ(line, "--focus 4 --blur-at-infinity 0.96 --max-coc 1.92");
  const dofkit::Frame want = dofkit::scene::bench_frame(64, 36);
  const dofkit::Image color = dofkit::io::read_color((dir.path() / "f/color.exr").string());
  ASSERT_TRUE(color.same_size(want.color));
  EXPECT_EQ(color.data(), want.color.data());
  const dofkit::Image depth = dofkit::io::read_depth((dir.path() / "f/depth.exr").string(), {});
  EXPECT_EQ(depth.data(), want.depth.data());
}
