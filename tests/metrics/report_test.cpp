// Report helpers: text layout, heat map ramp, tables; and the `dofkit compare` JSON output.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "io/image_io.hpp"
#include "metrics/metrics.hpp"
#include "metrics/report.hpp"

using namespace dofkit;
namespace fs = std::filesystem;

TEST(Report, TextIsDrawnInsideItsBox) {
  Image img(100, 20, 4, 0.0f);
  metrics::draw_text(img, 3, 2, "PSNR 29.4", 2, {1, 1, 1});
  const int w = metrics::text_width("PSNR 29.4", 2), h = metrics::text_height(2);
  EXPECT_EQ(w, 9 * 12 - 2);
  int ink = 0;
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x)
      if (img.at(x, y, 0) > 0) {
        ++ink;
        EXPECT_TRUE(x >= 3 && x < 3 + w && y >= 2 && y < 2 + h) << x << "," << y;
      }
  EXPECT_GT(ink, 100);
  // Lower case is drawn like upper case.
  Image a(40, 10, 3, 0.0f), b(40, 10, 3, 0.0f);
  metrics::draw_text(a, 0, 0, "edge", 1, {1, 1, 1});
  metrics::draw_text(b, 0, 0, "EDGE", 1, {1, 1, 1});
  EXPECT_EQ(a.data(), b.data());
}

TEST(Report, WrapKeepsLinesWithinWidth) {
  const auto lines = metrics::wrap_text("depth (near bright), edge band blue", 60, 1);  // 10 chars
  // 10 characters per line: depth | (near | bright), | edge band | blue
  ASSERT_EQ(lines.size(), 5u);
  EXPECT_EQ(lines[3], "edge band");
  EXPECT_EQ(lines[0], "depth");
  EXPECT_EQ(lines[1], "(near");
  for (const auto& l : lines) EXPECT_LE(metrics::text_width(l, 1), 60);
  EXPECT_EQ(metrics::wrap_text("", 60, 1).size(), 1u);
  EXPECT_EQ(metrics::wrap_text("abcdefghijklmnop", 30, 1)[0], "abcde");
}

TEST(Report, HeatMapRampIsMonotonic) {
  Image err(11, 1, 1);
  for (int x = 0; x <= 10; ++x) err.at(x, 0) = 0.02f * x;
  const Image h = metrics::heat_map(err, 0.2f);
  EXPECT_EQ(h.at(0, 0, 0) + h.at(0, 0, 1) + h.at(0, 0, 2), 0.0f);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(h.at(10, 0, c), 1.0f, 1e-5);
  for (int x = 1; x <= 10; ++x)
    EXPECT_GT(h.at(x, 0, 0) + h.at(x, 0, 1) + h.at(x, 0, 2), h.at(x - 1, 0, 0) + h.at(x - 1, 0, 1) + h.at(x - 1, 0, 2));
}

TEST(Report, MeansAndMarkdown) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<metrics::QualityRow> rows{{"a", "input", 20, 0.5, 19, nan},
                                        {"a", "reference", 30, 0.9, 28, 10},
                                        {"b", "input", 22, 0.7, nan, nan},
                                        {"b", "reference", 32, 0.8, 30, 20}};
  const auto all = metrics::with_means(rows);
  ASSERT_EQ(all.size(), 6u);
  EXPECT_EQ(all[4].scene, "mean");
  EXPECT_EQ(all[4].method, "input");
  EXPECT_DOUBLE_EQ(all[4].psnr_db, 21);
  EXPECT_DOUBLE_EQ(all[4].edge_psnr_db, 19);  // NaN skipped
  EXPECT_TRUE(std::isnan(all[4].time_ms));
  EXPECT_DOUBLE_EQ(all[5].ssim, 0.85);
  EXPECT_DOUBLE_EQ(all[5].time_ms, 15);
  const std::string md = metrics::markdown_table(all);
  EXPECT_NE(md.find("| a | reference | 30.00 | 0.9000 | 28.00 | 10.0 |"), std::string::npos) << md;
  EXPECT_NE(md.find("| **mean** | **input** | 21.00 | 0.6000 | 19.00 | – |"), std::string::npos) << md;
}

TEST(Report, ContactSheetHoldsEveryTile) {
  Image red(20, 12, 4, 1.0f);
  for (std::size_t i = 0; i < red.plane_size(); ++i) red.plane(1)[i] = red.plane(2)[i] = 0.0f;
  std::vector<metrics::SheetCell> cells(3, metrics::SheetCell{"t", red, "c", red});
  const Image s = metrics::contact_sheet("head", cells, 2, 1);
  int red_px = 0;
  for (int y = 0; y < s.height(); ++y)
    for (int x = 0; x < s.width(); ++x) red_px += s.at(x, y, 0) == 1.0f && s.at(x, y, 1) == 0.0f;
  EXPECT_EQ(red_px, 6 * 20 * 12);
}

