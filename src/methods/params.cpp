// Method parameter tables: validation, typed lookup by name, the builders (params.hpp).
#include "methods/params.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "dofkit/error.hpp"

namespace dofkit {

const char* param_type_name(ParamType type) {
  switch (type) {
    case ParamType::integer:
      return "int";
    case ParamType::real:
      return "float";
    case ParamType::choice:
      return "choice";
    case ParamType::boolean:
      return "bool";
  }
  return "?";
}

namespace {
std::string joined(const std::vector<std::string>& names, const char* sep = ", ") {
  std::string s;
  for (const auto& n : names) s += (s.empty() ? "" : sep) + n;
  return s;
}
std::string number(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}
}  // namespace

std::string param_kind(const ParamInfo& p) {
  switch (p.type) {
    case ParamType::integer:
    case ParamType::real: {
      std::string s = std::string(param_type_name(p.type)) + " " + number(p.min) + ".." + number(p.max);
      if (!p.unit.empty()) s += " " + p.unit;
      if (!p.choices.empty()) s += " or " + joined(p.choices, " or ");
      return s;
    }
    case ParamType::choice:
      return "one of " + joined(p.choices);
    case ParamType::boolean:
      return "on/off";
  }
  return "";
}

namespace detail {

namespace {

[[noreturn]] void bad_param(const std::string& method, const std::string& key, const std::string& value,
                            const std::string& why) {
  throw_usage("--set " + key + "=" + value + ": " + why + " (method " + method + ")");
}

[[noreturn]] void misuse(const std::string& method, const std::string& key, const std::string& why) {
  throw_internal("method " + method + " reads parameter " + key + ": " + why);
}

bool word_of(const ParamInfo& p, const std::string& v) {
  return std::find(p.choices.begin(), p.choices.end(), v) != p.choices.end();
}

// The value as a number in [min, max] (the one parser of numbers: user values and defaults).
double parse_number(const std::string& method, const ParamInfo& p, const std::string& v) {
  double d;
  try {
    std::size_t used = 0;
    d = std::stod(v, &used);
    if (used != v.size()) throw std::invalid_argument(v);
  } catch (const std::exception&) {
    bad_param(method, p.name, v, "not a number");
  }
  if (!(d >= p.min && d <= p.max))
    bad_param(method, p.name, v, "must be in [" + number(p.min) + ", " + number(p.max) + "]");
  if (p.type == ParamType::integer && d != std::floor(d)) bad_param(method, p.name, v, "must be an integer");
  return d;
}

bool parse_bool(const std::string& method, const ParamInfo& p, const std::string& v) {
  if (v == "on" || v == "true" || v == "1" || v == "yes") return true;
  if (v == "off" || v == "false" || v == "0" || v == "no") return false;
  bad_param(method, p.name, v, "must be on or off");
}

}  // namespace

void check_param_value(const std::string& method, const ParamInfo& p, const std::string& value) {
  switch (p.type) {
    case ParamType::integer:
    case ParamType::real:
      if (!word_of(p, value)) parse_number(method, p, value);
      return;
    case ParamType::choice:
      if (!word_of(p, value)) bad_param(method, p.name, value, "must be one of " + joined(p.choices));
      return;
    case ParamType::boolean:
      parse_bool(method, p, value);
      return;
  }
}

Params::Params(std::string method, const std::vector<ParamInfo>& declared,
               const std::map<std::string, std::string>& values)
    : method_(std::move(method)), declared_(declared), values_(values) {
  for (const auto& [key, value] : values_) {
    const auto it =
        std::find_if(declared_.begin(), declared_.end(), [&key = key](const ParamInfo& p) { return p.name == key; });
    if (it == declared_.end()) {
      std::vector<std::string> names;
      for (const ParamInfo& p : declared_) names.push_back(p.name);
      throw_usage("--set " + key + "=" + value + ": unknown parameter for method " + method_ +
                  (names.empty() ? std::string(" (it has none)") : " (known: " + joined(names) + ")"));
    }
    check_param_value(method_, *it, value);
  }
}

const ParamInfo& Params::declared(const std::string& key, ParamType type) const {
  const auto it = std::find_if(declared_.begin(), declared_.end(), [&](const ParamInfo& p) { return p.name == key; });
  if (it == declared_.end()) misuse(method_, key, "not in the method's parameter table");
  if (it->type != type)
    misuse(method_, key, std::string("declared ") + param_type_name(it->type) + ", read as " + param_type_name(type));
  const std::lock_guard<std::mutex> lock(mu_);
  read_.insert(key);
  return *it;
}

const std::string& Params::text(const ParamInfo& p, const std::string* when) const {
  const auto it = values_.find(p.name);
  if (it != values_.end()) return it->second;
  if (p.default_depends_on.empty()) return p.default_value;  // one default for every case
  if (!when) misuse(method_, p.name, "its default depends on " + p.default_depends_on + ": say which case");
  for (const auto& [value, def] : p.default_cases)
    if (value == *when) return def;
  misuse(method_, p.name, "no default declared for " + p.default_depends_on + "=" + *when);
}

bool Params::has(const std::string& key) const {
  const auto it = std::find_if(declared_.begin(), declared_.end(), [&](const ParamInfo& p) { return p.name == key; });
  if (it == declared_.end()) misuse(method_, key, "not in the method's parameter table");
  return values_.count(key) != 0;
}

double Params::get_double(const std::string& key) const {
  const ParamInfo& p = declared(key, ParamType::real);
  if (!p.choices.empty()) misuse(method_, key, "it also takes words: use get_double_or_auto");
  return parse_number(method_, p, text(p, nullptr));
}

double Params::get_double(const std::string& key, const std::string& when) const {
  const ParamInfo& p = declared(key, ParamType::real);
  return parse_number(method_, p, text(p, &when));
}

std::optional<double> Params::get_double_or_auto(const std::string& key) const {
  const ParamInfo& p = declared(key, ParamType::real);
  if (p.choices != std::vector<std::string>{"auto"}) misuse(method_, key, "it does not take auto");
  const std::string& v = text(p, nullptr);
  if (v == "auto") return std::nullopt;
  return parse_number(method_, p, v);
}

int Params::get_int(const std::string& key) const {
  const ParamInfo& p = declared(key, ParamType::integer);
  return static_cast<int>(parse_number(method_, p, text(p, nullptr)));
}

int Params::get_int(const std::string& key, const std::string& when) const {
  const ParamInfo& p = declared(key, ParamType::integer);
  return static_cast<int>(parse_number(method_, p, text(p, &when)));
}

bool Params::get_bool(const std::string& key) const {
  const ParamInfo& p = declared(key, ParamType::boolean);
  return parse_bool(method_, p, text(p, nullptr));
}

bool Params::get_bool(const std::string& key, const std::string& when) const {
  const ParamInfo& p = declared(key, ParamType::boolean);
  return parse_bool(method_, p, text(p, &when));
}

std::string Params::get_choice(const std::string& key) const {
  const ParamInfo& p = declared(key, ParamType::choice);
  const std::string& v = text(p, nullptr);
  check_param_value(method_, p, v);
  return v;
}

std::set<std::string> Params::keys_read() const {
  const std::lock_guard<std::mutex> lock(mu_);
  return read_;
}

// ---- builders

namespace {
// Shortest decimal that reads back as the same double (so a default's text is exact), fixed
// notation unless scientific is shorter ("40", "0.05", "1e+30").
std::string shortest(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

ParamInfo row(std::string name, ParamType type, const ParamDefault& def, std::string unit, std::string help) {
  ParamInfo p;
  p.name = std::move(name);
  p.type = type;
  p.unit = std::move(unit);
  p.help = std::move(help);
  p.default_value = def.text;
  p.default_depends_on = def.depends_on;
  p.default_cases = def.cases;
  return p;
}
}  // namespace

ParamDefault::ParamDefault(int v) : text(std::to_string(v)) {}
ParamDefault::ParamDefault(double v) : text(shortest(v)) {}
ParamDefault::ParamDefault(bool v) : text(v ? "on" : "off") {}
ParamDefault::ParamDefault(const char* v) : text(v) {}
ParamDefault::ParamDefault(std::string v) : text(std::move(v)) {}

ParamDefault param_by(std::string depends_on, std::initializer_list<std::pair<const char*, ParamDefault>> cases) {
  ParamDefault d("");
  d.depends_on = std::move(depends_on);
  // "4 (demo), 2 (book, g3d)": equal defaults grouped, in the order of their first case.
  std::vector<std::pair<std::string, std::vector<std::string>>> groups;
  for (const auto& [value, def] : cases) {
    d.cases.emplace_back(value, def.text);
    auto g = std::find_if(groups.begin(), groups.end(), [&def = def](const auto& x) { return x.first == def.text; });
    if (g == groups.end())
      groups.push_back({def.text, {value}});
    else
      g->second.push_back(value);
  }
  for (const auto& [text, values] : groups) d.text += (d.text.empty() ? "" : ", ") + text + " (" + joined(values) + ")";
  return d;
}

ParamInfo int_param(std::string name, const ParamDefault& def, int min, int max, std::string unit, std::string help) {
  ParamInfo p = row(std::move(name), ParamType::integer, def, std::move(unit), std::move(help));
  p.min = min;
  p.max = max;
  return p;
}

ParamInfo float_param(std::string name, const ParamDefault& def, double min, double max, std::string unit,
                      std::string help) {
  ParamInfo p = row(std::move(name), ParamType::real, def, std::move(unit), std::move(help));
  p.min = min;
  p.max = max;
  return p;
}

ParamInfo float_or_auto_param(std::string name, double min, double max, std::string unit, std::string help) {
  ParamInfo p = float_param(std::move(name), "auto", min, max, std::move(unit), std::move(help));
  p.choices = {"auto"};
  return p;
}

ParamInfo choice_param(std::string name, const ParamDefault& def, std::vector<std::string> choices, std::string help) {
  ParamInfo p = row(std::move(name), ParamType::choice, def, "", std::move(help));
  p.choices = std::move(choices);
  return p;
}

ParamInfo bool_param(std::string name, const ParamDefault& def, std::string help) {
  return row(std::move(name), ParamType::boolean, def, "", std::move(help));
}

ParamInfo depth_softness_param() {
  return float_param("depth_softness", 0.05, 0.001, 1.0, "",
                     "relative inverse-depth difference over which a source becomes 'in front'");
}

}  // namespace detail
}  // namespace dofkit
