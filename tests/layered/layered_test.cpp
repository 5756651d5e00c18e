// Properties of the layered method (docs/methods/layered.md): mattes, anchors, the Gaussian
// semigroup the recursion relies on, in-focus identity, hole filling and partial occlusion.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "core/filters.hpp"
#include "dofkit/render.hpp"
#include "methods/layered/anchors.hpp"
#include "methods/layered/composite.hpp"
#include "methods/layered/inpaint.hpp"

namespace {

using namespace dofkit;
using dofkit::detail::layered::LayerPlan;
using dofkit::detail::layered::plan_layers;
constexpr float kInf = std::numeric_limits<float>::infinity();

TEST(LayeredAnchors, PlanFollowsStackedSigma) {
  // Unit steps: the layer n steps from focus is blurred by sqrt(1² + … + n²) and its anchor
  // radius is that over sigma_per_radius.
  const LayerPlan p = plan_layers(7.48 * 1.0, 2.0, 16, 0.5, 1.0);
  EXPECT_EQ(p.focus, 3);
  EXPECT_EQ(p.count, 5);
  EXPECT_NEAR(p.total_sigma[0], std::sqrt(14.0) * p.scale_front, 1e-9);
  EXPECT_NEAR(p.anchor[0], 7.48, 1e-9);  // outermost anchor fitted to the extreme CoC
  EXPECT_NEAR(p.anchor[4], -2.0, 1e-9);
  EXPECT_EQ(p.anchor[p.focus], 0.0);
  for (int k = 0; k + 1 < p.count; ++k) EXPECT_GT(p.anchor[k], p.anchor[k + 1]);
  // Variances of the steps add up to the layer's total blur.
  double v = 0;
  for (int k = p.focus - 1; k >= 0; --k) {
    v += p.step_sigma[k] * p.step_sigma[k];
    EXPECT_NEAR(std::sqrt(v), p.total_sigma[k], 1e-9);
  }
}

TEST(LayeredAnchors, CapAndFocusOnlyScenes) {
  EXPECT_EQ(plan_layers(0.4, 0.5, 9).count, 1);  // all in focus: one layer
  const LayerPlan p = plan_layers(60, 30, 9);
  EXPECT_EQ(p.count, 9);
  EXPECT_NEAR(p.anchor.front(), 60, 1e-9);
  EXPECT_NEAR(p.anchor.back(), -30, 1e-9);
  EXPECT_EQ(plan_layers(60, 0.2, 9).focus, 8);  // nothing behind focus: no back layers
}

TEST(LayeredMattes, OneFragmentSumsToOneAcrossLayers) {
  // Composited front to back with "over", the copies of one opaque fragment cover exactly 1,
  // additively the weights lie in [1, 2) with at most two layers involved: the fragment is
  // whole in one layer and partial in the nearer neighbour.
  const LayerPlan p = plan_layers(25, 12, 9);
  for (float r = -30; r <= 30; r += 0.0137f) {
    double covered = 0, sum = 0;
    int used = 0;
    for (int k = 0; k < p.count; ++k) {
      const double w = p.weight(k, r);
      ASSERT_GE(w, 0.0);
      ASSERT_LE(w, 1.0);
      covered += (1 - covered) * w;
      sum += w;
      used += w > 0;
    }
    EXPECT_NEAR(covered, 1.0, 1e-6) << "r = " << r;
    EXPECT_LE(used, 2) << "r = " << r;
    EXPECT_GE(sum, 1.0 - 1e-6);
  }
  // At an anchor the fragment is whole in that layer (no interpolation).
  for (int k = 0; k < p.count; ++k) EXPECT_NEAR(p.weight(k, static_cast<float>(p.anchor[k])), 1.0f, 1e-6);
  // An exactly-in-focus fragment (r = 0, the focus anchor) is in the focus layer only, not
  // also in the first back layer (where it would be blurred into a halo).
  for (int j = 0; j < p.count; ++j) EXPECT_EQ(p.weight(j, 0.0f), j == p.focus ? 1.0f : 0.0f) << "layer " << j;
}

TEST(LayeredMattes, NearestMatteCountsEachFragmentOnce) {
  // band 0: one layer holds each fragment, at weight 1, the layer of the nearest anchor.
  LayerPlan p = plan_layers(25, 12, 9);
  p.band = 0;
  for (float r = -30; r <= 30; r += 0.0137f) {
    int used = 0, which = -1;
    for (int k = 0; k < p.count; ++k) {
      const float w = p.weight(k, r);
      ASSERT_TRUE(w == 0.0f || w == 1.0f);
      if (w > 0) ++used, which = k;
    }
    ASSERT_EQ(used, 1) << "r = " << r;
    for (int k = 0; k < p.count; ++k)
      EXPECT_LE(std::fabs(r - p.anchor[which]), std::fabs(r - p.anchor[k]) + 1e-4) << "r = " << r;
  }
}

TEST(LayeredMattes, NarrowBandRampsOnlyInTheMiddleOfTheGap) {
  // band 1/4 (the disc PSF's default): coverage under "over" is 1 everywhere; two layers share
  // a fragment only within the middle quarter of a gap, elsewhere it is whole in one.
  LayerPlan p = plan_layers(25, 12, 9);
  p.band = 0.25;
  for (float r = -30; r <= 30; r += 0.0137f) {
    double covered = 0;
    int used = 0;
    for (int k = 0; k < p.count; ++k) {
      const double w = p.weight(k, r);
      covered += (1 - covered) * w;
      used += w > 0;
    }
    EXPECT_NEAR(covered, 1.0, 1e-6) << "r = " << r;
    int k = 0;
    while (k + 1 < p.count && r < p.anchor[k + 1]) ++k;  // a_{k+1} <= r < a_k (or beyond)
    if (k + 1 < p.count && r < p.anchor[k]) {
      const double u = (r - p.anchor[k + 1]) / (p.anchor[k] - p.anchor[k + 1]);
      if (std::fabs(u - 0.5) > 0.125 + 1e-4) EXPECT_EQ(used, 1) << "r = " << r << ", u = " << u;
      if (std::fabs(u - 0.5) < 0.125 - 1e-4) EXPECT_EQ(used, 2) << "r = " << r << ", u = " << u;
    }
  }
}

TEST(LayeredBlur, TwoStepsEqualOneOfCombinedSigma) {
  // The recursion relies on H(σ₂) ∗ H(σ₁) = H(sqrt(σ₁² + σ₂²)); the extended-box Gaussians
  // match variance exactly and shape to ~1 %, so two steps and one step agree closely.
  const int w = 96, h = 64;
  Image a(w, h, 4, 0.0f);
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(0, 1);
  for (int y = 20; y < 44; ++y)
    for (int x = 30; x < 60; ++x) {
      const float al = u(rng);
      for (int c = 0; c < 3; ++c) a.at(x, y, c) = al * u(rng);
      a.at(x, y, 3) = al;
    }
  for (auto [s1, s2] : {std::pair{1.0f, 2.0f}, {3.0f, 4.0f}, {2.5f, 6.0f}}) {
    Image two = a, one = a;
    core::gaussian_blur(two, s1);
    core::gaussian_blur(two, s2);
    core::gaussian_blur(one, std::sqrt(s1 * s1 + s2 * s2));
    double worst = 0, peak = 0;
    for (std::size_t i = 0; i < one.data().size(); ++i) {
      worst = std::max(worst, static_cast<double>(std::fabs(one.data()[i] - two.data()[i])));
      peak = std::max(peak, static_cast<double>(one.data()[i]));
    }
    EXPECT_LT(worst, 0.01 * peak) << s1 << " then " << s2;  // measured: below 0.5 % of peak
  }
}

// A synthetic frame: background at 10 m (green), a vertical bar at 1 m (red) in columns
// [bx0, bx1); optionally a hidden fragment behind the bar (blue, also at 10 m).
Frame bar_frame(int w, int h, int bx0, int bx1, bool hidden) {
  Frame f;
  f.color = Image(w, h, 4, 0.0f);
  f.depth = Image(w, h, 1, 10.0f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const bool bar = x >= bx0 && x < bx1;
      f.color.at(x, y, bar ? 0 : 1) = 0.8f;
      f.color.at(x, y, 3) = 1.0f;
      if (bar) f.depth.at(x, y) = 1.0f;
    }
  if (hidden) {
    f.layer_color = {f.color, Image(w, h, 4, 0.0f)};
    f.layer_depth = {f.depth, Image(w, h, 1, kInf)};
    for (int y = 0; y < h; ++y)
      for (int x = bx0; x < bx1; ++x) {
        f.layer_color[1].at(x, y, 2) = 0.8f;
        f.layer_color[1].at(x, y, 3) = 1.0f;
        f.layer_depth[1].at(x, y) = 10.0f;
      }
  }
  return f;
}

// psf=gaussian pins S&W's recursive Gaussian (the default for multi-layer input is the disc).
RenderSettings layered_settings(double focus_m, double k_px, const char* psf = "gaussian") {
  RenderSettings rs;
  rs.method = "layered";
  rs.camera.model = BlurAtInfinity{focus_m, k_px};
  rs.params["psf"] = psf;
  return rs;
}

TEST(Layered, SceneInFocusLayerIsUnchanged) {
  // Every CoC within ±0.5 px: one layer, returned as is (single and multi-layer input).
  for (const char* psf : {"gaussian", "disc"})
    for (bool hidden : {false, true}) {
      Frame f = bar_frame(64, 40, 20, 30, hidden);
      const RenderResult r = render(f, layered_settings(5.0, 0.05, psf));
      ASSERT_EQ(r.image.data().size(), f.color.data().size());
      EXPECT_EQ(r.image.data(), f.color.data()) << (hidden ? "multi " : "single ") << psf;
    }
}

TEST(Layered, DiscPartialOcclusionShowsHiddenBackground) {
  // As below with the disc PSF (the default for multi-layer input): the 6 px bar with an
  // 18 px CoC radius covers at most 6 / 37 of the centre's disc, so mostly the hidden blue
  // fragment behind it is seen; the result stays opaque.
  const int w = 120, h = 48, bx0 = 57, bx1 = 63;
  RenderSettings rs = layered_settings(10.0, 2.0, "disc");
  const RenderResult multi = render(bar_frame(w, h, bx0, bx1, true), rs);
  const int cx = 60, cy = h / 2;
  EXPECT_GT(multi.image.at(cx, cy, 2), 0.5f);
  EXPECT_LT(multi.image.at(cx, cy, 0), 0.25f);
  EXPECT_NEAR(multi.image.at(cx, cy, 3), 1.0f, 1e-4);
  rs.params.erase("psf");  // auto: disc for multi-layer input
  EXPECT_EQ(render(bar_frame(w, h, bx0, bx1, true), rs).image.data(), multi.image.data());
}

TEST(Layered, PartialOcclusionShowsHiddenBackground) {
  // Focus on the background; the 6 px bar at 1 m has r = K (10/1 − 1) = 9·2 = 18 px, far
  // wider than itself, so a real lens sees mostly what is behind it — the blue hidden
  // fragment — through its middle.
  const int w = 120, h = 48, bx0 = 57, bx1 = 63;
  const RenderSettings rs = layered_settings(10.0, 2.0);
  const RenderResult multi = render(bar_frame(w, h, bx0, bx1, true), rs);
  const RenderResult single = render(bar_frame(w, h, bx0, bx1, false), rs);
  const int cx = 60, cy = h / 2;
  EXPECT_GT(multi.image.at(cx, cy, 2), 0.3f);  // hidden blue shows through the blurred bar
  EXPECT_LT(multi.image.at(cx, cy, 0), 0.5f);  // the bar is mostly transparent there
  EXPECT_NEAR(multi.image.at(cx, cy, 3), 1.0f, 1e-4);
  // Single-layer input knows nothing of the blue: it is filled from the background (green).
  EXPECT_LT(single.image.at(cx, cy, 2), 1e-4f);
  EXPECT_GT(single.image.at(cx, cy, 1), 0.3f);
}

TEST(Layered, SingleLayerHolesAreFilledNeverDark) {
  // A blurred near bar in front of a sharp background: behind the bar's blurred edge the
  // background must be inpainted (green), not black or transparent.
  const int w = 120, h = 48;
  const RenderResult r = render(bar_frame(w, h, 40, 80, false), layered_settings(10.0, 2.0));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      EXPECT_NEAR(r.image.at(x, y, 3), 1.0f, 1e-4) << x << "," << y;
      const float sum = r.image.at(x, y, 0) + r.image.at(x, y, 1);  // red + green = 0.8 everywhere
      EXPECT_NEAR(sum, 0.8f, 0.02f) << x << "," << y;
    }
}