// `dofkit compare --json` on a pair of files written here. Spawns the built CLI once (it is
// the only way to test the command's output); skipped when the CLI was not built.
TEST(CompareCommand, JsonOutput) {
  const fs::path exe = fs::path(DOFKIT_BINARY_DIR) / "dofkit";
  if (!fs::exists(exe)) GTEST_SKIP() << exe << " not built (DOFKIT_BUILD_CLI=OFF?)";
  const fs::path dir = fs::path(DOFKIT_BINARY_DIR) / "test_compare_cli";
  fs::create_directories(dir);
  const int w = 48, h = 32;
  Image a(w, h, 4, 1.0f), z(w, h, 1);
  for (int c = 0; c < 3; ++c)
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) a.at(x, y, c) = 0.2f + 0.6f * ((x * 3 + y * 5 + c) % 7) / 7.0f;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) z.at(x, y) = x < 24 ? 1.0f : std::numeric_limits<float>::infinity();
  Image b = a;
  b.at(5, 5, 0) += 0.3f;
  io::WriteOptions f32;
  f32.bits = 32;
  io::write_image((dir / "a.exr").string(), a, f32);
  io::write_image((dir / "b.exr").string(), b, f32);
  io::WriteOptions zopt = f32;
  zopt.channel_name = "Z";
  io::write_image((dir / "z.exr").string(), z, zopt);
  const std::string out = (dir / "out.json").string();
  const std::string cmd = exe.string() + " compare " + (dir / "a.exr").string() + " " + (dir / "b.exr").string() +
                          " --depth " + (dir / "z.exr").string() + " --json > " + out;
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  std::ifstream in(out);
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_NEAR(j["psnr_db"].get<double>(), metrics::psnr(a, b), 1e-9);
  EXPECT_NEAR(j["ssim"].get<double>(), metrics::ssim(a, b), 1e-9);
  EXPECT_NEAR(j["rmse_linear"].get<double>(), metrics::rmse_linear(a, b), 1e-9);
  // The changed pixel (5, 5) is 18 px from the depth edge at x = 23|24: outside the band.
  EXPECT_EQ(j["edge_psnr_db"], "inf");
  EXPECT_NEAR(j["edge_fraction"].get<double>(), 26.0 / 48.0, 1e-12);
  EXPECT_EQ(j["width"], w);

  // Identical images: PSNR "inf", SSIM 1. A size mismatch: exit code 3 naming both files.
  ASSERT_EQ(std::system((exe.string() + " compare " + (dir / "a.exr").string() + " " + (dir / "a.exr").string() +
                         " --json > " + out)
                            .c_str()),
            0);
  std::ifstream in2(out);
  const nlohmann::json j2 = nlohmann::json::parse(in2);
  EXPECT_EQ(j2["psnr_db"], "inf");
  EXPECT_EQ(j2["ssim"].get<double>(), 1.0);
  EXPECT_TRUE(j2["edge_psnr_db"].is_null());
  io::write_image((dir / "small.exr").string(), Image(40, 32, 4, 0.5f), f32);
  const std::string err = (dir / "err.txt").string();
  const int rc = std::system(
      (exe.string() + " compare " + (dir / "a.exr").string() + " " + (dir / "small.exr").string() + " 2> " + err)
          .c_str());
  EXPECT_EQ(WEXITSTATUS(rc), 3);
  std::ifstream e(err);
  std::stringstream msg;
  msg << e.rdbuf();
  EXPECT_NE(msg.str().find("small.exr"), std::string::npos) << msg.str();
  EXPECT_NE(msg.str().find("a.exr"), std::string::npos) << msg.str();
}

// `dofkit quality` end to end on one tiny scene (few lens samples: this checks the plumbing,
// not the scores): tables and sheet written, rows for every spec incl. a variant, means.
TEST(QualityCommand, WritesTablesAndSheet) {
  const fs::path exe = fs::path(DOFKIT_BINARY_DIR) / "dofkit";
  if (!fs::exists(exe)) GTEST_SKIP() << exe << " not built (DOFKIT_BUILD_CLI=OFF?)";
  const fs::path dir = fs::path(DOFKIT_BINARY_DIR) / "test_quality_cli";
  fs::remove_all(dir);
  const std::string cmd = exe.string() +
                          " quality --scenes occluder --size 64x36 --samples 4 --threads 2"
                          " --methods input,reference,reference:depth_softness=0.1 --out " +
                          dir.string() + " > " + (fs::path(DOFKIT_BINARY_DIR) / "test_quality_cli.md").string() +
                          " 2>/dev/null";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  EXPECT_TRUE(fs::exists(dir / "occluder.png"));
  EXPECT_TRUE(fs::exists(dir / "quality.md"));
  std::ifstream in(dir / "quality.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  ASSERT_EQ(j["rows"].size(), 6u);  // 3 rows + 3 means
  EXPECT_EQ(j["rows"][0]["method"], "input");
  EXPECT_TRUE(j["rows"][0]["time_ms"].is_null());
  EXPECT_EQ(j["rows"][2]["method"], "reference:depth_softness=0.1");
  EXPECT_GT(j["rows"][1]["time_ms"].get<double>(), 0.0);
  EXPECT_EQ(j["rows"][3]["scene"], "mean");
  // The blurred result is closer to the ground truth than the sharp input.
  EXPECT_GT(j["rows"][1]["psnr_db"].get<double>(), j["rows"][0]["psnr_db"].get<double>());
  const Image sheet = io::read_color((dir / "occluder.png").string());
  EXPECT_GT(sheet.width(), 3 * 64);

  // A bad method name is a usage error (exit 2) and writes nothing.
  const fs::path bad = fs::path(DOFKIT_BINARY_DIR) / "test_quality_cli_bad";
  fs::remove_all(bad);
  const int rc =
      std::system((exe.string() + " quality --methods nosuch --out " + bad.string() + " 2>/dev/null").c_str());
  EXPECT_EQ(WEXITSTATUS(rc), 2);
  EXPECT_FALSE(fs::exists(bad));
}
