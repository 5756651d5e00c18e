// `dofkit scene shadows --gbuffer` and `dofkit light` with translucent shadow maps (issue 34,
// tiny sizes): the scene writes the maps and names them in lights.json, `dofkit light` applies
// them with no further flag, and maps of the wrong size or without matrices are refused (one
// line naming the file and field, exit 3, no output); `dofkit pipeline --transparency`: the
// key transparency of §5.7 gets depth of field with its own depth over its area.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

#include "cli/cli_run.hpp"
#include "io/image_io.hpp"
#include "io/io_test_util.hpp"
#include "metrics/metrics.hpp"

using dofkit::test::channels_of;
using dofkit::test::CliRun;
using dofkit::test::dofkit_run;
using dofkit::test::ScratchDir;
namespace fs = std::filesystem;

namespace {

dofkit::Image rgb(const dofkit::Image& im) { return dofkit::test::rgb_planes(im); }

}  // namespace

TEST(ShadowCli, SceneMapsAreAppliedWithNoFlagAndBadMapsAreRefused) {
  ScratchDir dir;
  const std::string s = dir / "scene";
  CliRun r = dofkit_run(dir, "scene shadows --out " + s + " --size 96x54 --samples 4 --layers 0 --gbuffer");
  ASSERT_EQ(r.code, 0) << r.err;
  ASSERT_TRUE(fs::exists(s + "/shadow_0.exr"));
  EXPECT_TRUE(fs::exists(s + "/transparency.exr"));  // the glass pane (a key transparency)
  const std::vector<std::string> ch = channels_of(s + "/shadow_0.exr");
  for (const char* c : {"opaque.Z", "translucent.Z", "translucent.R", "translucent.G", "translucent.B"})
    EXPECT_NE(std::find(ch.begin(), ch.end(), c), ch.end()) << c;
  std::ifstream lf(s + "/lights.json");
  const nlohmann::json lj = nlohmann::json::parse(lf);
  ASSERT_TRUE(lj["lights"][0].contains("shadow"));
  EXPECT_EQ(lj["lights"][0]["shadow"]["maps"], "shadow_0.exr");

  const std::string base = "light --gbuffer " + s + "/gbuffer.exr --camera " + s + "/camera.json --lights ";
  const std::string out = dir / "lit.exr";
  r = dofkit_run(dir, base + s + "/lights.json --output " + out);
  ASSERT_EQ(r.code, 0) << r.err;
  // The same lights without the "shadow" entry: no shadows, farther from the tracer.
  nlohmann::json open = lj;
  open["lights"][0].erase("shadow");
  const std::string open_lights = dir / "open.json", open_out = dir / "open.exr";
  std::ofstream(open_lights) << open.dump();
  ASSERT_EQ(dofkit_run(dir, base + open_lights + " --output " + open_out).code, 0);
  const dofkit::Image truth = rgb(dofkit::io::read_color(s + "/lit.exr"));
  const double db = dofkit::metrics::psnr_linear(truth, rgb(dofkit::io::read_color(out)));
  const double db_open = dofkit::metrics::psnr_linear(truth, rgb(dofkit::io::read_color(open_out)));
  std::printf(
      "scene shadows 96x54: dofkit light vs lit.exr %.2f dB with the maps (whole image, shadow edges "
      "included), %.2f dB without\n",
      db, db_open);
  EXPECT_GT(db, db_open + 10);

  // Bad maps: one line naming the file and the field, exit 3, no output.
  const auto refused = [&](nlohmann::json bad, const std::string& mentions) {
    if (bad["lights"][0]["shadow"]["maps"] == "shadow_0.exr")
      bad["lights"][0]["shadow"]["maps"] = s + "/shadow_0.exr";  // the bad file lives elsewhere
    const std::string path = dir / "bad.json", o = dir / "refused.exr";
    std::ofstream(path) << bad.dump();
    const CliRun b = dofkit_run(dir, base + path + " --output " + o);
    EXPECT_EQ(b.code, 3) << b.err;
    EXPECT_EQ(std::count(b.err.begin(), b.err.end(), '\n'), 1) << b.err;
    EXPECT_NE(b.err.find(mentions), std::string::npos) << b.err;
    EXPECT_NE(b.err.find("bad.json"), std::string::npos) << b.err;
    EXPECT_FALSE(fs::exists(o));
  };
  nlohmann::json bad = lj;
  bad["lights"][0]["shadow"]["size_px"] = {256, 512};
  refused(bad, "lights[0].shadow.opaque_depth");
  bad = lj;
  bad["lights"][0]["shadow"].erase("view_matrix");
  refused(bad, "lights[0].shadow.view_matrix: required");
  bad = lj;
  bad["lights"][0]["shadow"].erase("projection_matrix");
  refused(bad, "lights[0].shadow.projection_matrix: required");
  bad = lj;
  bad["lights"][0]["shadow"]["projection_matrix"] = {1, 2, 3};
  refused(bad, "lights[0].shadow.projection_matrix");
  bad = lj;
  bad["lights"][0]["shadow"]["bias_m"] = -1;
  refused(bad, "lights[0].shadow.bias_m");
  bad = lj;
  bad["lights"][0]["shadow"]["translucent_color"] = s + "/lit.exr";  // R, G, B but 96x54, not the map's size
  refused(bad, "lights[0].shadow.translucent_color: " + s + "/lit.exr is 96x54, size_px says 512x512");
  bad = lj;
  bad["lights"][0]["shadow"]["opaque_depth"] = s + "/gbuffer.exr";  // no opaque.Z, no Z of the map's size
  refused(bad, "lights[0].shadow.opaque_depth");
  bad = lj;
  bad["lights"][0]["shadow"]["maps"] = s + "/missing.exr";
  refused(bad, "lights[0].shadow");
  bad = lj;
  bad["lights"][1]["shadow"] = lj["lights"][0]["shadow"];  // the ambient light
  refused(bad, "lights[1].shadow");
}

