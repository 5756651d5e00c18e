// Quality of `sterna` against the thin-lens ground truth of the built-in scenes, and the
// measurements quoted in docs/methods/sterna.md (DISABLED_ tests: run them with
//   build/test_sterna --gtest_also_run_disabled_tests --gtest_filter='*Measure*').
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <ctime>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <string>

#include "scene/bench_frame.hpp"
#include "dofkit/render.hpp"
#include "io/image_io.hpp"
#include "metrics/metrics.hpp"
#include "scene/scene.hpp"

using namespace dofkit;

namespace {

scene::SceneRender small_scene(const std::string& name, int w, int h, int samples, int blades = 0, double rot = 0) {
  scene::SceneOptions o;
  o.width = w;
  o.height = h;
  o.samples = samples;
  o.aperture.blades = blades;
  // sterna's own rotation_deg turns clockwise on screen, the shared one counter-clockwise.
  o.aperture.rotation_deg = -rot;
  return scene::render_scene(name, o);
}

RenderResult run_sterna(const scene::SceneRender& s, std::map<std::string, std::string> params, int threads = 0) {
  RenderSettings rs;
  rs.method = "sterna";
  rs.camera = s.camera;
  rs.params = std::move(params);
  rs.threads = threads;
  return render(s.pinhole, rs);
}

metrics::Scores score(const scene::SceneRender& s, const Image& img) {
  return metrics::compare(s.ground_truth, img, &s.pinhole.depth);
}

}  // namespace

// Floors measured at 160x90 with 128 lens samples per pixel (the ground truth's own noise is
// far below these errors). Each floor is ~0.3 dB / 0.01 below the measured value (comment).
TEST(SternaQuality, OccluderCircleFloor) {
  const auto s = small_scene("occluder", 160, 90, 128);
  const auto in = score(s, s.pinhole.color);
  const auto def = score(s, run_sterna(s, {}).image);
  const auto pps = score(s, run_sterna(s, {{"per_pixel_scale", "on"}}).image);
  std::printf(
      "occluder 160x90: input %.2f dB | sterna %.2f dB SSIM %.4f edge %.2f | per_pixel %.2f dB SSIM %.4f edge %.2f\n",
      in.psnr_db, def.psnr_db, def.ssim, def.edge_psnr_db, pps.psnr_db, pps.ssim, pps.edge_psnr_db);
  EXPECT_GT(def.psnr_db, in.psnr_db + 3.0);
  EXPECT_GT(def.psnr_db, 24.3);  // measured 24.64 dB
  EXPECT_GT(def.ssim, 0.69);     // measured 0.705
  EXPECT_GT(pps.psnr_db, 24.7);  // measured 25.01 dB
  EXPECT_GT(pps.ssim, 0.73);     // measured 0.740
}

TEST(SternaQuality, HighlightsHexagonFloor) {
  const auto s = small_scene("highlights", 160, 90, 128, 6, 0);
  const auto in = score(s, s.pinhole.color);
  const auto circ = score(s, run_sterna(s, {}).image);
  const auto hex = score(s, run_sterna(s, {{"bokeh", "polygon"}, {"blades", "6"}}).image);
  std::printf(
      "highlights hex 160x90: input %.2f dB | circle kernel %.2f dB SSIM %.4f | hexagon kernel %.2f dB SSIM %.4f edge "
      "%.2f\n",
      in.psnr_db, circ.psnr_db, circ.ssim, hex.psnr_db, hex.ssim, hex.edge_psnr_db);
  // Worse than the unblurred input in PSNR: the max fill brightens every HDR emitter's bokeh
  // (energy +18 %) and the near emitters' blend mask is the square of the separable near-CoC
  // dilation (docs/methods/sterna.md, artifacts). SSIM, which weighs structure, improves.
  EXPECT_GT(hex.psnr_db, 16.3);  // measured 16.63 dB (input 21.55 dB)
  EXPECT_GT(hex.ssim, 0.71);     // measured 0.722
  EXPECT_GT(hex.ssim, in.ssim);
}

// ---------------------------------------------------------------------------------------
// Measurements for the documentation (not run by default).

