// TEMPORARY placeholder: `dofkit demo` is being written (see the open issue); it reports
// that it is unavailable rather than pretending to work.
#include "commands.hpp"
#include "dofkit/error.hpp"

namespace dofkit::cli {

void add_demo_command(CLI::App& app) {
  auto* cmd = app.add_subcommand("demo", "(not available yet)");
  cmd->allow_extras();
  cmd->callback([] { throw_internal("dofkit demo is not implemented yet"); });
}

}  // namespace dofkit::cli
