// Every method parameter is declared in two places: its ParamInfo (what `dofkit methods`, --help
// and the docs tables show) and the call that reads it with its default. This holds them
// together: rendering with a parameter set to its declared default gives the same picture,
// bit for bit, as leaving it out. A default that depends on another parameter is declared as
// "VALUE (a, b), VALUE (c)" (or with " / "): then it is checked for each of those values of the
// selector parameter.
#include <gtest/gtest.h>

#include <map>
#include <regex>
#include <string>
#include <utility>
#include <vector>

#include "dofkit/render.hpp"
#include "scene/bench_frame.hpp"

using namespace dofkit;

namespace {

// The parameter that a method's conditional defaults name the values of.
const std::map<std::string, std::string> kSelector = {{"mcguire", "variant"}, {"layered", "psf"}};

// "4 (demo), 2 (book, g3d)" → {{"4", {"demo"}}, {"2", {"book", "g3d"}}}; "0.5" → {{"0.5", {}}}.
std::vector<std::pair<std::string, std::vector<std::string>>> parse_default(const std::string& text) {
  std::vector<std::pair<std::string, std::vector<std::string>>> out;
  const std::regex part(R"(\s*([^\s(,/]+)\s*\(([^)]*)\)\s*[,/]?)");
  auto it = std::sregex_iterator(text.begin(), text.end(), part);
  if (it == std::sregex_iterator()) return {{text, {}}};
  std::size_t consumed = 0;
  for (; it != std::sregex_iterator(); ++it) {
    std::vector<std::string> when;
    const std::string list = (*it)[2];
    const std::regex word(R"([A-Za-z0-9_.]+)");
    for (auto w = std::sregex_iterator(list.begin(), list.end(), word); w != std::sregex_iterator(); ++w)
      when.push_back(w->str());
    out.emplace_back((*it)[1], when);
    consumed += it->length();
  }
  EXPECT_EQ(consumed, text.size()) << "unparsed default text: " << text;
  return out;
}

TEST(ParamDefaults, DeclaredDefaultIsTheDefaultInUse) {
  const Frame frame = scene::bench_frame(48, 32);
  int checked = 0;
  for (const MethodInfo& m : methods()) {
    auto picture = [&](std::map<std::string, std::string> params) {
      RenderSettings s;
      s.method = m.name;
      s.camera.model = BlurAtInfinity{4.0, 12.0};
      s.camera.max_coc_px = 12;
      s.threads = 1;
      s.params = std::move(params);
      return render(frame, s).image.data();
    };
    for (const ParamInfo& p : m.params) {
      for (const auto& [value, when] : parse_default(p.default_value)) {
        if (when.empty()) {
          EXPECT_EQ(picture({{p.name, value}}), picture({})) << m.name << " " << p.name << "=" << value;
          ++checked;
          continue;
        }
        ASSERT_TRUE(kSelector.count(m.name)) << m.name << " " << p.name << ": a conditional default ("
                                             << p.default_value << ") but no selector parameter is known";
        const std::string& sel = kSelector.at(m.name);
        for (const std::string& w : when) {
          EXPECT_EQ(picture({{sel, w}, {p.name, value}}), picture({{sel, w}}))
              << m.name << " " << sel << "=" << w << " " << p.name << "=" << value;
          ++checked;
        }
      }
    }
  }
  EXPECT_GT(checked, 50);  // every method's parameters, not a silently empty loop
}

}  // namespace