TEST(SternaQuality, DISABLED_MeasureCircleAndHexagon) {
  const int w = 320, h = 180;
  for (const char* name : {"occluder", "highlights"})
    for (int blades : {0, 6}) {
      const auto s = small_scene(name, w, h, 256, blades, 0);
      std::map<std::string, std::string> shape;
      if (blades) shape = {{"bokeh", "polygon"}, {"blades", "6"}};
      const auto in = score(s, s.pinhole.color);
      std::printf("%-10s %-7s input                 %6.2f dB  SSIM %.4f  edge %6.2f dB\n", name,
                  blades ? "hexagon" : "circle", in.psnr_db, in.ssim, in.edge_psnr_db);
      for (const auto& extra : std::vector<std::map<std::string, std::string>>{
               {}, {{"per_pixel_scale", "on"}}, {{"near_upsample", "bicubic"}}, {{"firefly", "karis"}}}) {
        auto p = shape;
        p.insert(extra.begin(), extra.end());
        const auto sc = score(s, run_sterna(s, p).image);
        const std::string label = extra.empty() ? "default" : extra.begin()->first + "=" + extra.begin()->second;
        std::printf("%-10s %-7s %-21s %6.2f dB  SSIM %.4f  edge %6.2f dB\n", name, blades ? "hexagon" : "circle",
                    label.c_str(), sc.psnr_db, sc.ssim, sc.edge_psnr_db);
      }
    }
}

namespace {

// Frame k of a camera pan: the 4x pinhole render resampled to 1x with the camera moved by
// k/4 px. `box`: 4x4 box filter (anti-aliased input); otherwise point sampling (a highlight
// smaller than a pixel blinks on and off: the HDR fireflies of an aliased renderer). Depth
// takes the nearest of the footprint.
Frame pan_frame(const Frame& hi, int k, int w, int h, bool box) {
  Frame f;
  f.color = Image(w, h, 4);
  f.depth = Image(w, h, 1);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const int n = box ? 4 : 1, o = box ? 0 : 2;
      float zmin = std::numeric_limits<float>::infinity();
      for (int c = 0; c < 4; ++c) {
        float s = 0;
        for (int j = 0; j < n; ++j)
          for (int i = 0; i < n; ++i) s += hi.color.at(4 * x + i + o + k, 4 * y + j + o, c);
        f.color.at(x, y, c) = s / (n * n);
      }
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) zmin = std::min(zmin, hi.depth.at(4 * x + i + o + k, 4 * y + j + o));
      f.depth.at(x, y) = zmin;
    }
  return f;
}

double mean_abs_diff(const Image& a, const Image& b) {
  double s = 0;
  long n = 0;
  for (int c = 0; c < 3; ++c)
    for (int y = 8; y < a.height() - 8; ++y)
      for (int x = 8; x < a.width() - 8; ++x) {
        s += std::abs(a.at(x, y, c) - b.at(x, y, c));
        ++n;
      }
  return s / n;
}

double mean_rgb(const Image& a) {
  double e = 0;
  for (int ch = 0; ch < 3; ++ch)
    for (std::size_t i = 0; i < a.plane_size(); ++i) e += a.plane(ch)[i];
  return e / (3.0 * a.plane_size());
}

}  // namespace

TEST(SternaQuality, DISABLED_MeasureFireflyFlicker) {
  // The highlights scene at 320x180 panned by ¼ px per frame (8 frames). Flicker = mean over
  // consecutive frames of the mean |frame difference| (linear RGB, HDR), reported next to
  // the same figure for the input; part of it is the legitimate motion.
  const int w = 320, h = 180, frames = 8;
  scene::SceneOptions o;
  o.width = 4 * w + 4 * frames;
  o.height = 4 * h;
  const auto hi = scene::render_pinhole("highlights", o);
  // Same camera as the 1x scene (K scales with the width).
  scene::SceneOptions o1;
  o1.width = w;
  o1.height = h;
  const auto d = scene::scene_defaults("highlights", o1);
  CameraModel cam;
  cam.model = BlurAtInfinity{d.focus_m, d.blur_at_infinity_px};
  for (bool box : {true, false}) {
    std::vector<Frame> f;
    for (int k = 0; k < frames; ++k) f.push_back(pan_frame(hi.pinhole, k, w, h, box));
    double in = 0;
    for (int k = 1; k < frames; ++k) in += mean_abs_diff(f[k].color, f[k - 1].color) / (frames - 1);
    std::printf("%s input: flicker %.4f  mean %.4f\n", box ? "anti-aliased" : "aliased     ", in, mean_rgb(f[0].color));
    for (const char* ff : {"off", "karis"}) {
      RenderSettings rs;
      rs.method = "sterna";
      rs.camera = cam;
      rs.params = {{"firefly", ff}};
      std::vector<Image> out;
      for (const Frame& fr : f) out.push_back(render(fr, rs).image);
      double fl = 0;
      for (int k = 1; k < frames; ++k) fl += mean_abs_diff(out[k], out[k - 1]) / (frames - 1);
      std::printf("%s firefly=%-5s: flicker %.4f  mean %.4f\n", box ? "anti-aliased" : "aliased     ", ff, fl,
                  mean_rgb(out[0]));
    }
  }
}

