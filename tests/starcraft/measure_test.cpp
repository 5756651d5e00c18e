// Measurements against the thin-lens ground truth (not run in CI: DISABLED_). They produced
// the defaults and the numbers in docs/methods/starcraft.md; run with
//   build-starcraft/test_starcraft --gtest_also_run_disabled_tests --gtest_filter='*Measure*'
// Environment: SC_W (width, default 320), SC_SCENES (comma list, default all), SC_SWEEP=1 to
// sweep the tunable parameters, SC_IMG=dir to write the doc pictures there.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>
#include <vector>

#include "dofkit/render.hpp"
#include "io/image_io.hpp"
#include "metrics/metrics.hpp"
#include "scene/scene.hpp"

using namespace dofkit;

namespace {

std::vector<std::string> scenes_from_env() {
  const char* e = std::getenv("SC_SCENES");
  if (!e) return scene::scene_names();
  std::vector<std::string> out;
  std::stringstream ss(e);
  for (std::string s; std::getline(ss, s, ',');) out.push_back(s);
  return out;
}

int env_int(const char* name, int def) {
  const char* e = std::getenv(name);
  return e ? std::atoi(e) : def;
}

metrics::Scores score(const scene::SceneRender& sr, const std::string& method,
                      const std::map<std::string, std::string>& params, double* ms = nullptr) {
  RenderSettings s;
  s.method = method;
  s.camera = sr.camera;
  s.params = params;
  const auto t0 = std::chrono::steady_clock::now();
  const RenderResult r = render(sr.pinhole, s);
  if (ms) *ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return metrics::compare(sr.ground_truth, r.image, &sr.pinhole.depth);
}

}  // namespace

TEST(StarcraftMeasure, DISABLED_QualityAgainstGroundTruth) {
  const int w = env_int("SC_W", 320);
  const bool sweep = env_int("SC_SWEEP", 0) != 0;
  for (const auto& name : scenes_from_env()) {
    scene::SceneOptions opt;
    opt.width = w;
    opt.height = w * 9 / 16;
    const scene::SceneRender sr = scene::render_scene(name, opt);
    for (const char* m : {"scatter", "reference", "starcraft"}) {
      double ms = 0;
      const auto sc = score(sr, m, {}, &ms);
      std::printf("%-10s %-10s %-40s PSNR %6.2f SSIM %.4f edge %6.2f  (%.0f ms)\n", name.c_str(), m, "defaults",
                  sc.psnr_db, sc.ssim, sc.edge_psnr_db, ms);
    }
    if (!sweep) continue;
    std::vector<std::map<std::string, std::string>> variants = {
        {{"sigma_per_radius", "0.35"}}, {{"sigma_per_radius", "0.4"}}, {{"sigma_per_radius", "0.45"}},
        {{"sigma_per_radius", "0.6"}},  {{"medium_fraction", "0.35"}}, {{"medium_fraction", "0.65"}},
        {{"keep_own_blur", "on"}},      {{"coc_reduce", "max"}},       {{"depth_blur", "0.5"}},
        {{"depth_blur", "2"}},
    };
    // SC_VARIANTS="k=v,k=v;k=v" replaces the list above.
    if (const char* e = std::getenv("SC_VARIANTS")) {
      variants.clear();
      std::stringstream all(e);
      for (std::string one; std::getline(all, one, ';');) {
        std::map<std::string, std::string> v;
        std::stringstream kv(one);
        for (std::string p; std::getline(kv, p, ',');)
          if (auto eq = p.find('='); eq != std::string::npos) v[p.substr(0, eq)] = p.substr(eq + 1);
        variants.push_back(v);
      }
    }
    for (const auto& v : variants) {
      std::string label;
      for (const auto& [k, val] : v) label += k + "=" + val + " ";
      const auto sc = score(sr, "starcraft", v);
      std::printf("%-10s %-10s %-40s PSNR %6.2f SSIM %.4f edge %6.2f\n", name.c_str(), "starcraft", label.c_str(),
                  sc.psnr_db, sc.ssim, sc.edge_psnr_db);
    }
    // The large level's radius relative to the camera's K.
    const double k = std::get<BlurAtInfinity>(sr.camera.model).blur_at_infinity_px;
    for (double f : {0.75, 1.5, 2.0, 3.0}) {
      const auto sc = score(sr, "starcraft", {{"large_radius_px", std::to_string(f * k)}});
      std::printf("%-10s %-10s large_radius_px=%.2f·K %21s PSNR %6.2f SSIM %.4f edge %6.2f\n", name.c_str(),
                  "starcraft", f, "", sc.psnr_db, sc.ssim, sc.edge_psnr_db);
    }
  }
}

