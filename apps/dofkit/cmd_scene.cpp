// `dofkit scene`: renders a built-in scene's pinhole RGB-D input (+ layers) and its thin-lens
// ground truth, and writes them with the parameters needed to reproduce the camera in
// `dofkit render`.
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <mutex>
#include <sstream>

#include <nlohmann/json.hpp>

#include "budget.hpp"
#include "cli_common.hpp"
#include "commands.hpp"
#include "core/parallel.hpp"
#include "quality_run.hpp"
#include "dofkit/error.hpp"
#include "io/atomic_write.hpp"
#include "io/exr_direct.hpp"
#include "io/image_io.hpp"
#include "io/atomic_write.hpp"
#include "io/layers_io.hpp"
#include "light_common.hpp"
#include "scene/raytracer.hpp"
#include "scene/scene.hpp"

namespace dofkit::cli {

namespace {

// The built-in scenes' shadow maps: side in texels and depth bias in metres (about two texels
// at the scenes' farthest receivers).
constexpr int kSceneShadowMapPx = 512;
constexpr double kSceneShadowBiasM = 0.03;

struct SceneArgs {
  std::string name;
  std::string out;
  std::string size = "640x360";
  int samples = 0;
  double focus_m = 0;
  double blur_px = 0;
  int layers = 4;
  ApertureFlags aperture;
  std::uint64_t seed = 1;
  int threads = 0;
  bool list = false;
  BudgetFlags budget;
  bool gbuffer = false;
  double ao_radius_m = 0;
  int ao_rays = 4096;
};

// Shortest decimal that reads back as the same double (for flags that must reproduce exactly).
std::string exact(double v) {
  char buf[64];
  for (int p = 1; p <= 17; ++p) {
    std::snprintf(buf, sizeof buf, "%.*g", p, v);
    if (std::strtod(buf, nullptr) == v) break;
  }
  return buf;
}

void run_scene(const SceneArgs& a) {
  if (a.list) {
    for (const auto& n : scene::scene_names()) std::cout << n << "\t" << scene::scene_description(n) << "\n";
    for (const auto& n : scene::ao_scene_names()) std::cout << n << "\t" << scene::scene_description(n) << "\n";
    for (const auto& n : scene::light_scene_names()) std::cout << n << "\t" << scene::scene_description(n) << "\n";
    return;
  }
  if (a.name.empty()) throw_usage("scene: a scene NAME is required (see dofkit scene --list)");
  if (a.out.empty()) throw_usage("scene: --out DIR is required");
  a.budget.apply();
  if (!(a.ao_radius_m >= 0) || !std::isfinite(a.ao_radius_m))
    throw_usage("--ao-radius: must be a finite number of metres >= 0 (0 = the scene's own, for an AO scene)");
  if (a.ao_rays < 1 || a.ao_rays > (1 << 20)) throw_usage("--ao-rays: must be 1..1048576");

  scene::SceneOptions opt;
  parse_size(a.size, "--size", opt.width, opt.height);
  opt.samples = a.samples;
  opt.focus_m = a.focus_m;
  opt.blur_at_infinity_px = a.blur_px;
  opt.layers = a.layers;
  opt.aperture = a.aperture.build();
  opt.seed = a.seed;
  opt.threads = a.threads;
  // Validates the name and every option before anything is rendered or written.
  const scene::SceneDefaults d = scene::scene_defaults(a.name, opt);
  // The size is an image like any other: within --max-pixels and, with its layers, the memory.
  const long long px = static_cast<long long>(opt.width) * opt.height;
  if (px > io::pixel_budget())
    throw_usage("--size " + a.size + ": " + std::to_string(px) + " pixels, more than the limit of " +
                std::to_string(io::pixel_budget()) + " (--max-pixels)");
  check_memory(scene_bytes(opt.width, opt.height, opt.layers),
               "scene " + a.name + " at " + a.size +
                   (a.layers ? " with " + std::to_string(a.layers) + " layers" : std::string()),
               "use a smaller --size or fewer --layers");

  std::error_code ec;
  const std::filesystem::path out_dir(a.out);
  if (std::filesystem::exists(out_dir, ec) && !std::filesystem::is_directory(out_dir, ec))
    throw_bad_input("--out " + a.out + ": exists and is not a folder");
  std::filesystem::create_directories(a.out, ec);
  if (ec || !std::filesystem::is_directory(a.out))
    throw_bad_input("--out: cannot create directory '" + a.out + "': " + ec.message());

  // Progress line on stderr, only for a terminal (logs and pipes stay clean).
  const bool tty = isatty(fileno(stderr)) != 0;
  std::mutex mu;
  int last_pct = -1;
  if (tty) {
    opt.progress = [&](double f) {
      const int pct = static_cast<int>(f * 100);
      std::lock_guard<std::mutex> lock(mu);
      if (pct == last_pct) return;
      last_pct = pct;
      std::fprintf(stderr, "\rdofkit scene %s: ground truth %3d%%", a.name.c_str(), pct);
      std::fflush(stderr);
    };
  }
  const auto t0 = std::chrono::steady_clock::now();
  const scene::SceneRender r = scene::render_scene(a.name, opt);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (tty) std::fprintf(stderr, "\rdofkit scene %s: done in %.1f s          \n", a.name.c_str(), seconds);

  const std::filesystem::path dir(a.out);
  io::WriteOptions colour;
  colour.bits = 32;
  io::WriteOptions depth = colour;
  depth.channel_name = "Z";
  io::write_image((dir / "color.exr").string(), r.pinhole.color, colour);
  io::write_image((dir / "depth.exr").string(), r.pinhole.depth, depth);
  if (a.layers > 0) io::write_layers_exr((dir / "layers.exr").string(), r.pinhole);
  io::write_image((dir / "ground_truth.exr").string(), r.ground_truth, colour);

  // G-buffer, camera and AO (docs/gbuffer.md).
  const scene::Scene built = scene::build_scene(a.name);
  const double ao_radius = a.ao_radius_m > 0 ? a.ao_radius_m : built.ao_radius_m;
  const bool write_ao = a.ao_radius_m > 0 || (a.gbuffer && built.ao_radius_m > 0);
  std::vector<std::string> extra_files;
  if (a.gbuffer) {
    const scene::LensCamera cam = scene::camera_for(built, opt);
    scene::GBuffer g;
    core::with_threads(a.threads, [&] { g = scene::render_gbuffer(built, cam); });
    const std::vector<io::exr::OutChannel> ch = {{"Z", g.z.plane(0)},
                                                 {"N.X", g.normal.plane(0)},
                                                 {"N.Y", g.normal.plane(1)},
                                                 {"N.Z", g.normal.plane(2)},
                                                 {"albedo.R", g.albedo.plane(0)},
                                                 {"albedo.G", g.albedo.plane(1)},
                                                 {"albedo.B", g.albedo.plane(2)},
                                                 {"specular.R", g.specular.plane(0)},
                                                 {"specular.G", g.specular.plane(1)},
                                                 {"specular.B", g.specular.plane(2)},
                                                 {"gloss", g.gloss.plane(0)},
                                                 {"emissive.R", g.emissive.plane(0)},
                                                 {"emissive.G", g.emissive.plane(1)},
                                                 {"emissive.B", g.emissive.plane(2)}};
    const std::string gpath = (std::filesystem::path(a.out) / "gbuffer.exr").string();
    io::write_atomically(gpath, [&](const std::string& tmp) {
      io::exr::write_scanline(tmp, gpath, cam.width, cam.height, ch, false, "zip");
    });
    nlohmann::json c;
    c["width"] = cam.width;
    c["height"] = cam.height;
    c["hfov_deg"] = cam.hfov_deg;
    c["vfov_deg"] = 2 * std::atan(0.5 * cam.height / cam.f_px()) * 180 / 3.14159265358979323846;
    c["f_px"] = cam.f_px();
    c["principal_point_px"] = {0.5 * cam.width, 0.5 * cam.height};
    c["pixel_centre"] = "pixel (x, y) has its centre at (x + 0.5, y + 0.5), y growing downward";
    c["ray"] =
        "pixel (x, y) sees along (X, Y, Z) = ((x + 0.5 - W/2) / f_px, -(y + 0.5 - H/2) / f_px, -1) in camera "
        "space (X right, Y up, Z towards the camera); a point at depth z is that ray times z";
    c["depth"] = "planar depth along the optical axis (-Z in camera space), metres; +inf where no surface is hit";
    c["normal_space"] = "camera space: X right, Y up, Z towards the camera; unit length; 0 on the background";
    c["clip_near_m"] = 0.05;
    c["clip_far_m"] = 1000.0;
    c["clip_note"] = "nominal planes for a rasteriser's projection; the ray tracer itself does not clip";
    c["pitch_deg"] = built.pitch_deg;
    c["view_matrix"] = scene::world_to_camera(built);
    c["view_matrix_note"] =
        "world to camera space, row-major 4x4; the scene's level world frame: X right, Y up, Z towards a level "
        "camera at the origin (the camera only pitches down by pitch_deg)";
    if (write_ao) c["ao_radius_m"] = ao_radius;
    const std::string cpath = (std::filesystem::path(a.out) / "camera.json").string();
    io::write_atomically(cpath, [&](const std::string& tmp) {
      std::ofstream f(tmp, std::ios::binary);
      f << c.dump(2) << "\n";
      f.close();
      if (!f) throw_bad_input(cpath + ": cannot write");
    });
    extra_files.push_back("gbuffer.exr");
    extra_files.push_back("camera.json");
    if (!built.lights.empty()) {
      // The scene's lights (world space, so that `dofkit light --camera camera.json` turns them
      // back) and the tracer's forward-lit ground truth at the exact hits (docs/lighting.md).
      // Shadow-casting lights get their §5.8 maps rendered from the light (docs/lighting.md)
      // and named in lights.json, so that `dofkit light` applies them with no further flag.
      std::vector<Light> file_lights = built.lights;
      std::vector<std::string> shadow_files(file_lights.size());
      for (std::size_t k = 0; k < file_lights.size(); ++k) {
        if (!file_lights[k].casts_shadows) continue;
        ShadowMaps maps;
        core::with_threads(a.threads, [&] {
          maps = scene::render_shadow_maps(built, file_lights[k], kSceneShadowMapPx, kSceneShadowBiasM);
        });
        shadow_files[k] = "shadow_" + std::to_string(k) + ".exr";
        write_shadow_maps((std::filesystem::path(a.out) / shadow_files[k]).string(), maps);
        file_lights[k].shadow = std::make_shared<const ShadowMaps>(std::move(maps));
        extra_files.push_back(shadow_files[k]);
      }
      const std::string lpath = (std::filesystem::path(a.out) / "lights.json").string();
      const nlohmann::json lj = lights_json(file_lights, true, scene::world_to_camera(built), shadow_files);
      io::write_atomically(lpath, [&](const std::string& tmp) {
        std::ofstream f(tmp, std::ios::binary);
        f << lj.dump(2) << "\n";
        f.close();
        if (!f) throw_bad_input(lpath + ": cannot write");
      });
      Image lit;
      core::with_threads(a.threads, [&] { lit = scene::render_lit(built, cam); });
      io::WriteOptions rgb;
      rgb.bits = 32;
      io::write_image((std::filesystem::path(a.out) / "lit.exr").string(), lit, rgb);
      // The pipeline's ground truth: the lit scene through the same thin lens and samples as
      // ground_truth.exr (docs/lighting.md).
      scene::Scene lit_scene = built;
      lit_scene.lit = true;
      Image lit_gt;
      core::with_threads(a.threads, [&] { lit_gt = scene::render_thin_lens(lit_scene, cam, d.samples, opt.seed, {}); });
      io::write_image((std::filesystem::path(a.out) / "lit_ground_truth.exr").string(), lit_gt, colour);
      extra_files.push_back("lights.json");
      extra_files.push_back("lit.exr");
      extra_files.push_back("lit_ground_truth.exr");
      // Key transparencies (§5.7): premultiplied lit colour, coverage and depth, the input of
      // `dofkit pipeline --transparency` (docs/lighting.md).
      if (std::any_of(built.prims.begin(), built.prims.end(),
                      [](const scene::Primitive& p) { return p.camera_alpha < 1; })) {
        Image t;
        core::with_threads(a.threads, [&] { t = scene::render_transparency(built, cam); });
        const std::string tpath = (std::filesystem::path(a.out) / "transparency.exr").string();
        const std::vector<io::exr::OutChannel> tch = {
            {"R", t.plane(0)}, {"G", t.plane(1)}, {"B", t.plane(2)}, {"A", t.plane(3)}, {"Z", t.plane(4)}};
        io::write_atomically(tpath, [&](const std::string& tmp) {
          io::exr::write_scanline(tmp, tpath, cam.width, cam.height, tch, false, "zip");
        });
        extra_files.push_back("transparency.exr");
      }
    }
  }
  if (write_ao) {
    if (tty) std::fprintf(stderr, "dofkit scene %s: ambient occlusion, %d rays per pixel\n", a.name.c_str(), a.ao_rays);
    const scene::LensCamera cam = scene::camera_for(built, opt);
    Image ao;
    core::with_threads(a.threads, [&] { ao = scene::render_ao(built, cam, ao_radius, a.ao_rays, a.seed); });
    io::WriteOptions one;
    one.bits = 32;
    one.channel_name = "Y";
    io::write_image((std::filesystem::path(a.out) / "ao.exr").string(), ao, one);
    extra_files.push_back("ao.exr");
  }

  std::ostringstream flags;
  flags << "--focus " << exact(d.focus_m) << " --blur-at-infinity " << exact(d.blur_at_infinity_px);
  if (!a.aperture.text().empty()) flags << " " << a.aperture.text();
  nlohmann::json j;
  j["scene"] = a.name;
  j["description"] = scene::scene_description(a.name);
  j["width"] = opt.width;
  j["height"] = opt.height;
  j["hfov_deg"] = d.hfov_deg;
  j["focus_m"] = d.focus_m;
  j["blur_at_infinity_px"] = d.blur_at_infinity_px;
  j["coc_model"] = "r(z) = blur_at_infinity_px * (focus_m / z - 1), px at this width";
  j["samples"] = d.samples;
  j["layers"] = a.layers;
  j["blades"] = opt.aperture.blades;
  j["blade_rotation_deg"] = opt.aperture.rotation_deg;
  j["blade_curvature"] = opt.aperture.curvature;
  j["anamorphic"] = opt.aperture.anamorphic;
  j["cat_eye"] = opt.aperture.cat_eye;
  j["aperture_flags"] = a.aperture.text();
  j["seed"] = a.seed;
  j["render_flags"] = flags.str();
  j["ground_truth_seconds"] = seconds;
  j["files"] = {{"color", "color.exr"}, {"depth", "depth.exr"}, {"ground_truth", "ground_truth.exr"}};
  if (a.layers > 0) j["files"]["layers"] = "layers.exr";
  if (a.gbuffer) {
    j["files"]["gbuffer"] = "gbuffer.exr";
    j["files"]["camera"] = "camera.json";
    if (!built.lights.empty()) {
      j["files"]["lights"] = "lights.json";
      j["files"]["lit"] = "lit.exr";
      j["files"]["lit_ground_truth"] = "lit_ground_truth.exr";
      if (std::find(extra_files.begin(), extra_files.end(), "transparency.exr") != extra_files.end())
        j["files"]["transparency"] = "transparency.exr";
    }
  }
  if (write_ao) {
    j["files"]["ao"] = "ao.exr";
    j["ao_radius_m"] = ao_radius;
    j["ao_rays"] = a.ao_rays;
  }
  // Written through a temporary file + rename like every other output (atomic_write.hpp: an
  // unpredictable name created with O_EXCL, never through a symlink planted in the folder).
  const std::string params_path = (dir / "params.json").string();
  io::write_atomically(params_path, [&](const std::string& temp) {
    std::FILE* f = std::fopen(temp.c_str(), "wb");
    if (!f) throw_bad_input("--out: cannot write '" + params_path + "'");
    const std::string s = j.dump(2) + "\n";
    const bool ok = std::fwrite(s.data(), 1, s.size(), f) == s.size();
    if (std::fclose(f) != 0 || !ok) throw_bad_input("--out: cannot write '" + params_path + "'");
  });
  std::cout << "wrote " << a.out << "/{color,depth" << (a.layers > 0 ? ",layers" : "") << ",ground_truth}.exr";
  for (const auto& f : extra_files) std::cout << ", " << f;
  std::cout << " and params.json; reproduce the camera with: dofkit render " << flags.str() << "\n";
}

}  // namespace

void add_scene_command(CLI::App& app) {
  auto args = std::make_shared<SceneArgs>();
  auto* cmd =
      app.add_subcommand("scene",
                         "render a built-in scene: pinhole colour + depth (+ layers) and the thin-lens ground truth\n"
                         "example: dofkit scene occluder --out scenes/occluder --size 640x360");
  cmd->add_option("name", args->name, "scene name (see --list)");
  cmd->add_flag("--list", args->list, "list the built-in scenes with a description");
  cmd->add_option("--out", args->out, "output directory (created if missing)");
  cmd->add_option("--size", args->size, "image size WIDTHxHEIGHT in px (default 640x360; each 1 to 16384)");
  add_number(cmd, "--samples", args->samples,
             "lens samples per pixel for the ground truth (default: the scene's, enough for >= 45 dB "
             "between two seeds at 640x360)",
             "scene --samples");
  add_number(cmd, "--focus", args->focus_m, "focus distance z_F in metres (default: the scene's)", "scene --focus");
  add_number(cmd, "--blur-at-infinity", args->blur_px,
             "blur radius K of a point at infinity, px at the rendered width (default: the scene's, "
             "scaled from 640 px wide)",
             "scene --blur-at-infinity");
  add_number(cmd, "--layers", args->layers,
             "surfaces per pixel written to layers.exr, front to back (0 = none; default 4)", "scene --layers");
  args->aperture.add(cmd, /*rotation_alias=*/true);
  cmd->add_option("--seed", args->seed, "lens sampling seed (default 1)");
  add_threads(cmd, args->threads, "worker threads (0 = all cores)");
  args->budget.add(cmd);
  cmd->add_flag("--gbuffer", args->gbuffer,
                "also write gbuffer.exr (channels Z, N.X N.Y N.Z, albedo.R/G/B, specular.R/G/B, gloss, "
                "emissive.R/G/B) and camera.json (docs/gbuffer.md); for an AO scene also ao.exr at its radius; for the "
                "lighting scene also lights.json and lit.exr (docs/lighting.md)");
  cmd->add_option("--ao-radius", args->ao_radius_m,
                  "write ao.exr: ray-traced ambient occlusion within this radius, metres (default for an AO scene "
                  "with --gbuffer: the scene's own)");
  cmd->add_option("--ao-rays", args->ao_rays, "cosine-weighted quasi-random rays per pixel for ao.exr (default 4096)");
  cmd->callback([args] { run_scene(*args); });
}

}  // namespace dofkit::cli
