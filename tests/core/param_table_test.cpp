// The parameter tables (methods/params.hpp): every table is well formed, and every method's
// parse site reads exactly the keys its table declares — a lookup of an undeclared key (or
// with the wrong type, or a per-case default without its case) throws Error(internal), and a
// declared key that no parse site reads is reported here. Each method renders a small frame
// with its defaults and with every value of every choice and on/off parameter, which takes
// each branch that selects what is read (mcguire's variants, layered's psf, sc2's presets).
#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <map>
#include <optional>
#include <regex>
#include <set>
#include <string>
#include <vector>

#include "core/parallel.hpp"
#include "effects/ssao/ssao.hpp"
#include "methods/method.hpp"
#include "scene/bench_frame.hpp"

using namespace dofkit;

namespace {

bool ends_with(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

void check_table(const std::string& method, const std::vector<ParamInfo>& table) {
  std::set<std::string> names;
  for (const ParamInfo& p : table) names.insert(p.name);
  EXPECT_EQ(names.size(), table.size()) << method << ": a key declared twice";
  for (const ParamInfo& p : table) {
    SCOPED_TRACE(method + " " + p.name);
    EXPECT_TRUE(std::regex_match(p.name, std::regex("[a-z][a-z0-9_]*")));
    EXPECT_FALSE(p.help.empty());
    for (const auto& [suffix, unit] :
         std::vector<std::pair<std::string, std::string>>{{"_px", "px"}, {"_deg", "deg"}, {"_m", "m"}})
      if (ends_with(p.name, suffix)) EXPECT_EQ(p.unit, unit) << "the name says " << unit;
    switch (p.type) {
      case ParamType::integer:
        EXPECT_EQ(p.min, static_cast<int>(p.min));
        EXPECT_EQ(p.max, static_cast<int>(p.max));
        EXPECT_TRUE(p.choices.empty());
        [[fallthrough]];
      case ParamType::real:
        EXPECT_LE(p.min, p.max);
        break;
      case ParamType::choice:
        EXPECT_GE(p.choices.size(), 2u);
        EXPECT_TRUE(p.unit.empty());
        break;
      case ParamType::boolean:
        EXPECT_TRUE(p.choices.empty());
        EXPECT_TRUE(p.unit.empty());
        break;
    }
    // Every default is a value the parameter accepts.
    std::vector<std::string> defaults;
    if (p.default_depends_on.empty()) {
      defaults.push_back(p.default_value);
    } else {
      EXPECT_FALSE(p.default_cases.empty());
      for (const auto& [when, def] : p.default_cases) defaults.push_back(def);
      const ParamInfo* selector = nullptr;
      for (const ParamInfo& q : table)
        if (q.name == p.default_depends_on) selector = &q;
      ASSERT_NE(selector, nullptr) << "depends on an undeclared key " << p.default_depends_on;
      EXPECT_EQ(selector->type, ParamType::choice);
      for (const auto& [when, def] : p.default_cases)
        EXPECT_NE(std::find(selector->choices.begin(), selector->choices.end(), when), selector->choices.end())
            << when << " is not a value of " << selector->name;
    }
    for (const std::string& d : defaults) EXPECT_NO_THROW(detail::check_param_value(method, p, d)) << d;
  }
}

// {} and, per choice / on-off parameter, each of its values alone.
std::vector<std::map<std::string, std::string>> settings_to_try(const std::vector<ParamInfo>& table) {
  std::vector<std::map<std::string, std::string>> out{{}};
  for (const ParamInfo& p : table) {
    if (p.type == ParamType::choice)
      for (const std::string& c : p.choices) out.push_back({{p.name, c}});
    if (p.type == ParamType::boolean)
      for (const char* v : {"on", "off"}) out.push_back({{p.name, v}});
  }
  return out;
}

std::set<std::string> names_of(const std::vector<ParamInfo>& table) {
  std::set<std::string> out;
  for (const ParamInfo& p : table) out.insert(p.name);
  return out;
}

TEST(ParamTable, EveryTableIsWellFormed) {
  int tables = 0;
  for (const detail::MethodDef* m : detail::all_methods()) {
    check_table(m->name, m->params);
    ++tables;
  }
  for (const MethodInfo& m : detail::ao::method_infos()) {
    check_table(m.name, m.params);
    ++tables;
  }
  EXPECT_GE(tables, 9);
}

TEST(ParamTable, EveryMethodReadsExactlyItsDeclaredKeys) {
  const int w = 40, h = 24;
  const Frame frame = scene::bench_frame(w, h);
  CameraModel camera = scene::bench_camera(w);
  camera.max_coc_px = 8;
  const CocFunction coc_of(camera, w);
  Image coc(w, h, 1);
  for (int y = 0; y < h; ++y) coc_of.evaluate(frame.depth.row(0, y), coc.row(0, y), w);
  int renders = 0;
  for (const detail::MethodDef* m : detail::all_methods()) {
    std::set<std::string> read;
    for (const auto& values : settings_to_try(m->params)) {
      std::string label = m->name;
      for (const auto& [k, v] : values) label += " " + k + "=" + v;
      SCOPED_TRACE(label);
      const detail::Params params(m->name, m->params, values);
      detail::DebugSink sink("");
      detail::Workspace ws;
      Image out(w, h, 4);
      EXPECT_NO_THROW(core::with_threads(1, [&] {
        m->render({frame, coc, camera, coc_of, params, sink, 1, ws, nullptr, nullptr}, out);
      }));
      const std::set<std::string> keys = params.keys_read();
      read.insert(keys.begin(), keys.end());
      ++renders;
    }
    EXPECT_EQ(read, names_of(m->params)) << m->name << ": declared keys no parse site reads (or the reverse)";
  }
  EXPECT_GT(renders, 40);
  for (const MethodInfo& m : detail::ao::method_infos()) {
    std::set<std::string> read;
    for (const auto& values : settings_to_try(m.params)) {
      std::set<std::string> keys;
      if (m.name == "sc2")
        EXPECT_NO_THROW(detail::ao::parse_sc2(values, &keys));
      else
        EXPECT_NO_THROW(detail::ao::parse_gtao(values, &keys));
      read.insert(keys.begin(), keys.end());
    }
    EXPECT_EQ(read, names_of(m.params)) << m.name;
  }
}

// The Error f throws (nullopt: none).
std::optional<Error> error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e;
  }
  return std::nullopt;
}

