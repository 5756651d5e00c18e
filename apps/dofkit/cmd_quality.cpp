// `dofkit quality`: every method against the thin-lens ground truth of the built-in scenes;
// writes a contact sheet per scene and the tables (quality.md, quality.json) to --out.
#include <iostream>
#include <memory>
#include <sstream>

#include "cli_common.hpp"
#include "commands.hpp"
#include "cli_common.hpp"
#include "quality_run.hpp"

namespace dofkit::cli {

void add_quality_command(CLI::App& app) {
  struct Opts {
    std::string scenes, methods, size = "320x180", out = "dofkit-quality";
    std::vector<std::string> set;
    int samples = 0, threads = 0, layers = 0;
    BudgetFlags budget;
    std::string backend = "cpu";
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
  cmd->add_option("--backend", opts->backend,
                  "cpu (default) or vulkan: run the methods on the GPU (give --methods from mcguire, sterna, "
                  "starcraft, and input)");
  cmd->callback([opts] {
    opts->budget.apply();
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
