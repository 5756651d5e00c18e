// Quality of the layered method against the thin-lens ground truth of the built-in scenes
// occluder and fence, for single-layer (RGB-D) and multi-layer input, with the reference
// method as the best single-layer technique. Floors are set a little below the measured
// values (stated next to each); they catch regressions. Each scene is rendered once and
// every row scored from it.
#include <gtest/gtest.h>

#include <cstdio>
#include <map>
#include <string>

#include "dofkit/render.hpp"
#include "metrics/metrics.hpp"
#include "scene/scene.hpp"

namespace {

using namespace dofkit;

struct Row {
  double psnr, edge;
};

Row score(const scene::SceneRender& s, const Frame& input, const std::string& method, const char* psf = nullptr) {
  RenderSettings rs;
  rs.method = method;
  rs.camera = s.camera;
  if (psf) rs.params["psf"] = psf;
  const RenderResult r = render(input, rs);
  const metrics::Scores m = metrics::compare(s.ground_truth, r.image, &s.pinhole.depth);
  return {m.psnr_db, m.edge_psnr_db};
}

struct Measured {
  Row single, multi;            // psf=gaussian (S&W's recursive Gaussians)
  Row disc_single, disc_multi;  // psf=disc
  Row multi_default;            // no parameters (psf=auto: disc for multi-layer input)
  Row reference;
};

const Measured& measure(const std::string& name) {
  static std::map<std::string, Measured> cache;
  if (auto it = cache.find(name); it != cache.end()) return it->second;
  scene::SceneOptions opt;
  opt.width = 320;
  opt.height = 180;
  opt.layers = 4;
  opt.samples = 128;  // ground-truth noise floor well above the scores measured here
  const scene::SceneRender s = scene::render_scene(name, opt);
  Frame single = s.pinhole;
  single.layer_color.clear();
  single.layer_depth.clear();
  Measured m;
  m.single = score(s, single, "layered", "gaussian");
  m.multi = score(s, s.pinhole, "layered", "gaussian");
  m.disc_single = score(s, single, "layered", "disc");
  m.disc_multi = score(s, s.pinhole, "layered", "disc");
  m.multi_default = score(s, s.pinhole, "layered");
  m.reference = score(s, single, "reference");
  std::printf(
      "%s: gaussian single %.2f dB (edge %.2f), multi %.2f (edge %.2f); disc single %.2f (edge %.2f), "
      "multi %.2f (edge %.2f); reference %.2f (edge %.2f)\n",
      name.c_str(), m.single.psnr, m.single.edge, m.multi.psnr, m.multi.edge, m.disc_single.psnr, m.disc_single.edge,
      m.disc_multi.psnr, m.disc_multi.edge, m.reference.psnr, m.reference.edge);
  return cache[name] = m;
}

// psf=gaussian. Measured (320x180, 128 ground-truth samples, scenes of 4735d48, after the fix
// that keeps exactly-in-focus fragments out of the first back layer): occluder — single
// 35.18 dB (edge 33.63), multi 35.57 dB (edge 34.62). (Before the fix: 32.47 / 33.20 edge.)
TEST(LayeredQuality, Occluder) {
  const Measured& m = measure("occluder");
  EXPECT_GT(m.single.psnr, 34.9);
  EXPECT_GT(m.single.edge, 33.3);
  EXPECT_GT(m.multi.psnr, 35.2);
  EXPECT_GT(m.multi.edge, 34.3);
}

// psf=gaussian. Measured: fence (thicker, darker bars since 4735d48) — single 28.03 dB (edge
// 28.02), multi 29.28 dB (edge 29.27); the fence's edge band covers almost the whole frame.
TEST(LayeredQuality, Fence) {
  const Measured& m = measure("fence");
  EXPECT_GT(m.single.psnr, 27.7);
  EXPECT_GT(m.single.edge, 27.7);
  EXPECT_GT(m.multi.psnr, 28.9);
  EXPECT_GT(m.multi.edge, 28.9);
}

// psf=disc (matte band 1/4). Measured: occluder single 35.57 dB (edge 34.25), multi 35.70 dB
// (edge 35.21).
TEST(LayeredQuality, DiscOccluder) {
  const Measured& m = measure("occluder");
  EXPECT_GT(m.disc_single.psnr, 35.2);
  EXPECT_GT(m.disc_single.edge, 33.9);
  EXPECT_GT(m.disc_multi.psnr, 35.4);
  EXPECT_GT(m.disc_multi.edge, 34.9);
}

// psf=disc. Measured: fence single 32.53 dB (edge 32.52), multi 38.63 dB (edge 38.62).
TEST(LayeredQuality, DiscFence) {
  const Measured& m = measure("fence");
  EXPECT_GT(m.disc_single.psnr, 32.2);
  EXPECT_GT(m.disc_single.edge, 32.2);
  EXPECT_GT(m.disc_multi.psnr, 38.3);
  EXPECT_GT(m.disc_multi.edge, 38.3);
}

// Issue 7's target: with multi-layer input (default parameters: psf=auto picks the disc),
// beat every single-layer technique, the reference included, in edge PSNR. Measured:
// occluder 35.21 vs reference 33.61 dB (+1.60), fence 38.62 vs 32.03 dB (+6.59). With
// psf=gaussian it is met on occluder (34.62) but not on fence (29.27).
TEST(LayeredQuality, MultiLayerBeatsReferenceAtEdges) {
  for (const char* name : {"occluder", "fence"}) {
    const Measured& m = measure(name);
    EXPECT_EQ(m.multi_default.edge, m.disc_multi.edge) << name;  // auto = disc for multi-layer input
    EXPECT_GT(m.multi_default.edge, m.reference.edge) << name;
  }
}

}  // namespace