namespace {

// Writes a colour image as an 8-bit sRGB PNG (over black) for the docs; 1-plane images are
// written as grey with `gain`.
void write_png(const std::string& path, const Image& img, float gain = 1.0f) {
  Image out(img.width(), img.height(), 3);
  for (int c = 0; c < 3; ++c)
    for (int y = 0; y < img.height(); ++y)
      for (int x = 0; x < img.width(); ++x) out.at(x, y, c) = gain * img.at(x, y, img.channels() == 1 ? 0 : c);
  io::write_image(path, out);
}

}  // namespace

TEST(SternaQuality, DISABLED_WriteDocImages) {
  const std::string dir = std::string(DOFKIT_SOURCE_DIR) + "/docs/img/sterna/";
  {
    const auto s = small_scene("occluder", 320, 180, 0);
    write_png(dir + "occluder_input.png", s.pinhole.color);
    write_png(dir + "occluder_ground_truth.png", s.ground_truth);
    write_png(dir + "occluder_sterna.png", run_sterna(s, {}).image);
    write_png(dir + "occluder_sterna_per_pixel.png", run_sterna(s, {{"per_pixel_scale", "on"}}).image);
    for (const char* v : {"near_coc", "far_coc", "near_coc_dilated", "near", "far", "near_fill", "far_fill"}) {
      RenderSettings rs;
      rs.method = "sterna";
      rs.camera = s.camera;
      rs.debug_view = v;
      write_png(dir + "occluder_view_" + v + ".png", render(s.pinhole, rs).debug);
    }
  }
  {
    const auto s = small_scene("highlights", 320, 180, 0, 6, 0);
    write_png(dir + "highlights_hex_ground_truth.png", s.ground_truth);
    write_png(dir + "highlights_hex_sterna.png", run_sterna(s, {{"bokeh", "polygon"}, {"blades", "6"}}).image);
    write_png(dir + "highlights_hex_sterna_karis.png",
              run_sterna(s, {{"bokeh", "polygon"}, {"blades", "6"}, {"firefly", "karis"}}).image);
  }
  {
    // A single HDR point far behind focus through 5-blade, rotated and anamorphic kernels.
    for (const auto& [label, p] : std::vector<std::pair<std::string, std::map<std::string, std::string>>>{
             {"circle", {}},
             {"pentagon", {{"bokeh", "polygon"}, {"blades", "5"}}},
             {"hexagon_rot15", {{"bokeh", "polygon"}, {"blades", "6"}, {"rotation_deg", "15"}}},
             {"anamorphic", {{"anamorphic", "0.6"}}}}) {
      Frame f;
      f.color = Image(96, 96, 4, 0.0f);
      for (int y = 0; y < 96; ++y)
        for (int x = 0; x < 96; ++x) f.color.at(x, y, 3) = 1.0f;
      for (int c = 0; c < 3; ++c) f.color.at(48, 48, c) = 60.0f;
      f.depth = Image(96, 96, 1, std::numeric_limits<float>::infinity());
      RenderSettings rs;
      rs.method = "sterna";
      rs.camera.model = BlurAtInfinity{2.0, 24.0};
      rs.params = p;
      write_png(dir + "point_" + label + ".png", render(f, rs).image);
    }
  }
}

TEST(SternaQuality, DISABLED_MeasureTime1080p) {
  // The frame of `dofkit bench` (focus 4 m, K = 1.5 % of the width, clamp 3 %), timed as
  // process CPU time with one thread so that a loaded machine does not distort it.
  const int w = 1920, h = 1080;
  const Frame f = scene::bench_frame(w, h);
  for (const auto& p : std::vector<std::map<std::string, std::string>>{{},
                                                                       {{"bokeh", "polygon"}},
                                                                       {{"per_pixel_scale", "on"}},
                                                                       {{"firefly", "karis"}},
                                                                       {{"near_upsample", "bicubic"}}}) {
    RenderSettings rs;
    rs.method = "sterna";
    rs.camera.model = BlurAtInfinity{4.0, 0.015 * w};
    rs.camera.max_coc_px = 0.03 * w;
    rs.params = p;
    rs.threads = 1;
    std::vector<double> ms;
    for (int i = 0; i < 5; ++i) {
      timespec a, b;
      clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &a);
      const RenderResult r = render(f, rs);
      clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &b);
      ms.push_back((b.tv_sec - a.tv_sec) * 1e3 + (b.tv_nsec - a.tv_nsec) * 1e-6);
    }
    std::sort(ms.begin(), ms.end());
    std::printf("1920x1080 1 thread %-22s CPU %.1f ms (median of 5, includes the CoC map)\n",
                p.empty() ? "default" : (p.begin()->first + "=" + p.begin()->second).c_str(), ms[2]);
  }
}