TEST(LayeredInpaint, PushPullExtrapolatesTheLayer) {
  // A layer with constant colour around a hole is filled with the same colour; a hole
  // bordered by content on one side only is filled partly transparent.
  Image layer(32, 16, 4, 0.0f);
  std::vector<std::uint8_t> hole(layer.plane_size(), 0);
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 32; ++x) {
      if (x >= 12 && x < 20) {
        hole[y * 32 + x] = 1;
        continue;
      }
      if (x < 12) {
        layer.at(x, y, 0) = 0.5f;
        layer.at(x, y, 3) = 1.0f;
      }  // content on the left only
    }
  Image filled = layer;
  detail::layered::push_pull_fill(filled, hole, false);
  const float a = filled.at(16, 8, 3);
  EXPECT_GT(a, 0.2f);
  EXPECT_LT(a, 0.8f);
  EXPECT_NEAR(filled.at(16, 8, 0) / a, 0.5f, 1e-4);  // colour is the layer's own
  EXPECT_EQ(filled.at(3, 3, 0), 0.5f);               // known pixels untouched
  // under: what the layer holds at a hole pixel (a hidden fragment) stays in front of the fill.
  Image held = layer;
  held.at(16, 8, 2) = 0.3f;
  held.at(16, 8, 3) = 0.6f;
  detail::layered::push_pull_fill(held, hole, false, true);
  EXPECT_NEAR(held.at(16, 8, 3), 0.6f + 0.4f * a, 1e-5);
  EXPECT_NEAR(held.at(16, 8, 2), 0.3f, 1e-6);  // the fill has no blue
  EXPECT_NEAR(held.at(16, 8, 0), 0.4f * filled.at(16, 8, 0), 1e-5);
  Image opaque = layer;
  detail::layered::push_pull_fill(opaque, hole, true);
  EXPECT_EQ(opaque.at(16, 8, 3), 1.0f);
  EXPECT_NEAR(opaque.at(16, 8, 0), 0.5f, 1e-4);
}

TEST(Layered, SameResultForAnyThreadCountAndDebugViews) {
  for (const char* psf : {"gaussian", "disc"})
    for (bool hidden : {true, false}) {
      Frame f = bar_frame(90, 50, 30, 50, hidden);
      RenderSettings rs = layered_settings(10.0, 3.0, psf);
      rs.threads = 1;
      const RenderResult one = render(f, rs);
      rs.threads = 2;
      const RenderResult two = render(f, rs);
      EXPECT_EQ(one.image.data(), two.image.data()) << psf << (hidden ? " multi" : " single");
      for (const char* view : {"front", "back", "layer_0_matted", "layer_0_blurred"}) {
        rs.debug_view = view;
        const RenderResult d = render(f, rs);
        EXPECT_EQ(d.debug.width(), 90) << view;
        EXPECT_EQ(d.debug.channels(), 4) << view;
      }
    }
}

}  // namespace
