// TEMPORARY placeholder: `dofkit quality` is being written (see the open issue); it reports
// that it is unavailable rather than pretending to work.
#include "commands.hpp"
#include "dofkit/error.hpp"

namespace dofkit::cli {

void add_quality_command(CLI::App& app) {
  auto* cmd = app.add_subcommand("quality", "(not available yet)");
  cmd->allow_extras();
  cmd->callback([] { throw_internal("dofkit quality is not implemented yet"); });
}

}  // namespace dofkit::cli
