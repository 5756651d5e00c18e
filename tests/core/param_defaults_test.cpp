// A parameter's declared default (its table row, methods/params.hpp: what `dofkit methods`,
// --help and the docs tables show) is the default in use: rendering with the parameter set to
// its declared default gives the same picture, bit for bit, as leaving it out. A default that
// depends on another parameter (ParamInfo::default_depends_on) is checked for each of its cases
// with that parameter set to the case.
#include <gtest/gtest.h>

#include <map>
#include <string>
#include <utility>
#include <vector>

#include "dofkit/render.hpp"
#include "scene/bench_frame.hpp"

using namespace dofkit;

namespace {

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
      if (p.default_depends_on.empty()) {
        EXPECT_EQ(picture({{p.name, p.default_value}}), picture({}))
            << m.name << " " << p.name << "=" << p.default_value;
        ++checked;
        continue;
      }
      for (const auto& [when, value] : p.default_cases) {
        const std::string& sel = p.default_depends_on;
        EXPECT_EQ(picture({{sel, when}, {p.name, value}}), picture({{sel, when}}))
            << m.name << " " << sel << "=" << when << " " << p.name << "=" << value;
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 50);  // every method's parameters, not a silently empty loop
}

}  // namespace
