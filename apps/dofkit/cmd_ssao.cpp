// `dofkit ssao`: screen-space ambient occlusion of a depth map (+ optional normals), by
// StarCraft II's method (sc2) or GTAO (gtao); see docs/methods/ssao.md.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>

#include <nlohmann/json.hpp>

#include "cli_common.hpp"
#include "commands.hpp"
#include "dofkit/ao.hpp"
#include "dofkit/error.hpp"
#include "io/image_io.hpp"
#include "ssao_common.hpp"

namespace dofkit::cli {

namespace {

struct SsaoArgs {
  std::string depth, normals, camera, output, debug_view, debug_output, method = "sc2", preset;
  double fov_deg = 0, radius_m = 0;
  std::vector<std::string> sets;
  int threads = 0;
  int bits = 0;
};

void run_ssao(const SsaoArgs& a, const CLI::App& cmd) {
  if (a.debug_view == "list") {
    for (const MethodInfo& m : ao_methods())
      if (m.name == a.method)
        for (const DebugViewInfo& v : m.debug_views) std::cout << v.name << "\t" << v.help << "\n";
    return;
  }
  // Flags first (exit 2), before any file is read.
  if (a.depth.empty()) throw_usage("--depth: required (planar depth z in metres, e.g. depth.exr or gbuffer.exr)");
  if (a.output.empty()) throw_usage("--output: required (the AO image, e.g. ao.exr)");
  const bool fov_given = cmd.count("--fov-deg") > 0;
  if (fov_given == !a.camera.empty())
    throw_usage(fov_given ? "--fov-deg and --camera: give only one of them"
                          : "no field of view: give --fov-deg F (horizontal, degrees) or --camera camera.json");
  if (cmd.count("--radius") == 0) throw_usage("--radius: required (the AO radius in metres, e.g. 0.5)");
  if (!(a.radius_m > 0) || !std::isfinite(a.radius_m))
    throw_usage("--radius: must be a finite number of metres > 0, got " + std::to_string(a.radius_m));
  if (fov_given && !(a.fov_deg > 0 && a.fov_deg < 180)) throw_usage("--fov-deg: must be in (0, 180) degrees");
  if (a.debug_view.empty() != a.debug_output.empty())
    throw_usage("--debug-view and --debug-output: give both (or --debug-view list)");
  AoSettings s;
  s.method = a.method;
  s.radius_m = a.radius_m;
  s.hfov_deg = fov_given ? a.fov_deg : 60;  // checked against the camera file below
  s.params = parse_sets(a.sets);
  if (!a.preset.empty()) {
    if (s.params.count("preset")) throw_usage("--preset and --set preset=…: give only one of them");
    s.params["preset"] = a.preset;
  }
  s.threads = a.threads;
  s.debug_view = a.debug_view;
  AoRenderer probe(s);  // validates the method, parameters and debug view now
  io::WriteOptions out_opt;
  out_opt.bits = a.bits;
  out_opt.channel_name = "Y";
  io::check_output_format(a.output, out_opt, "--output");
  io::WriteOptions debug_opt;
  debug_opt.channel_name = "Y";
  if (!a.debug_output.empty()) io::check_output_format(a.debug_output, debug_opt, "--debug-output");
  check_paths({{"--depth", a.depth}, {"--normals", a.normals}, {"--camera", a.camera}},
              {{"--output", a.output}, {"--debug-output", a.debug_output}});

  // Inputs (exit 3 for anything wrong in them).
  const Image depth = io::read_depth(a.depth, {});
  if (!a.camera.empty()) s.hfov_deg = read_camera_fov(a.camera, depth.width(), depth.height());
  Image normals;
  if (!a.normals.empty()) {
    normals = io::read_normals(a.normals);
    if (!normals.same_size(depth))
      throw_bad_input("--normals " + a.normals + ": " + std::to_string(normals.width()) + "x" +
                      std::to_string(normals.height()) + " does not match the depth's " +
                      std::to_string(depth.width()) + "x" + std::to_string(depth.height()));
  }
  AoRenderer renderer(s);
  const AoResult& r = renderer.render(depth, a.normals.empty() ? nullptr : &normals);
  if (r.normals_reconstructed) std::cerr << "dofkit ssao: no --normals given: normals reconstructed from the depth\n";
  OutputWriter out;
  out.add_image(a.output, r.ao, out_opt);
  if (!a.debug_output.empty()) out.add_image(a.debug_output, r.debug, debug_opt);
  out.commit();
}

}  // namespace

void add_ssao_command(CLI::App& app) {
  auto a = std::make_shared<SsaoArgs>();
  auto* cmd = app.add_subcommand(
      "ssao",
      "screen-space ambient occlusion of a depth map: StarCraft II's SSAO (sc2) or GTAO (gtao)\n"
      "example: dofkit ssao --depth scene/gbuffer.exr --normals scene/gbuffer.exr --camera scene/camera.json "
      "--radius 0.5 --output ao.exr");
  cmd->add_option("--depth", a->depth,
                  "planar depth z, metres (+inf = sky): a one-channel image, or the Z channel of an EXR such as "
                  "dofkit scene's gbuffer.exr");
  cmd->add_option("--normals", a->normals,
                  "camera-space unit normals (X right, Y up, Z towards the camera), float EXR/TIFF: channels N.X N.Y "
                  "N.Z, X Y Z or R G B (default: reconstructed from the depth)");
  cmd->add_option("--fov-deg", a->fov_deg, "horizontal field of view of the depth map, degrees (0..180)");
  cmd->add_option("--camera", a->camera, "camera.json (dofkit scene --gbuffer) giving hfov_deg, instead of --fov-deg");
  cmd->add_option("--radius", a->radius_m, "AO radius, metres (> 0): how far an occluder can be and still occlude");
  cmd->add_option("--method", a->method, "sc2 (StarCraft II, default) or gtao (ground-truth-based AO)")
      ->check(CLI::IsMember({"sc2", "gtao"}));
  cmd->add_option("--preset", a->preset,
                  "sc2 only: chapter (default) or tuned (artist values fitted to ray-traced AO on the built-in AO "
                  "scenes)");
  cmd->add_option("--set", a->sets, "method parameter KEY=VALUE (repeatable; the parameters are listed below)");
  cmd->add_option("--output", a->output, "the AO image (1 = open, 0 = occluded): .exr (channel Y), .png, .tif");
  cmd->add_option("--bits", a->bits,
                  "bits per channel of --output: EXR 16/32, PNG 8/16, TIFF 8/16/32 (default: EXR 32, PNG/TIFF 8)");
  cmd->add_option("--debug-view", a->debug_view, "intermediate buffer to write (see --debug-view list)");
  cmd->add_option("--debug-output", a->debug_output, "file for --debug-view");
  add_threads(cmd, a->threads, "worker threads (0 = all hardware threads)");
  cmd->footer(ssao_params_help());
  cmd->callback([a, cmd] { run_ssao(*a, *cmd); });
}

}  // namespace dofkit::cli