ErrorKind kind_of(const std::function<void()>& f) {
  const std::optional<Error> e = error_of(f);
  EXPECT_TRUE(e.has_value()) << "no error";
  return e ? e->kind() : ErrorKind::internal;
}

std::string message_of(const std::function<void()>& f) {
  const std::optional<Error> e = error_of(f);
  return e ? e->what() : "(no error)";
}

TEST(ParamTable, MisuseIsAnInternalError) {
  const std::vector<ParamInfo> table{
      detail::int_param("layers", 9, 3, 16, "", "layers"),
      detail::choice_param("psf", "auto", {"auto", "gaussian", "disc"}, "psf"),
      detail::float_param("band", detail::param_by("psf", {{"gaussian", 1.0}, {"disc", 0.25}}), 0, 1, "", "band"),
  };
  const std::map<std::string, std::string> none;
  const detail::Params p("t", table, none);
  EXPECT_EQ(kind_of([&] { p.get_int("nope"); }), ErrorKind::internal);
  EXPECT_EQ(kind_of([&] { p.has("nope"); }), ErrorKind::internal);
  EXPECT_EQ(kind_of([&] { p.get_double("layers"); }), ErrorKind::internal);        // declared int
  EXPECT_EQ(kind_of([&] { p.get_double("band"); }), ErrorKind::internal);          // which case?
  EXPECT_EQ(kind_of([&] { p.get_double("band", "auto"); }), ErrorKind::internal);  // no such case
  EXPECT_EQ(p.get_int("layers"), 9);
  EXPECT_EQ(p.get_double("band", "gaussian"), 1.0);
  EXPECT_EQ(p.get_double("band", "disc"), 0.25);
  EXPECT_EQ(p.get_choice("psf"), "auto");
  EXPECT_EQ(table[2].default_value, "1 (gaussian), 0.25 (disc)");
}

