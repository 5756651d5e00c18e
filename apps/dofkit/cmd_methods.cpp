// `dofkit methods`: lists the techniques, their parameters and debug views (`--json`: the same
// as one JSON document, which tests/docs/params_doc_test.py checks the docs tables against).
#include <iostream>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "dofkit/render.hpp"

namespace dofkit::cli {

void add_methods_command(CLI::App& app) {
  auto* cmd = app.add_subcommand("methods", "list the techniques with their --set parameters and debug views");
  static bool json = false;
  cmd->add_flag(
      "--json", json,
      "print the list as JSON: [{name, summary, params: [{name, default, help}], debug_views: [{name, help}]}]");
  cmd->callback([] {
    if (json) {
      nlohmann::json out = nlohmann::json::array();
      for (const auto& m : methods()) {
        nlohmann::json params = nlohmann::json::array(), views = nlohmann::json::array();
        for (const auto& p : m.params)
          params.push_back({{"name", p.name}, {"default", p.default_value}, {"help", p.help}});
        for (const auto& v : m.debug_views) views.push_back({{"name", v.name}, {"help", v.help}});
        out.push_back({{"name", m.name}, {"summary", m.summary}, {"params", params}, {"debug_views", views}});
      }
      std::cout << out.dump(2) << "\n";
      return;
    }
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
