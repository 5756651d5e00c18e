// Measurement harness (not part of the normal run): scores parameter sets of the mcguire
// method against the thin-lens ground truth of the built-in scenes, caching the ground truth
// in $MCGUIRE_CACHE (default /tmp/mcguire_gt). Used to resolve the items of docs/methods/mcguire.md "Resolved uncertain
// items" and to fill the quality table in docs/methods/mcguire.md. Run with
//   MCGUIRE_CONFIGS="variant=demo;variant=demo,double_coc=on" \
//   test_mcguire --gtest_also_run_disabled_tests --gtest_filter=*Measure*
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include "dofkit/render.hpp"
#include "metrics/metrics.hpp"
#include "scene/scene.hpp"

using namespace dofkit;

namespace {

std::string env(const char* k, const char* def) {
  const char* v = std::getenv(k);
  return v && *v ? v : def;
}

bool load(const std::string& path, Image& img, int w, int h, int c) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  img = Image(w, h, c);
  in.read(reinterpret_cast<char*>(img.data().data()), static_cast<std::streamsize>(img.data().size() * sizeof(float)));
  return static_cast<bool>(in);
}
void save(const std::string& path, const Image& img) {
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(img.data().data()),
            static_cast<std::streamsize>(img.data().size() * sizeof(float)));
}

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, sep))
    if (!item.empty()) out.push_back(item);
  return out;
}

}  // namespace

TEST(McguireMeasure, DISABLED_Measure) {
  const std::string cache = env("MCGUIRE_CACHE", "/tmp/mcguire_gt");
  std::system(("mkdir -p " + cache).c_str());
  const int w = std::stoi(env("MCGUIRE_W", "320")), h = std::stoi(env("MCGUIRE_H", "180"));
  const auto scenes = split(env("MCGUIRE_SCENES", "occluder,fence,ground,highlights,portrait,sky"), ',');
  const auto configs = split(env("MCGUIRE_CONFIGS", "variant=book;variant=demo;variant=g3d"), ';');
  for (const std::string& name : scenes) {
    scene::SceneOptions opt;
    opt.width = w;
    opt.height = h;
    scene::SceneRender s = scene::render_pinhole(name, opt);
    const std::string gt_path = cache + "/" + name + "_" + std::to_string(w) + "x" + std::to_string(h) + ".bin";
    // The pinhole frame is cached with the ground truth so the two always come from the same
    // build of the scenes.
    Image gt;
    if (!load(gt_path, gt, w, h, 4) || !load(gt_path + ".rgba", s.pinhole.color, w, h, 4) ||
        !load(gt_path + ".z", s.pinhole.depth, w, h, 1)) {
      s = scene::render_scene(name, opt);
      gt = s.ground_truth;
      save(gt_path, gt);
      save(gt_path + ".rgba", s.pinhole.color);
      save(gt_path + ".z", s.pinhole.depth);
    }
    if (env("MCGUIRE_CHECK", "")[0]) {  // cached ground truth against a fresh low-sample one
      scene::SceneOptions o2 = opt;
      o2.samples = 32;
      const scene::SceneRender f = scene::render_scene(name, o2);
      std::printf("check %s: gt psnr %.2f, pinhole psnr %.2f\n", name.c_str(), metrics::psnr(gt, f.ground_truth),
                  metrics::psnr(s.pinhole.color, f.pinhole.color));
    }
    const metrics::Scores in = metrics::compare(gt, s.pinhole.color, &s.pinhole.depth);
    std::printf("%-10s %-40s %6.2f %6.4f %6.2f\n", name.c_str(), "input", in.psnr_db, in.ssim, in.edge_psnr_db);
    for (const std::string& cfg : configs) {
      RenderSettings rs;
      rs.method = env("MCGUIRE_METHOD", "mcguire");
      rs.camera = s.camera;
      for (const std::string& kv : split(cfg, ',')) {
        const auto eq = kv.find('=');
        rs.params[kv.substr(0, eq)] = kv.substr(eq + 1);
      }
      const RenderResult r = render(s.pinhole, rs);
      const metrics::Scores sc = metrics::compare(gt, r.image, &s.pinhole.depth);
      std::printf("%-10s %-40s %6.2f %6.4f %6.2f\n", name.c_str(), cfg.c_str(), sc.psnr_db, sc.ssim, sc.edge_psnr_db);
    }
  }
}