namespace {

// 1-plane data (e.g. a level in [0, 1]) as a grey picture, values written as they are.
Image grey(const Image& p, float scale = 1.0f) {
  Image out(p.width(), p.height(), 4, 1.0f);
  for (std::size_t i = 0; i < p.plane_size(); ++i)
    for (int c = 0; c < 3; ++c) out.plane(c)[i] = p.plane(0)[i] * scale;
  return out;
}

void save(const std::string& dir, const std::string& name, const Image& img, bool data = false) {
  io::WriteOptions o;
  o.keep_alpha = false;
  if (data) o.encoding = io::Encoding::linear;
  io::write_image(dir + "/" + name + ".png", img, o);
}

}  // namespace

TEST(StarcraftMeasure, DISABLED_DocPictures) {
  const char* dir_env = std::getenv("SC_IMG");
  ASSERT_NE(dir_env, nullptr) << "set SC_IMG to the output folder";
  const std::string dir = dir_env;
  scene::SceneOptions opt;
  opt.width = 320;
  opt.height = 180;
  const scene::SceneRender sr = scene::render_scene("occluder", opt);
  RenderSettings s;
  s.method = "starcraft";
  s.camera = sr.camera;
  save(dir, "occluder_input", sr.pinhole.color);
  save(dir, "occluder_ground_truth", sr.ground_truth);
  save(dir, "occluder_starcraft", render(sr.pinhole, s).image);
  for (const char* v : {"coc", "used_coc"}) {
    s.debug_view = v;
    save(dir, std::string("occluder_") + v, grey(render(sr.pinhole, s).debug), true);
  }
  for (const char* v : {"medium", "large", "small"}) {
    s.debug_view = v;
    save(dir, std::string("occluder_") + v, render(sr.pinhole, s).debug);
  }
  s.debug_view = "weights";
  {
    const Image wts = render(sr.pinhole, s).debug;  // source, small, medium, large
    Image rgb(wts.width(), wts.height(), 4, 1.0f);
    for (int c = 0; c < 3; ++c) std::copy(wts.plane(c + 1), wts.plane(c + 1) + wts.plane_size(), rgb.plane(c));
    save(dir, "occluder_weights", rgb, true);  // R small, G medium, B large, black = source
  }
  s.debug_view = "blurred_depth";
  {
    Image z = render(sr.pinhole, s).debug;
    for (float& v : z.data()) v = 1.0f / v;  // show 1/z, near = bright
    float mx = 0;
    for (float v : z.data()) mx = std::max(mx, v);
    save(dir, "occluder_blurred_depth", grey(z, 1.0f / mx), true);
  }
  s.debug_view.clear();

  // Transparency (§4.4): a 45 % tinted pane at 1 m over the scene (focus 3 m, so the pane is
  // out of focus). The colour holds the pane composited over the opaque scene; the depth is
  // the opaque scene's.
  Frame f = sr.pinhole;
  Image mask(f.width(), f.height(), 1, 0.0f), zmask(f.width(), f.height(), 1, 1.0f);
  const float tint[3] = {0.9f, 0.85f, 0.3f}, a = 0.45f;
  for (int y = 20; y < 110; ++y)
    for (int x = 180; x < 300; ++x) {
      const bool frame_bar = x < 186 || x >= 294 || y < 26 || y >= 104;  // an opaque-ish frame
      const float aa = frame_bar ? 0.95f : a;
      mask.at(x, y) = 1.0f;
      for (int c = 0; c < 3; ++c) f.color.at(x, y, c) = (1 - aa) * f.color.at(x, y, c) + aa * tint[c];
    }
  save(dir, "pane_input", f.color);
  save(dir, "pane_plain", render(f, s).image);
  save(dir, "pane_masked", render_masked(f, mask, zmask, s).image);
}
