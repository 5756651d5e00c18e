// TEMPORARY placeholder: `dofkit render` is being written (see the open issue); it reports
// that it is unavailable rather than pretending to work.
#include "commands.hpp"
#include "dofkit/error.hpp"

namespace dofkit::cli {

void add_render_command(CLI::App& app) {
  auto* cmd = app.add_subcommand("render", "(not available yet)");
  cmd->allow_extras();
  cmd->callback([] { throw_internal("dofkit render is not implemented yet"); });
}

}  // namespace dofkit::cli
