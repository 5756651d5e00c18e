// Push-pull hole fill, fast form (oracle: inpaint.cpp's push_pull_fill; tests/layered hold
// push_pull_fill_fast to it bit for bit). Inputs: a matted layer and its hole mask (w·h bytes,
// 1 = disoccluded). Output: the layer with every hole pixel replaced (or, `under`, backed) by
// the pushed pyramid's value, opaque if asked. The pyramid levels live in the workspace; the
// pull of level 1 from the layer (or, in the fused stack, from the per-pixel codes:
// fused_pull.cpp) is the caller's, the pull of the levels above and the push back down are
// here.
#pragma once
#include <string>
#include <vector>

#include "dofkit/image.hpp"
#include "methods/method.hpp"

namespace dofkit::detail::layered {

// The push-pull pyramid above level 0 (levels 1 … L, down to 1×1), from the workspace.
struct Pyramid {
  std::vector<Image*> val{nullptr}, wgt{nullptr};  // index 0 unused (level 0 = the layer)
  int levels = 1;                                  // including level 0
};
Pyramid make_pyramid(Workspace& ws, int w, int h, const std::string& prefix = "layered.pp");

// Row y of pyramid level l + 1 (cv, cwt) pulled from level l (fine, fwt): pull_level's
// arithmetic, with shortcuts for empty and all-known blocks. Needs fine rows 2y and 2y + 1 (where it exists) only.
void pull_upper_row(const Image& fine, const Image& fwt, Image& cv, Image& cwt, int y);

// Pull of levels `first` … L (first >= 2) from the level below, then the push from the top
// down to level 1: v ← w v + (1 − w) up(v_{l+1}) where w < 1. With first = 3, level 2 has
// been pulled already, row by row, by the pass that wrote level 1 (pull_upper_row on level
// 1's rows while they were in cache): the same rows from the same inputs.
void pull_push_upper(const Pyramid& p, int first = 2);

// inpaint.cpp's final rules for a hole pixel j of the layer rows d, fill value v.
inline void finish_fill(bool opaque, bool under, float* const* d, int j, float* v) {
  if (opaque && v[3] > 1e-6f) {
    for (int k = 0; k < 3; ++k) v[k] /= v[3];
    v[3] = 1.0f;
  }
  if (under) {
    const float t = 1.0f - d[3][j];
    for (int k = 0; k < 4; ++k) d[k][j] += t * v[k];
  } else {
    for (int k = 0; k < 4; ++k) d[k][j] = v[k];
  }
}

}  // namespace dofkit::detail::layered
