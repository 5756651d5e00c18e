// core/pass_profile: named scopes record nested paths in the order they first opened, sum
// repeated scopes, and record nothing while profiling is off. (No timing is asserted beyond
// times being non-negative.)
#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

#include "core/pass_profile.hpp"
#include "dofkit/render.hpp"
#include "scene/bench_frame.hpp"

namespace dofkit::core {
namespace {

std::vector<std::string> paths(const std::vector<PassTime>& t) {
  std::vector<std::string> p;
  for (const PassTime& x : t) p.push_back(x.path);
  return p;
}

TEST(PassProfile, NestedScopesRecordTheirPathsInFirstOpenOrder) {
  set_pass_profiling(true);
  for (int frame = 0; frame < 3; ++frame) {
    PassScope outer("method");
    { PassScope a("first"); }
    {
      PassScope b("second");
      PassScope c("inner");
    }
    { PassScope a("first"); }
  }
  { PassScope after("after"); }
  const std::vector<PassTime> t = take_pass_profile();
  set_pass_profiling(false);
  EXPECT_EQ(paths(t),
            (std::vector<std::string>{"method", "method/first", "method/second", "method/second/inner", "after"}));
  const int calls[] = {3, 6, 3, 3, 1};
  for (std::size_t i = 0; i < t.size(); ++i) {
    EXPECT_EQ(t[i].calls, calls[i]) << t[i].path;
    EXPECT_GE(t[i].ms, 0.0) << t[i].path;
  }
  EXPECT_TRUE(take_pass_profile().empty());  // taking cleared it
}

TEST(PassProfile, RecordsNothingWhileOff) {
  set_pass_profiling(false);
  { PassScope a("ignored"); }
  EXPECT_TRUE(take_pass_profile().empty());
  // A scope opened while off stays silent even if profiling starts before it closes.
  {
    PassScope a("opened while off");
    set_pass_profiling(true);
  }
  EXPECT_TRUE(take_pass_profile().empty());
  set_pass_profiling(false);
}

// Every method's render reports render()'s own steps and its passes under its name.
TEST(PassProfile, RenderReportsTheMethodsPasses) {
  const Frame frame = scene::bench_frame(96, 54);
  const std::vector<std::pair<std::string, std::string>> expect = {{"mcguire", "mcguire/horizontal"},
                                                                   {"sterna", "sterna/gather"},
                                                                   {"starcraft", "starcraft/medium + final"},
                                                                   {"layered", "layered/fused stack/layer blur"},
                                                                   {"reference", "reference"}};
  for (const auto& [method, pass] : expect) {
    SCOPED_TRACE(method);
    RenderSettings s;
    s.method = method;
    s.camera = scene::bench_camera(96);
    set_pass_profiling(true);
    render(frame, s);
    const std::vector<std::string> p = paths(take_pass_profile());
    set_pass_profiling(false);
    for (const std::string& want : {std::string("frame check"), std::string("coc map"), method, pass})
      EXPECT_NE(std::find(p.begin(), p.end(), want), p.end()) << want;
  }
}

}  // namespace
}  // namespace dofkit::core