TEST(ParamTable, DefaultsAreWrittenShortAndExact) {
  EXPECT_EQ(detail::ParamDefault(40.0).text, "40");
  EXPECT_EQ(detail::ParamDefault(0.05).text, "0.05");
  EXPECT_EQ(detail::ParamDefault(0.3772).text, "0.3772");
  EXPECT_EQ(detail::ParamDefault(1e30).text, "1e+30");
  EXPECT_EQ(detail::ParamDefault(1 << 20).text, "1048576");
  EXPECT_EQ(detail::ParamDefault(true).text, "on");
  // The text reads back as the very double declared (a default parsed like a user's value).
  for (const double v : {0.6, 0.1, 1.0 / 3.0, 0.15, 1e-3, 2.172})
    EXPECT_EQ(std::stod(detail::ParamDefault(v).text), v) << detail::ParamDefault(v).text;
}

TEST(ParamTable, BadValuesAreUsageErrorsNamingTheKey) {
  const detail::MethodDef* layered = detail::find_method("layered");
  ASSERT_NE(layered, nullptr);
  const auto make = [&](std::map<std::string, std::string> v) {
    return [layered, v] { const detail::Params p("layered", layered->params, v); };
  };
  EXPECT_EQ(message_of(make({{"layers", "99"}})), "--set layers=99: must be in [3, 16] (method layered)");
  EXPECT_EQ(message_of(make({{"layers", "4.5"}})), "--set layers=4.5: must be an integer (method layered)");
  EXPECT_EQ(message_of(make({{"layers", "x"}})), "--set layers=x: not a number (method layered)");
  EXPECT_EQ(message_of(make({{"half_res", "maybe"}})), "--set half_res=maybe: must be on or off (method layered)");
  EXPECT_EQ(message_of(make({{"psf", "box"}})), "--set psf=box: must be one of auto, gaussian, disc (method layered)");
  EXPECT_EQ(kind_of(make({{"nope", "1"}})), ErrorKind::usage);
  EXPECT_NE(message_of(make({{"nope", "1"}})).find("unknown parameter for method layered"), std::string::npos);
  // A value is checked even where the method would not read it (quarter_res with half_res off).
  EXPECT_EQ(kind_of(make({{"half_res", "off"}, {"quarter_res", "x"}})), ErrorKind::usage);
  // sterna's kernel_scale takes auto or a number in range.
  const detail::MethodDef* sterna = detail::find_method("sterna");
  ASSERT_NE(sterna, nullptr);
  const std::map<std::string, std::string> automatic{{"kernel_scale", "auto"}}, scaled{{"kernel_scale", "0.7"}};
  EXPECT_FALSE(detail::Params("sterna", sterna->params, automatic).get_double_or_auto("kernel_scale"));
  EXPECT_EQ(detail::Params("sterna", sterna->params, scaled).get_double_or_auto("kernel_scale"), 0.7);
  const std::map<std::string, std::string> big{{"kernel_scale", "51"}};
  EXPECT_EQ(message_of([&] { const detail::Params p("sterna", sterna->params, big); }),
            "--set kernel_scale=51: must be in [0.01, 50] (method sterna)");
  // And through the library: the Renderer refuses it before any frame.
  RenderSettings s;
  s.method = "layered";
  s.params = {{"layers", "2"}};
  EXPECT_EQ(kind_of([&] { Renderer r(s); }), ErrorKind::usage);
}

}  // namespace
