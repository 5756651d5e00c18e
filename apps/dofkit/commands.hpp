// The dofkit subcommands. Each lives in its own cmd_<name>.cpp and registers itself on the
// CLI11 app; errors are reported by throwing dofkit::Error (main turns them into one line
// on stderr and the exit code: usage 2, bad input 3, internal 1).
#pragma once
#include <CLI/CLI.hpp>

namespace dofkit::cli {

void add_render_command(CLI::App& app);
void add_methods_command(CLI::App& app);
void add_demo_command(CLI::App& app);
void add_scene_command(CLI::App& app);
void add_compare_command(CLI::App& app);
void add_quality_command(CLI::App& app);
void add_bench_command(CLI::App& app);
void add_ssao_command(CLI::App& app);

}  // namespace dofkit::cli
