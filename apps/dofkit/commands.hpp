// The dofkit subcommands. Each lives in its own cmd_<name>.cpp and registers itself on the
// CLI11 app; errors are reported by throwing dofkit::Error (main turns them into one line
// on stderr and the exit code: usage 2, bad input 3, internal 1).
#pragma once
#include <CLI/CLI.hpp>

#include <string>
#include <vector>

#include "dofkit/render.hpp"

namespace dofkit::cli {

void add_render_command(CLI::App& app);
void add_methods_command(CLI::App& app);
void add_demo_command(CLI::App& app);
void add_scene_command(CLI::App& app);
void add_compare_command(CLI::App& app);
void add_quality_command(CLI::App& app);
void add_bench_command(CLI::App& app);
void add_ssao_command(CLI::App& app);
void add_light_command(CLI::App& app);
void add_pipeline_command(CLI::App& app);
void add_view_command(CLI::App& app);

/// Runs `dofkit render ARGS...` in this process, exactly as the command line would (same
/// parsing, checks and all-or-nothing output), with `progress` as the renderer's
/// RenderSettings::progress (cancelling makes it throw Cancelled, and no output is written).
/// Throws dofkit::Error like the command.
void run_render_command(const std::vector<std::string>& args, const ProgressCallback& progress);

}  // namespace dofkit::cli
