// `dofkit methods`: lists the techniques, their parameters and debug views (`--json`: the same
// as one JSON document, which tests/docs/params_doc_test.py checks the docs tables against).
#include <iostream>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "dofkit/render.hpp"

namespace dofkit::cli {

namespace {
// One row of a method's parameter table: type, unit, default, range (int / float: [min, max],
// with the words accepted instead of a number) or choices, and the per-case defaults.
nlohmann::json param_json(const ParamInfo& p) {
  nlohmann::json j{{"name", p.name}, {"type", param_type_name(p.type)}, {"unit", p.unit}, {"default", p.default_value}};
  if (p.type == ParamType::integer || p.type == ParamType::real) {
    if (p.type == ParamType::integer)
      j["range"] = {static_cast<long long>(p.min), static_cast<long long>(p.max)};
    else
      j["range"] = {p.min, p.max};
    if (!p.choices.empty()) j["words"] = p.choices;
  } else if (p.type == ParamType::choice) {
    j["choices"] = p.choices;
  }
  if (!p.default_depends_on.empty()) {
    j["default_depends_on"] = p.default_depends_on;
    nlohmann::json cases = nlohmann::json::object();
    for (const auto& [value, def] : p.default_cases) cases[value] = def;
    j["default_cases"] = cases;
  }
  j["help"] = p.help;
  return j;
}
}  // namespace

void add_methods_command(CLI::App& app) {
  auto* cmd = app.add_subcommand("methods", "list the techniques with their --set parameters and debug views");
  static bool json = false;
  cmd->add_flag(
      "--json", json,
      "print the list as JSON: [{name, summary, params: [{name, type, unit, default, range | choices, help, …}], "
      "debug_views: [{name, help}]}]");
  cmd->callback([] {
    if (json) {
      nlohmann::json out = nlohmann::json::array();
      for (const auto& m : methods()) {
        nlohmann::json params = nlohmann::json::array(), views = nlohmann::json::array();
        for (const auto& p : m.params) params.push_back(param_json(p));
        for (const auto& v : m.debug_views) views.push_back({{"name", v.name}, {"help", v.help}});
        out.push_back({{"name", m.name}, {"summary", m.summary}, {"params", params}, {"debug_views", views}});
      }
      std::cout << out.dump(2) << "\n";
      return;
    }
    for (const auto& m : methods()) {
      std::cout << m.name << " — " << m.summary << "\n";
      for (const auto& p : m.params)
        std::cout << "    --set " << p.name << "=" << p.default_value << "  (" << param_kind(p) << ") " << p.help
                  << "\n";
      if (!m.debug_views.empty()) {
        std::cout << "    debug views:";
        for (const auto& v : m.debug_views) std::cout << " " << v.name;
        std::cout << "\n";
      }
    }
  });
}

}  // namespace dofkit::cli
