// `dofkit methods`: lists the techniques, their parameters and debug views.
#include <iostream>

#include "commands.hpp"
#include "dofkit/render.hpp"

namespace dofkit::cli {

void add_methods_command(CLI::App& app) {
  auto* cmd = app.add_subcommand("methods", "list the techniques with their --set parameters and debug views");
  cmd->callback([] {
    for (const auto& m : methods()) {
      std::cout << m.name << " — " << m.summary << "\n";
      for (const auto& p : m.params)
        std::cout << "    --set " << p.name << "=" << p.default_value << "  " << p.help << "\n";
      if (!m.debug_views.empty()) {
        std::cout << "    debug views:";
        for (const auto& v : m.debug_views) std::cout << " " << v.name;
        std::cout << "\n";
      }
    }
  });
}

}  // namespace dofkit::cli
