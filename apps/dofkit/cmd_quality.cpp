// `dofkit quality`: every method against the thin-lens ground truth of the built-in scenes;
// writes a contact sheet per scene and the tables (quality.md, quality.json) to --out.
#include <algorithm>
#include <filesystem>
#include <iostream>
#include <memory>
#include <sstream>

#include "cli_common.hpp"
#include "commands.hpp"
#include "dofkit/error.hpp"
#include "cli_common.hpp"
#include "quality_run.hpp"
#include "ssao_common.hpp"

namespace dofkit::cli {

void add_quality_command(CLI::App& app) {
  struct Opts {
    std::string scenes, methods, size = "320x180", out = "dofkit-quality";
    std::vector<std::string> set;
    int samples = 0, threads = 0, layers = 0, input_bits = 0;
    BudgetFlags budget;
    std::string effect = "dof", radii, ao_cache;
    std::vector<std::string> external;
    int ao_rays = 4096;
    bool fit = false, no_normals = false;
    std::string backend = "cpu";
    ApertureFlags aperture;
    HighlightFlags highlights;
  };
  auto opts = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand(
      "quality",
      "score methods against the thin-lens ground truth of the built-in scenes: Markdown + JSON "
      "table and a contact sheet per scene\n"
      "example: dofkit quality --scenes occluder,fence --methods input,reference,mcguire:variant=book --out q");
  cmd->add_option("--scenes", opts->scenes, "comma-separated scenes (default: all; see dofkit scene --help)");
  cmd->add_option("--methods", opts->methods,
                  "comma-separated rows: input (the unblurred pinhole image) or a method, optionally "
                  "with parameters name:key=value,key=value; input_layers=N sets that row's input layers "
                  "(default: input and every method)");
  cmd->add_option("--size", opts->size, "scene size WxH in pixels (default 320x180)");
  add_number(cmd, "--samples", opts->samples,
             "ground-truth lens samples per pixel (default: the scene's own, >= 45 dB noise floor)",
             "quality --samples");
  add_number(cmd, "--layers", opts->layers,
             "fragments per pixel in the input frames (front to back; 0 = plain RGB-D, the default); "
             "a row may override it: layered:input_layers=4",
             "quality --layers");
  cmd->add_option("--out", opts->out, "output folder (default ./dofkit-quality)");
  add_threads(cmd, opts->threads, "worker threads (default: all hardware threads)");
  opts->budget.add(cmd, false);
  cmd->add_option("--set", opts->set, "method.key=value for every row of that method (repeatable)");
  cmd->add_option("--input-bits", opts->input_bits,
                  "8 or 16: quantise the input colour to an 8/16-bit sRGB file's values first (clipped at 1, "
                  "display-referred; the default highlight boost then applies); default 0 = float HDR");
  opts->aperture.add(cmd);
  opts->highlights.add(cmd);
  auto* ao = "Ambient occlusion (--effect ao; docs/methods/ssao.md)";
  cmd->add_option("--effect", opts->effect,
                  "dof (depth of field, default) or ao: score the AO methods (--methods sc2,sc2:preset=tuned,gtao by "
                  "default) against the tracer's AO on the built-in AO scenes (--scenes ao_corner,ao_shelf; --size "
                  "default 640x360)")
      ->check(CLI::IsMember({"dof", "ao"}));
  cmd->add_option("--radii", opts->radii, "AO radii in metres, comma-separated (default: each scene's own)")->group(ao);
  cmd->add_option("--ao-rays", opts->ao_rays, "reference AO rays per pixel (default 4096)")->group(ao);
  cmd->add_option("--external", opts->external,
                  "a folder with pinhole_depth.exr, normal.exr, ao.exr and params.json (ao_distance_m, f_px) rendered "
                  "elsewhere, scored too (repeatable)")
      ->group(ao);
  cmd->add_flag("--fit", opts->fit,
                "fit sc2's artist parameters (lowest mean squared error) on the built-in scenes, print them and add "
                "the row sc2:fitted")
      ->group(ao);
  cmd->add_option("--ao-cache", opts->ao_cache,
                  "folder where the reference AO images are kept between runs (created if missing; named by scene, "
                  "size, radius and rays)")
      ->group(ao);
  cmd->add_flag("--no-normals", opts->no_normals, "give the AO methods the depth only (normals reconstructed)")
      ->group(ao);
  cmd->add_option("--backend", opts->backend,
                  "cpu (default) or vulkan: run the methods on the GPU (give --methods from mcguire, sterna, "
                  "starcraft, and input)");
  cmd->callback([opts, cmd] {
    opts->budget.apply();
    if (opts->effect == "ao") {
      AoQualityOptions q;
      if (!opts->scenes.empty()) {
        std::istringstream in(opts->scenes);
        for (std::string s; std::getline(in, s, ',');)
          if (!s.empty()) q.scenes.push_back(s);
      }
      if (!opts->methods.empty()) q.methods = parse_ao_method_list(opts->methods);
      if (cmd->count("--size") > 0) parse_size(opts->size, "--size", q.width, q.height);
      if (!opts->radii.empty())
        for (double r : parse_numbers(opts->radii, std::count(opts->radii.begin(), opts->radii.end(), ',') + 1,
                                      "--radii", "radii in metres", {"quality --radii"}))
          q.radii.push_back(r);
      if (!opts->set.empty() || opts->samples || opts->layers || opts->backend != "cpu" || opts->input_bits)
        throw_usage("--set, --samples, --layers, --backend, --input-bits: only with --effect dof");
      q.rays = opts->ao_rays;
      q.cache_dir = opts->ao_cache;
      if (!q.cache_dir.empty()) std::filesystem::create_directories(q.cache_dir);
      q.external = opts->external;
      q.out_dir = opts->out;
      q.threads = opts->threads;
      q.fit = opts->fit;
      q.no_normals = opts->no_normals;
      q.command_line = "dofkit quality --effect ao";
      if (!opts->scenes.empty()) q.command_line += " --scenes " + opts->scenes;
      if (!opts->methods.empty()) q.command_line += " --methods " + opts->methods;
      q.command_line += " --size " + std::to_string(q.width) + "x" + std::to_string(q.height);
      if (!opts->radii.empty()) q.command_line += " --radii " + opts->radii;
      q.command_line += " --ao-rays " + std::to_string(q.rays);
      for (const auto& e : opts->external) q.command_line += " --external " + e;
      if (opts->no_normals) q.command_line += " --no-normals";
      if (opts->threads) q.command_line += " --threads " + std::to_string(opts->threads);
      run_ao_quality(q);
      return;
    }
    if (!opts->radii.empty() || !opts->external.empty() || opts->fit || opts->no_normals || cmd->count("--ao-rays") ||
        !opts->ao_cache.empty())
      throw_usage("--radii, --ao-rays, --ao-cache, --external, --fit, --no-normals: only with --effect ao");
    QualityOptions q;
    if (!opts->scenes.empty()) {
      std::istringstream in(opts->scenes);
      for (std::string s; std::getline(in, s, ',');)
        if (!s.empty()) q.scenes.push_back(s);
    }
    if (!opts->methods.empty()) q.methods = parse_method_list(opts->methods);
    parse_size(opts->size, "--size", q.width, q.height);
    for (const auto& s : opts->set) parse_set(s, q.set);
    q.samples = opts->samples;
    q.aperture = opts->aperture.build();
    q.input_bits = opts->input_bits;
    q.highlights = opts->highlights.build(opts->input_bits > 0);
    q.layers = opts->layers;
    q.threads = opts->threads;
    q.backend = parse_backend(opts->backend);
    q.out_dir = opts->out;
    q.command_line = "dofkit quality";
    if (!opts->scenes.empty()) q.command_line += " --scenes " + opts->scenes;
    if (!opts->methods.empty()) q.command_line += " --methods " + opts->methods;
    q.command_line += " --size " + opts->size;
    if (opts->samples) q.command_line += " --samples " + std::to_string(opts->samples);
    if (opts->layers) q.command_line += " --layers " + std::to_string(opts->layers);
    for (const auto& s : opts->set) q.command_line += " --set " + s;
    if (!opts->aperture.text().empty()) q.command_line += " " + opts->aperture.text();
    if (opts->input_bits) q.command_line += " --input-bits " + std::to_string(opts->input_bits);
    if (!opts->highlights.text().empty()) q.command_line += " " + opts->highlights.text();
    if (opts->threads) q.command_line += " --threads " + std::to_string(opts->threads);
    if (q.backend != Backend::cpu) q.command_line += " --backend " + opts->backend;
    const QualityResult r = run_quality(q);
    std::cout << metrics::markdown_table(r.rows);
    std::cerr << "wrote:";
    for (const auto& f : r.files) std::cerr << " " << f;
    std::cerr << "\n";
  });
}

}  // namespace dofkit::cli
