// `dofkit pipeline`: StarCraft II's chain on a G-buffer (docs/lighting.md#the-pipeline):
// SSAO → deferred lighting, the AO term multiplying the lights it should → a key transparency
// composited over the lit image → depth of field, re-applied over the transparency's area with
// its own depth (§5.7, render_masked).
#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>
#include <utility>

#include <fmt/core.h>

#include "cli_common.hpp"
#include "commands.hpp"
#include "dofkit/ao.hpp"
#include "dofkit/error.hpp"
#include "dofkit/light.hpp"
#include "dofkit/render.hpp"
#include "io/image_io.hpp"
#include "light_common.hpp"

namespace dofkit::cli {

namespace {

struct PipelineArgs {
  GBufferFiles g;
  std::string camera_file, lights, output, debug_dir, stop_after = "dof";
  std::string transparency, transparency_depth;
  std::string ao_method = "sc2", method = "lens";
  double ao_radius_m = 0;
  std::vector<std::string> sets;
  CameraFlags camera;
  int threads = 0;
};

// The stages in order; --stop-after names one.
constexpr const char* kStages[] = {"ao", "light", "dof"};

int stage_index(const std::string& s) {
  for (int k = 0; k < 3; ++k)
    if (s == kStages[k]) return k;
  return -1;
}

void run_pipeline(const PipelineArgs& a) {
  // Flags first (exit 2).
  check_gbuffer_flags(a.g);
  if (a.camera_file.empty())
    throw_usage("--camera: required (camera.json: hfov_deg, and view_matrix for world lights)");
  if (a.lights.empty()) throw_usage("--lights: required (a lights file, docs/lighting.md)");
  if (a.output.empty()) throw_usage("--output: required (the final image, e.g. final.exr)");
  const int last = stage_index(a.stop_after);
  if (last < 0) throw_usage("--stop-after " + a.stop_after + ": not a stage (ao, light, dof)");
  if (a.ao_method == "none" && last == 0) throw_usage("--stop-after ao: needs an AO method (--ao-method sc2|gtao)");
  if (!(a.ao_radius_m >= 0) || !std::isfinite(a.ao_radius_m))
    throw_usage("--ao-radius: must be a finite number of metres > 0 (0 = the default, 0.5)");
  const bool dof = last == 2;
  if (dof && !a.camera.model_given())
    throw_usage("the dof stage needs a camera model (e.g. --focus 3.5 --blur-at-infinity 10; or --stop-after light)");
  if (dof) a.camera.check();
  if (a.transparency.empty() != a.transparency_depth.empty())
    throw_usage("--transparency and --transparency-depth: give both or neither");
  const std::map<std::string, std::string> params = parse_sets(a.sets);
  io::WriteOptions out_opt;
  io::check_output_format(a.output, out_opt, "--output");
  check_paths({{"--gbuffer", a.g.gbuffer},
               {"--depth", a.g.depth},
               {"--normals", a.g.normals},
               {"--albedo", a.g.albedo},
               {"--camera", a.camera_file},
               {"--lights", a.lights},
               {"--transparency", a.transparency},
               {"--transparency-depth", a.transparency_depth}},
              {{"--output", a.output}});

  // Inputs (exit 3).
  const GBufferImages g = read_gbuffer(a.g);
  for (const std::string& m : g.missing) std::cerr << "dofkit pipeline: no " << m << " channel: taken as 0\n";
  const CameraFile cam = read_camera_file(a.camera_file, g.depth.width(), g.depth.height());
  const std::vector<Light> lights = read_lights_file(a.lights, &cam);
  // The key transparency (§5.7): premultiplied RGBA over the lit opaque scene, and its depth.
  Image trans, trans_alpha, trans_depth;
  if (!a.transparency.empty()) {
    trans = io::read_color(a.transparency);
    io::DepthOptions dopt;
    dopt.invalid_as_far = true;  // outside the coverage the depth is never used
    trans_depth = io::read_depth(a.transparency_depth, dopt);
    for (const auto& [im, name] : {std::pair<const Image*, const std::string*>{&trans, &a.transparency},
                                   std::pair<const Image*, const std::string*>{&trans_depth, &a.transparency_depth}})
      if (!im->same_size(g.depth))
        throw_bad_input(*name + ": is " + std::to_string(im->width()) + "x" + std::to_string(im->height()) +
                        ", the G-buffer " + std::to_string(g.depth.width()) + "x" + std::to_string(g.depth.height()));
    trans_alpha = Image(trans.width(), trans.height(), 1);
    for (std::size_t i = 0; i < trans.plane_size(); ++i) {
      const float al = trans.plane(3)[i];
      const bool colour_ok =
          std::isfinite(trans.plane(0)[i]) && std::isfinite(trans.plane(1)[i]) && std::isfinite(trans.plane(2)[i]);
      if (!(al >= 0 && al <= 1) || !colour_ok)
        throw_bad_input(a.transparency + ": pixel (" + std::to_string(i % trans.width()) + ", " +
                        std::to_string(i / trans.width()) + "): alpha outside [0, 1] or a non-finite colour");
      if (al > 0 && !(trans_depth.plane(0)[i] > 0 && std::isfinite(trans_depth.plane(0)[i])))
        throw_bad_input(a.transparency_depth + ": pixel (" + std::to_string(i % trans.width()) + ", " +
                        std::to_string(i / trans.width()) + ") is covered but has no finite depth > 0");
      trans_alpha.plane(0)[i] = al;
    }
  }

  OutputWriter out;
  const auto debug = [&](const char* name, const Image& im, const char* channel) {
    if (a.debug_dir.empty()) return;
    io::WriteOptions w;
    w.channel_name = channel;
    out.add_image((std::filesystem::path(a.debug_dir) / name).string(), im, w);
  };
  if (!a.debug_dir.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(a.debug_dir, ec);
    if (ec) throw_bad_input("--debug-dir " + a.debug_dir + ": cannot create the folder: " + ec.message());
  }

  // 1. AO (§5.5): the term that multiplies the lights marked "ao" (ambient lights by default).
  Image ao;
  if (a.ao_method != "none") {
    AoSettings s;
    s.method = a.ao_method;
    s.hfov_deg = cam.hfov_deg;
    double radius = a.ao_radius_m;
    if (radius == 0) radius = 0.5;
    s.radius_m = radius;
    s.threads = a.threads;
    ao = ambient_occlusion(g.depth, &g.normals, s).ao;
    debug("ao.exr", ao, "Y");
    if (last == 0) {
      io::WriteOptions w;
      w.channel_name = "Y";
      out.add_image(a.output, ao, w);
      out.commit();
      return;
    }
  }

  // 2. Lighting (§5.4).
  LightSettings ls;
  ls.hfov_deg = cam.hfov_deg;
  ls.threads = a.threads;
  ls.ao = ao.empty() ? nullptr : &ao;
  Image lit;
  try {
    lit = deferred_lighting(g.ref(), lights, ls).lit;
  } catch (const Error& e) {
    if (e.kind() != ErrorKind::bad_input) throw;
    throw_bad_input((a.g.gbuffer.empty() ? std::string("G-buffer") : "--gbuffer " + a.g.gbuffer) + ": " + e.what());
  }
  debug("lit.exr", lit, "Y");
  // 3. The key transparency drawn over the lit opaque scene (it is not lit by the deferred
  // pass, as in the chapter): composite = lit · (1 − α) + premultiplied colour.
  if (!trans.empty()) {
    for (int c = 0; c < 3; ++c)
      for (std::size_t i = 0; i < lit.plane_size(); ++i)
        lit.plane(c)[i] = lit.plane(c)[i] * (1 - trans_alpha.plane(0)[i]) + trans.plane(c)[i];
    debug("composite.exr", lit, "Y");
  }
  if (!dof) {
    out.add_image(a.output, lit, out_opt);
    out.commit();
    return;
  }

  // 4. Depth of field (§5.6) of the lit image with its depth; with a key transparency, once
  // more over its area with its own depth, blended by its coverage (render_masked).
  Frame frame;
  frame.color = Image(lit.width(), lit.height(), 4, 1.0f);
  for (int c = 0; c < 3; ++c) std::copy(lit.plane(c), lit.plane(c) + lit.plane_size(), frame.color.plane(c));
  frame.depth = g.depth;
  RenderSettings rs;
  rs.method = a.method;
  rs.params = params;
  rs.threads = a.threads;
  rs.camera = a.camera.build(&frame.depth);
  const RenderResult r = trans.empty() ? render(frame, rs) : render_masked(frame, trans_alpha, trans_depth, rs);
  Image rgb(lit.width(), lit.height(), 3);
  for (int c = 0; c < 3; ++c) std::copy(r.image.plane(c), r.image.plane(c) + rgb.plane_size(), rgb.plane(c));
  out.add_image(a.output, rgb, out_opt);
  out.commit();
}

}  // namespace

void add_pipeline_command(CLI::App& app) {
  auto a = std::make_shared<PipelineArgs>();
  auto* cmd = app.add_subcommand(
      "pipeline",
      "StarCraft II's screen-space chain on a G-buffer: SSAO -> deferred lighting (AO multiplies the lights marked "
      "\"ao\") -> depth of field\n"
      "example: dofkit pipeline --gbuffer s/gbuffer.exr --camera s/camera.json --lights s/lights.json --focus 3.5 "
      "--blur-at-infinity 10 --output final.exr --debug-dir stages");
  cmd->add_option("--gbuffer", a->g.gbuffer, "G-buffer EXR (as dofkit light --gbuffer)");
  cmd->add_option("--depth", a->g.depth, "planar depth from its own file");
  cmd->add_option("--normals", a->g.normals, "camera-space normals from their own file");
  cmd->add_option("--albedo", a->g.albedo, "diffuse albedo from its own file");
  cmd->add_option("--channels", a->g.channel_maps, "channel names of a buffer, BUFFER=NAME[,NAME,NAME] (repeatable)");
  cmd->add_option("--camera", a->camera_file, "camera.json: hfov_deg, view_matrix");
  cmd->add_option("--lights", a->lights, "lights file (docs/lighting.md)");
  cmd->add_option("--ao-method", a->ao_method, "sc2 (default), gtao, or none (no AO stage)")
      ->check(CLI::IsMember({"sc2", "gtao", "none"}));
  cmd->add_option("--ao-radius", a->ao_radius_m, "AO radius, metres (default 0.5)");
  cmd->add_option("--method", a->method, "depth-of-field method (default lens; see dofkit methods)");
  cmd->add_option("--set", a->sets, "depth-of-field method parameter KEY=VALUE (repeatable)");
  a->camera.add(cmd);
  cmd->add_option("--transparency", a->transparency,
                  "a key transparency (StarCraft II §5.7): its colour, premultiplied RGBA (alpha = coverage), drawn "
                  "over the lit image; depth of field is applied again over its area with --transparency-depth");
  cmd->add_option("--transparency-depth", a->transparency_depth,
                  "the key transparency's planar depth, metres (used where its alpha > 0)");
  cmd->add_option("--stop-after", a->stop_after, "ao, light or dof (default): the output is that stage's buffer");
  cmd->add_option("--output", a->output, "the final image (or --stop-after's stage): .exr, .tif, .png");
  cmd->add_option("--debug-dir", a->debug_dir,
                  "also write every stage's buffer there: ao.exr, lit.exr (composite.exr with --transparency)");
  add_threads(cmd, a->threads, "worker threads (0 = all); the output is the same for every count");
  cmd->callback([a] { run_pipeline(*a); });
}

}  // namespace dofkit::cli
