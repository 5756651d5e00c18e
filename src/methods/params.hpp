// Method parameters, declared once. A method (or an AO method) lists its parameters as a
// table of ParamInfo made by the builders below (name, type, unit, default, range or choices,
// one line of help); Params validates the `--set` values against that table and the parse
// sites read them by name only, taking default and range from the table. Reading a name the
// table lacks, or with the wrong type, is a programming error (Error(internal), exit 1), which
// tests/core/param_table_test.cpp drives out of every method.
#pragma once
#include <initializer_list>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "dofkit/render.hpp"

namespace dofkit::detail {

/// Validated, typed access to a method's `--set` values by the method's parameter table.
class Params {
 public:
  /// Checks every value against `declared` (unknown key, not a number, out of range, not an
  /// integer, not on/off, not one of the choices: Error(usage) naming the key, the value and
  /// the method). `declared` and `values` must outlive this object.
  Params(std::string method, const std::vector<ParamInfo>& declared, const std::map<std::string, std::string>& values);
  Params(const Params&) = delete;
  Params& operator=(const Params&) = delete;

  /// Whether the user gave the key (it must be declared).
  bool has(const std::string& key) const;
  double get_double(const std::string& key) const;
  int get_int(const std::string& key) const;
  bool get_bool(const std::string& key) const;
  std::string get_choice(const std::string& key) const;
  /// A real parameter that also accepts the word "auto": nullopt for auto.
  std::optional<double> get_double_or_auto(const std::string& key) const;
  /// The same for a parameter whose default may depend on another parameter
  /// (ParamInfo::default_depends_on): `when` names the case in force, whose default applies.
  double get_double(const std::string& key, const std::string& when) const;
  int get_int(const std::string& key, const std::string& when) const;
  bool get_bool(const std::string& key, const std::string& when) const;

  /// The keys looked up so far (for the test that every declared key is read somewhere).
  std::set<std::string> keys_read() const;

 private:
  const ParamInfo& declared(const std::string& key, ParamType type) const;
  const std::string& text(const ParamInfo& p, const std::string* when) const;
  std::string method_;
  const std::vector<ParamInfo>& declared_;
  const std::map<std::string, std::string>& values_;
  mutable std::mutex mu_;
  mutable std::set<std::string> read_;
};

/// Throws Error(usage) unless `value` is valid for `p` (the messages of Params).
void check_param_value(const std::string& method, const ParamInfo& p, const std::string& value);

/// The text form of a default: shortest round-trip decimal for numbers, on/off for bools.
struct ParamDefault {
  ParamDefault(int v);  // implicit: the builders take 9, 0.6, true or "auto" alike
  ParamDefault(double v);
  ParamDefault(bool v);
  ParamDefault(const char* v);
  ParamDefault(std::string v);
  std::string text;
  /// Set by param_by(): the parameter the default depends on, and the default per value.
  std::string depends_on;
  std::vector<std::pair<std::string, std::string>> cases;
};

/// A default that depends on another parameter's value: param_by("variant", {{"demo", 4},
/// {"book", 2}, {"g3d", 2}}) lists as "4 (demo), 2 (book, g3d)".
ParamDefault param_by(std::string depends_on, std::initializer_list<std::pair<const char*, ParamDefault>> cases);

// The builders of a table row. `unit`: "px", "deg", "m" … or "" (dimensionless).
ParamInfo int_param(std::string name, const ParamDefault& def, int min, int max, std::string unit, std::string help);
ParamInfo float_param(std::string name, const ParamDefault& def, double min, double max, std::string unit,
                      std::string help);
/// A real parameter that also accepts "auto" (its default).
ParamInfo float_or_auto_param(std::string name, double min, double max, std::string unit, std::string help);
ParamInfo choice_param(std::string name, const ParamDefault& def, std::vector<std::string> choices, std::string help);
ParamInfo bool_param(std::string name, const ParamDefault& def, std::string help);

/// The row `reference` and `lens` share: how soft their depth test is.
ParamInfo depth_softness_param();

}  // namespace dofkit::detail
