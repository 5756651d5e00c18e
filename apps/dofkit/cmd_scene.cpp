// `dofkit scene`: renders a built-in scene's pinhole RGB-D input (+ layers) and its thin-lens
// ground truth, and writes them with the parameters needed to reproduce the camera in
// `dofkit render`.
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <mutex>
#include <sstream>

#include <nlohmann/json.hpp>

#include "budget.hpp"
#include "cli_common.hpp"
#include "commands.hpp"
#include "quality_run.hpp"
#include "dofkit/error.hpp"
#include "io/image_io.hpp"
#include "io/atomic_write.hpp"
#include "io/layers_io.hpp"
#include "scene/scene.hpp"

namespace dofkit::cli {

namespace {

struct SceneArgs {
  std::string name;
  std::string out;
  std::string size = "640x360";
  int samples = 0;
  double focus_m = 0;
  double blur_px = 0;
  int layers = 4;
  int blades = 0;
  double rotation_deg = 0;
  std::uint64_t seed = 1;
  int threads = 0;
  bool list = false;
  BudgetFlags budget;
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
    return;
  }
  if (a.name.empty()) throw_usage("scene: a scene NAME is required (see dofkit scene --list)");
  if (a.out.empty()) throw_usage("scene: --out DIR is required");
  a.budget.apply();

  scene::SceneOptions opt;
  parse_size(a.size, "--size", opt.width, opt.height);
  opt.samples = a.samples;
  opt.focus_m = a.focus_m;
  opt.blur_at_infinity_px = a.blur_px;
  opt.layers = a.layers;
  opt.blades = a.blades;
  opt.blade_rotation_deg = a.rotation_deg;
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

  std::ostringstream flags;
  flags << "--focus " << exact(d.focus_m) << " --blur-at-infinity " << exact(d.blur_at_infinity_px);
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
  j["blades"] = a.blades;
  j["blade_rotation_deg"] = a.rotation_deg;
  j["seed"] = a.seed;
  j["render_flags"] = flags.str();
  j["ground_truth_seconds"] = seconds;
  j["files"] = {{"color", "color.exr"}, {"depth", "depth.exr"}, {"ground_truth", "ground_truth.exr"}};
  if (a.layers > 0) j["files"]["layers"] = "layers.exr";
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
  std::cout << "wrote " << a.out << "/{color,depth" << (a.layers > 0 ? ",layers" : "")
            << ",ground_truth}.exr and params.json; reproduce the camera with: dofkit render " << flags.str() << "\n";
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
  add_number(cmd, "--blades", args->blades, "aperture blades: 0 = circular, >= 3 = regular polygon", "scene --blades");
  add_number(cmd, "--rotation", args->rotation_deg, "aperture polygon rotation in degrees", "scene --rotation");
  cmd->add_option("--seed", args->seed, "lens sampling seed (default 1)");
  add_threads(cmd, args->threads, "worker threads (0 = all cores)");
  args->budget.add(cmd);
  cmd->callback([args] { run_scene(*args); });
}

}  // namespace dofkit::cli
