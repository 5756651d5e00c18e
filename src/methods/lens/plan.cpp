#include "methods/lens/plan.hpp"

#include <algorithm>
#include <cmath>

namespace dofkit::detail::lens {

namespace {
// Anchors 0 < a_1 < a_2 … on one side of focus until `extent` is reached (the last one sits at
// `extent` exactly, so the outermost sources are on an anchor).
std::vector<float> side(float extent, const LensOptions& opt) {
  std::vector<float> a;
  float x = 0.0f;
  while (x < extent) {
    x += std::max(opt.slice_px, opt.slice_rel * x);
    // A last step of less than a quarter of a normal step is folded into the one before.
    if (x >= extent || extent - x < 0.25f * std::max(opt.slice_px, opt.slice_rel * x)) x = extent;
    a.push_back(x);
  }
  return a;
}

int level_of(float min_radius, const LensOptions& opt) {
  int level = 0;
  while (level < opt.max_level && min_radius >= opt.level_px * static_cast<float>(2 << level)) ++level;
  return level;
}
}  // namespace

SlicePlan plan_slices(float near_max, float far_max, const LensOptions& opt) {
  SlicePlan p;
  const std::vector<float> nears = side(near_max, opt), fars = side(far_max, opt);
  for (auto it = nears.rbegin(); it != nears.rend(); ++it) p.anchor.push_back(*it);
  p.anchor.push_back(0.0f);
  for (float f : fars) p.anchor.push_back(-f);
  const int k = p.count();
  p.level.resize(k);
  for (int j = 0; j < k; ++j) {
    // The smallest |CoC| a member of slice j can have: its inner neighbour anchor (the one
    // toward focus); the focus slice and its neighbours hold in-focus sources.
    const float a = p.anchor[j];
    float inner = 0.0f;
    if (a > 0 && j + 1 < k) inner = std::max(0.0f, p.anchor[j + 1]);
    if (a < 0 && j > 0) inner = std::max(0.0f, -p.anchor[j - 1]);
    p.level[j] = level_of(std::max(inner, opt.direct_px()), opt);
  }
  p.build_lookup();
  return p;
}

void SlicePlan::build_lookup() {
  const int k = count();
  const int bins = static_cast<int>((anchor[0] - anchor[k - 1]) * kBins) + 2;
  lookup_.assign(bins, 0);
  for (int b = 0; b < bins; ++b) {
    const float r = anchor[0] - static_cast<float>(b) / kBins;  // the bin's nearest CoC
    int j = 0;
    while (j + 1 < k && anchor[j + 1] >= r) ++j;
    lookup_[b] = std::min(j, k - 1);
  }
}

void SlicePlan::member(float r, int& j, float& t) const {
  const int k = count();
  if (r >= anchor[0]) {
    j = 0;
    t = 0.0f;
    return;
  }
  if (r <= anchor[k - 1]) {
    j = k - 1;
    t = 0.0f;
    return;
  }
  // First anchor below r (anchors decrease); r lies in (anchor[j+1], anchor[j]].
  const auto it = std::upper_bound(anchor.begin(), anchor.end(), r, [](float v, float a) { return v > a; });
  j = static_cast<int>(it - anchor.begin()) - 1;
  t = (anchor[j] - r) / (anchor[j] - anchor[j + 1]);
}

}  // namespace dofkit::detail::lens
