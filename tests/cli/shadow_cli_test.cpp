// `dofkit scene shadows --gbuffer` and `dofkit light` with translucent shadow maps (issue 34,
// tiny sizes): the scene writes the maps and names them in lights.json, `dofkit light` applies
// them with no further flag, and maps of the wrong size or without matrices are refused (one
// line naming the file and field, exit 3, no output).
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

dofkit::Image rgb(const dofkit::Image& im) {
  dofkit::Image o(im.width(), im.height(), 3);
  std::copy(im.data().begin(), im.data().begin() + 3 * im.plane_size(), o.data().begin());
  return o;
}

}  // namespace

TEST(ShadowCli, SceneMapsAreAppliedWithNoFlagAndBadMapsAreRefused) {
  ScratchDir dir;
  const std::string s = dir / "scene";
  CliRun r = dofkit_run(dir, "scene shadows --out " + s + " --size 96x54 --samples 4 --layers 0 --gbuffer");
  ASSERT_EQ(r.code, 0) << r.err;
  ASSERT_TRUE(fs::exists(s + "/shadow_0.exr"));
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
