// Multi-layer input behind an in-focus subject (the held-out finding of issue 31): a deep file
// holds hidden fragments only where something hid them, so behind a subject it may hold none.
// A layer's hole is where every fragment of the pixel lies in front of the layer; such holes
// are filled for multi-layer input too. Left transparent, the far layer's hole behind the
// subject blurred into a dark halo around it.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "dofkit/render.hpp"

using namespace dofkit;

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr int kW = 96, kH = 64, kX0 = 36, kX1 = 60, kY0 = 20, kY1 = 44;  // the subject's square
constexpr float kBack[3] = {0.2f, 0.5f, 0.8f}, kSubject[3] = {0.9f, 0.3f, 0.1f};

// A far wall (12 m) and an in-focus square (4 m); with `hidden_layer`, a second layer that
// holds no fragment anywhere (the wall behind the square is unknown).
Frame frame(bool hidden_layer) {
  Frame f;
  f.color = Image(kW, kH, 4, 1.0f);
  f.depth = Image(kW, kH, 1, 12.0f);
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      const bool in = x >= kX0 && x < kX1 && y >= kY0 && y < kY1;
      for (int c = 0; c < 3; ++c) f.color.at(x, y, c) = in ? kSubject[c] : kBack[c];
      if (in) f.depth.at(x, y) = 4.0f;
    }
  if (hidden_layer) {
    f.layer_color = {f.color, Image(kW, kH, 4, 0.0f)};
    f.layer_depth = {f.depth, Image(kW, kH, 1, kInf)};
  }
  return f;
}

RenderSettings settings(const std::string& psf) {
  RenderSettings s;
  s.method = "layered";
  s.camera.model = BlurAtInfinity{4.0, 16.0};  // the wall: r = 16 (1 − 4/12) ≈ 10.7 px
  s.params["psf"] = psf;
  s.threads = 1;
  return s;
}

TEST(LayeredDeepHole, NoHaloAroundAnInFocusSubjectWithEmptyHiddenLayers) {
  for (const char* psf : {"gaussian", "disc"}) {
    SCOPED_TRACE(psf);
    const Image deep = render(frame(true), settings(psf)).image;
    const Image single = render(frame(false), settings(psf)).image;
    // The wall beside the square, 3 to 9 px from its left and right edges (inside the far
    // blur's reach of the hole, outside the in-focus subject): the wall's colour, as with
    // single-layer input, whose holes were always filled.
    float worst = 0.0f, worst_vs_single = 0.0f;
    for (int y = kY0 + 4; y < kY1 - 4; ++y)
      for (int d = 3; d <= 9; ++d)
        for (int x : {kX0 - d, kX1 - 1 + d})
          for (int c = 0; c < 3; ++c) {
            worst = std::max(worst, std::fabs(deep.at(x, y, c) - kBack[c]));
            worst_vs_single = std::max(worst_vs_single, std::fabs(deep.at(x, y, c) - single.at(x, y, c)));
          }
    EXPECT_LT(worst, 0.02f);
    EXPECT_LT(worst_vs_single, 0.02f);
    // The fill can be switched off; then the hole shows (what the rule above prevents).
    RenderSettings off = settings(psf);
    off.params["fill"] = "off";
    const Image holes = render(frame(true), off).image;
    float darkest = 1.0f;
    for (int y = kY0 + 4; y < kY1 - 4; ++y) darkest = std::min(darkest, holes.at(kX0 - 3, y, 2) / kBack[2]);
    EXPECT_LT(darkest, 0.9f) << "the test frame no longer has a hole behind the subject";
  }
}

}  // namespace
