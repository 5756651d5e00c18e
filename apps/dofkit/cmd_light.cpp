// `dofkit light`: deferred point / spot / directional / ambient lighting of a G-buffer with a
// lights file (docs/lighting.md).
#include <cmath>
#include <iostream>
#include <memory>

#include <fmt/core.h>

#include "cli_common.hpp"
#include "commands.hpp"
#include "dofkit/error.hpp"
#include "dofkit/light.hpp"
#include "io/exr_direct.hpp"
#include "io/image_io.hpp"
#include "light_common.hpp"

namespace dofkit::cli {

namespace {

struct LightArgs {
  GBufferFiles g;
  std::string camera, lights, output, layers_output, ao, impl = "tiled";
  double fov_deg = 0;
  bool no_emissive = false, stats = false;
  int threads = 0;
  int bits = 0;
};

// A layer channel's name: "<index>_<name>" with anything but [A-Za-z0-9_-] turned into '_'.
std::string layer_name(std::size_t k, const Light& l) {
  std::string n = fmt::format("{:02d}", k);
  if (!l.name.empty()) n += "_" + l.name.substr(0, 40);
  for (char& c : n)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '-') c = '_';
  return n;
}

void run_light(const LightArgs& a, const CLI::App& cmd) {
  // Flags first (exit 2), before any file is read.
  check_gbuffer_flags(a.g);
  if (a.lights.empty()) throw_usage("--lights: required (a lights file, docs/lighting.md)");
  if (a.output.empty()) throw_usage("--output: required (the lit image, e.g. lit.exr)");
  const bool fov_given = cmd.count("--fov-deg") > 0;
  if (fov_given == !a.camera.empty())
    throw_usage(fov_given ? "--fov-deg and --camera: give only one of them"
                          : "no field of view: give --fov-deg F (horizontal, degrees) or --camera camera.json");
  if (fov_given && !(a.fov_deg > 0 && a.fov_deg < 180)) throw_usage("--fov-deg: must be in (0, 180) degrees");
  io::WriteOptions out_opt;
  out_opt.bits = a.bits;
  io::check_output_format(a.output, out_opt, "--output");
  if (!a.layers_output.empty() && !io::is_exr_path(a.layers_output))
    throw_usage("--layers-output " + a.layers_output + ": must be an .exr file (one R, G, B layer per light)");
  check_paths({{"--gbuffer", a.g.gbuffer},
               {"--depth", a.g.depth},
               {"--normals", a.g.normals},
               {"--albedo", a.g.albedo},
               {"--specular", a.g.specular},
               {"--gloss", a.g.gloss},
               {"--emissive", a.g.emissive},
               {"--camera", a.camera},
               {"--lights", a.lights},
               {"--ao", a.ao}},
              {{"--output", a.output}, {"--layers-output", a.layers_output}});

  // Inputs (exit 3 for anything wrong in them).
  const GBufferImages g = read_gbuffer(a.g);
  for (const std::string& m : g.missing) std::cerr << "dofkit light: no " << m << " channel: taken as 0\n";
  CameraFile cam;
  cam.hfov_deg = a.fov_deg;
  if (!a.camera.empty()) cam = read_camera_file(a.camera, g.depth.width(), g.depth.height());
  const std::vector<Light> lights = read_lights_file(a.lights, a.camera.empty() ? nullptr : &cam);
  if (!a.layers_output.empty() && static_cast<int>(lights.size()) > kMaxLightLayers)
    throw_bad_input("--lights " + a.lights + ": " + std::to_string(lights.size()) +
                    " lights; --layers-output takes at most " + std::to_string(kMaxLightLayers));
  Image ao;
  if (!a.ao.empty()) {
    ao = io::read_mask(a.ao);
    if (!ao.same_size(g.depth))
      throw_bad_input("--ao " + a.ao + ": " + std::to_string(ao.width()) + "x" + std::to_string(ao.height()) +
                      " does not match the G-buffer's " + std::to_string(g.depth.width()) + "x" +
                      std::to_string(g.depth.height()));
  }
  LightSettings s;
  s.hfov_deg = cam.hfov_deg;
  s.threads = a.threads;
  s.impl = a.impl;
  s.layers = !a.layers_output.empty();
  s.emissive = !a.no_emissive;
  s.ao = a.ao.empty() ? nullptr : &ao;
  LightResult r;
  try {
    r = while_doing("lighting", [&] { return deferred_lighting(g.ref(), lights, s); });
  } catch (const Error& e) {
    // The buffers' own problems (a NaN, a depth <= 0) name the G-buffer file.
    if (e.kind() != ErrorKind::bad_input) throw;
    throw_bad_input((a.g.gbuffer.empty() ? std::string("G-buffer") : "--gbuffer " + a.g.gbuffer) + ": " + e.what());
  }
  if (a.stats) {
    std::cout << fmt::format("{} tiles of 16x16\n", r.stats.tiles);
    for (std::size_t k = 0; k < lights.size(); ++k)
      std::cout << fmt::format("light {} {}: {} tiles ({:.1f} %), {} pixels shaded\n", k, lights[k].name,
                               r.stats.tiles_touched[k], 100.0 * r.stats.tiles_touched[k] / r.stats.tiles,
                               r.stats.pixels_shaded[k]);
  }
  OutputWriter out;
  out.add_image(a.output, r.lit, out_opt);
  if (!a.layers_output.empty()) {
    const int w = r.lit.width(), h = r.lit.height();
    out.add_file(a.layers_output, [&](const std::string& tmp) {
      static const char* const kSuffix[3] = {".R", ".G", ".B"};
      std::vector<io::exr::OutChannel> ch;
      for (std::size_t k = 0; k < lights.size(); ++k) {
        const std::string n = layer_name(k, lights[k]);
        for (int c = 0; c < 3; ++c) ch.push_back({n + kSuffix[c], r.layers[k].plane(c)});
      }
      for (int c = 0; c < 3; ++c) ch.push_back({kSuffix[c] + 1, r.lit.plane(c)});
      io::exr::write_scanline(tmp, a.layers_output, w, h, ch, false, "zip");
    });
  }
  out.commit();
}

}  // namespace

