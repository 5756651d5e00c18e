// `dofkit demo` (what scripts/demo runs): renders the built-in scenes, runs every method,
// writes a contact sheet per scene and the quality table to ./dofkit-demo/, prints the
// table and where to look. Sized to finish in a couple of minutes on 2 cores.
// It is `dofkit quality` with every scene and method and demo-sized defaults.
#include <filesystem>
#include <iostream>
#include <memory>

#include "cli_common.hpp"
#include "commands.hpp"
#include "dofkit/error.hpp"
#include "quality_run.hpp"

namespace dofkit::cli {

void add_demo_command(CLI::App& app) {
  struct Opts {
    // 480x270 keeps the sheet labels legible (tiles >= 480 px get double-size text) and,
    // with the scenes' own ground-truth sampling (their >= 45 dB noise floor), takes about
    // 140 s of CPU time in all, about a minute on 2 idle cores; the ray tracer dominates.
    std::string out = "dofkit-demo", size = "480x270";
    int samples = 0, threads = 0;
    int layers = 4;  // the layered method gets the hidden surfaces it is designed for
    BudgetFlags budget;
  };
  auto opts = std::make_shared<Opts>();
  auto* cmd =
      app.add_subcommand("demo",
                         "the guided tour: every method on every built-in scene against the thin-lens ground truth; "
                         "writes contact sheets and the quality table to ./dofkit-demo/");
  cmd->add_option("--out", opts->out, "output folder (default ./dofkit-demo)");
  cmd->add_option("--size", opts->size, "scene size WxH in pixels (default 480x270)");
  add_number(cmd, "--samples", opts->samples, "ground-truth lens samples per pixel (default: the scene's own)",
             "demo --samples");
  add_number(cmd, "--layers", opts->layers, "fragments per pixel in the input frames (default 4; 0 = plain RGB-D)",
             "demo --layers");
  add_threads(cmd, opts->threads, "worker threads (default: all hardware threads)");
  opts->budget.add(cmd, false);
  cmd->callback([opts] {
    opts->budget.apply();
    QualityOptions q;
    parse_size(opts->size, "--size", q.width, q.height);
    q.samples = opts->samples;
    q.layers = opts->layers;
    q.threads = opts->threads;
    q.out_dir = opts->out;
    q.command_line = "dofkit demo --size " + opts->size;
    if (opts->samples) q.command_line += " --samples " + std::to_string(opts->samples);
    q.command_line += " --layers " + std::to_string(opts->layers);
    // A folder the tour cannot write is refused before its banner.
    std::error_code ec;
    if (std::filesystem::exists(opts->out, ec) && !std::filesystem::is_directory(opts->out, ec))
      throw_bad_input("--out " + opts->out + ": exists and is not a folder");
    std::cerr << "dofkit demo: rendering the built-in scenes at " << opts->size
              << ", their thin-lens ground truth, and every method (this takes a minute or two)\n";
    const QualityResult r = run_quality(q);
    std::cout << metrics::markdown_table(r.rows) << "\n";
    const std::string dir = std::filesystem::absolute(opts->out).lexically_normal().string();
    std::cout << "Contact sheets (input | ground truth | each method; error heat maps below):\n";
    for (const auto& f : r.files)
      if (f.size() > 4 && f.substr(f.size() - 4) == ".png") std::cout << "  " << f << "\n";
    std::cout << "Table: " << opts->out << "/quality.md (and quality.json)\n"
              << "All output is in " << dir << "\n"
              << "Next: dofkit quality --help (choose scenes, methods, sizes), dofkit render --help\n";
  });
}

}  // namespace dofkit::cli