namespace {

// The pixels of the box [x0, x1) × [y0, y1): RMS difference of R, G, B.
double rms_in(const dofkit::Image& a, const dofkit::Image& b, int x0, int y0, int x1, int y1) {
  double sse = 0;
  int n = 0;
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x)
      for (int c = 0; c < 3; ++c) {
        const double d = static_cast<double>(a.at(x, y, c)) - b.at(x, y, c);
        sse += d * d;
        ++n;
      }
  return std::sqrt(sse / n);
}

}  // namespace

TEST(ShadowCli, PipelineKeyTransparencyGetsItsOwnDepthOfField) {
  ScratchDir dir;
  const std::string s = dir / "scene";
  ASSERT_EQ(dofkit_run(dir, "scene shadows --out " + s + " --size 96x54 --samples 4 --layers 0 --gbuffer").code, 0);
  // A 70 % red pane over x in [30, 62), y in [14, 40) at 1.5 m (in focus); the scene behind it
  // is 3-6 m away (blurred). Premultiplied colour; depth 0 (unused) outside.
  const int w = 96, h = 54;
  std::vector<float> rgba(4 * w * h, 0.0f), z(w * h, 0.0f), clear(4 * w * h, 0.0f);
  for (int y = 14; y < 40; ++y)
    for (int x = 30; x < 62; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * w + x;
      const float a = 0.7f;
      rgba[4 * i] = 0.9f * a;
      rgba[4 * i + 1] = 0.2f * a;
      rgba[4 * i + 2] = 0.2f * a;
      rgba[4 * i + 3] = a;
      z[i] = 1.5f;
    }
  const std::string pane = dir / "pane.exr", pane_z = dir / "pane_z.exr", none = dir / "none.exr";
  dofkit::test::raw_write(pane, w, h, {"R", "G", "B", "A"}, rgba);
  dofkit::test::raw_write(pane_z, w, h, {"Z"}, z);
  dofkit::test::raw_write(none, w, h, {"R", "G", "B", "A"}, clear);
  const std::string args = "pipeline --gbuffer " + s + "/gbuffer.exr --camera " + s + "/camera.json --lights " + s +
                           "/lights.json --ao-method none --focus 1.5 --blur-at-infinity 6 --method lens";
  const std::string key = dir / "key.exr", plain = dir / "plain.exr", stages = dir / "stages";
  CliRun r = dofkit_run(dir, args + " --threads 2 --transparency " + pane + " --transparency-depth " + pane_z +
                                 " --output " + key + " --debug-dir " + stages);
  ASSERT_EQ(r.code, 0) << r.err;
  ASSERT_TRUE(fs::exists(stages + "/composite.exr"));
  // The same composite blurred with the opaque depth only (no re-application).
  r = dofkit_run(dir, "render --color " + stages + "/composite.exr --depth " + s +
                          "/gbuffer.exr --focus 1.5 --blur-at-infinity 6 --method lens --threads 2 --output " + plain);
  ASSERT_EQ(r.code, 0) << r.err;
  const dofkit::Image composite = rgb(dofkit::io::read_color(stages + "/composite.exr"));
  const dofkit::Image k = rgb(dofkit::io::read_color(key)), p = rgb(dofkit::io::read_color(plain));
  // Inside the pane (away from its rim) the pane is in focus: the pass with its depth keeps
  // the composite sharp, the opaque depth blurs it with the scene behind, and the two are
  // blended by the coverage: 0.7 · sharp + 0.3 · blurred.
  const double err_key = rms_in(k, composite, 36, 20, 56, 34), err_plain = rms_in(p, composite, 36, 20, 56, 34);
  dofkit::Image blend = composite;
  for (int y = 20; y < 34; ++y)
    for (int x = 36; x < 56; ++x)
      for (int c = 0; c < 3; ++c) blend.at(x, y, c) = 0.7f * composite.at(x, y, c) + 0.3f * p.at(x, y, c);
  const double err_blend = rms_in(k, blend, 36, 20, 56, 34);
  std::printf(
      "pane interior vs the sharp composite: key transparency %.6f, opaque depth only %.6f (RMS); vs 0.7 "
      "sharp + 0.3 blurred %.2g\n",
      err_key, err_plain, err_blend);
  EXPECT_GT(err_plain, 0.005);  // the scene behind the pane has texture the blur changes
  EXPECT_LT(err_blend, 1e-4);
  // The same bits with one thread.
  const std::string key1 = dir / "key1.exr";
  ASSERT_EQ(dofkit_run(dir, args + " --threads 1 --transparency " + pane + " --transparency-depth " + pane_z +
                                " --output " + key1)
                .code,
            0);
  EXPECT_EQ(rgb(dofkit::io::read_color(key1)).data(), k.data());
  // No coverage: the same bits as without a transparency.
  const std::string with_none = dir / "with_none.exr", without = dir / "without.exr";
  ASSERT_EQ(
      dofkit_run(dir, args + " --transparency " + none + " --transparency-depth " + pane_z + " --output " + with_none)
          .code,
      0);
  ASSERT_EQ(dofkit_run(dir, args + " --output " + without).code, 0);
  EXPECT_EQ(rgb(dofkit::io::read_color(with_none)).data(), rgb(dofkit::io::read_color(without)).data());
  // Bad input: one flag without the other (usage), a covered pixel without depth (exit 3).
  EXPECT_EQ(dofkit_run(dir, args + " --transparency " + pane + " --output " + (dir / "x.exr")).code, 2);
  std::vector<float> hole = z;
  hole[20 * w + 40] = 0;
  const std::string holed = dir / "holed.exr", x = dir / "x.exr";
  dofkit::test::raw_write(holed, w, h, {"Z"}, hole);
  r = dofkit_run(dir, args + " --transparency " + pane + " --transparency-depth " + holed + " --output " + x);
  EXPECT_EQ(r.code, 3) << r.err;
  EXPECT_NE(r.err.find("holed.exr"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(x));
}