void add_light_command(CLI::App& app) {
  auto a = std::make_shared<LightArgs>();
  auto* cmd = app.add_subcommand(
      "light",
      "deferred lighting of a G-buffer: point, spot, directional and ambient lights from a lights file, with tile "
      "and per-pixel volume culling (StarCraft II)\n"
      "example: dofkit light --gbuffer s/gbuffer.exr --camera s/camera.json --lights s/lights.json --output lit.exr");
  cmd->add_option("--gbuffer", a->g.gbuffer,
                  "G-buffer EXR with channels Z, N.X N.Y N.Z, albedo.R/G/B and optionally specular.R/G/B, gloss, "
                  "emissive.R/G/B (dofkit scene --gbuffer); the default file for every buffer");
  cmd->add_option("--depth", a->g.depth, "planar depth z, metres, from its own file (default: --gbuffer's Z)");
  cmd->add_option("--normals", a->g.normals, "camera-space normals from their own float file (N.X.., X Y Z or R G B)");
  cmd->add_option("--albedo", a->g.albedo, "diffuse albedo from its own file (albedo.R/G/B or R G B)");
  cmd->add_option("--specular", a->g.specular, "specular colour from its own file (specular.R/G/B or R G B)");
  cmd->add_option("--gloss", a->g.gloss, "gloss in [0, 1] from its own file (gloss or Y)");
  cmd->add_option("--emissive", a->g.emissive, "emitted radiance from its own file (emissive.R/G/B or R G B)");
  cmd->add_option("--channels", a->g.channel_maps,
                  "channel names of a buffer, BUFFER=NAME[,NAME,NAME] (repeatable), e.g. albedo=DiffCol.R,DiffCol.G,"
                  "DiffCol.B or depth=Depth.V");
  cmd->add_option("--camera", a->camera,
                  "camera.json (dofkit scene --gbuffer): hfov_deg, and view_matrix for world-space lights");
  cmd->add_option("--fov-deg", a->fov_deg, "horizontal field of view, degrees (0..180), instead of --camera");
  cmd->add_option("--lights", a->lights, "lights file (JSON; schema in docs/lighting.md; at most 1024 lights)");
  cmd->add_option("--output", a->output, "the lit image (linear RGB: emissive + every light): .exr, .tif, .png");
  cmd->add_option("--bits", a->bits, "bits per channel of --output (EXR 16/32, PNG 8/16, TIFF 8/16/32)");
  cmd->add_option("--layers-output", a->layers_output,
                  "also write each light's contribution as its own R, G, B layer (NN_name.R …) plus the sum (R, G, B) "
                  "to this EXR (at most 64 lights)");
  cmd->add_option("--ao", a->ao,
                  "an ambient-occlusion image (1 channel, 1 = open) that multiplies the lights whose "
                  "\"ao\" is true (ambient lights by default)");
  cmd->add_flag("--no-emissive", a->no_emissive, "leave the emissive buffer out of the lit image");
  cmd->add_option("--impl", a->impl,
                  "tiled (default: tile + per-pixel volume culling) or brute (every light at every pixel; the oracle)")
      ->check(CLI::IsMember({"tiled", "brute"}));
  cmd->add_flag("--stats", a->stats, "print, per light, the tiles it touched and the pixels it was evaluated at");
  add_threads(cmd, a->threads, "worker threads (0 = all hardware threads); the output is the same for any count");
  cmd->callback([a, cmd] { run_light(*a, *cmd); });
}

}  // namespace dofkit::cli
