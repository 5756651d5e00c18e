// Depth at another resolution than the colour (depth_resample.hpp): the size/aspect check,
// nearest and bilinear exactly, guided snapping a depth edge to the colour edge without blending
// the two sides, and the same
// output for any thread count. Tiny images.
#include <gtest/gtest.h>

#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "dofkit/error.hpp"
#include "io/depth_resample.hpp"

using namespace dofkit;

namespace {

int code_of(const std::function<void()>& fn, std::string* message = nullptr) {
  try {
    fn();
  } catch (const Error& e) {
    if (message) *message = e.what();
    return e.exit_code();
  }
  return 0;
}

// 64x48 colour: dark left of column 30, bright from it; depth 1 m there, 4 m right of it.
struct EdgeScene {
  Image color{64, 48, 4, 1.0f}, full{64, 48, 1}, low{16, 12, 1};
  EdgeScene() {
    for (int y = 0; y < 48; ++y)
      for (int x = 0; x < 64; ++x) {
        const bool left = x < 30;
        for (int c = 0; c < 3; ++c) color.at(x, y, c) = left ? 0.05f : 0.8f;
        full.at(x, y) = left ? 1.0f : 4.0f;
      }
    // Box 4x down-sampled in z, as a phone or a resize would give it (column 7 mixes both).
    for (int j = 0; j < 12; ++j)
      for (int i = 0; i < 16; ++i) {
        double s = 0;
        for (int y = 4 * j; y < 4 * j + 4; ++y)
          for (int x = 4 * i; x < 4 * i + 4; ++x) s += full.at(x, y);
        low.at(i, j) = static_cast<float>(s / 16);
      }
  }
};

}  // namespace

TEST(DepthFit, SameAspectSmallerIsAcceptedOtherAspectNeedsStretch) {
  EXPECT_EQ(code_of([] { io::check_depth_fit("d", 320, 180, "c", 1280, 720, false); }), 0);
  EXPECT_EQ(code_of([] { io::check_depth_fit("d", 427, 240, "c", 1280, 720, false); }), 0);  // 3:1, rounded
  EXPECT_EQ(code_of([] { io::check_depth_fit("d", 64, 48, "c", 64, 48, false); }), 0);
  std::string m;
  EXPECT_EQ(code_of([] { io::check_depth_fit("d.png", 320, 320, "c.jpg", 1280, 720, false); }, &m), 3);
  EXPECT_NE(m.find("d.png: depth is 320x320 but colour c.jpg is 1280x720"), std::string::npos) << m;
  EXPECT_NE(m.find("--depth-fit stretch"), std::string::npos) << m;
  EXPECT_EQ(code_of([] { io::check_depth_fit("d", 320, 320, "c", 1280, 720, true); }), 0);
  EXPECT_EQ(code_of([] { io::check_depth_fit("d", 1281, 720, "c", 1280, 720, true); }, &m), 3);
  EXPECT_NE(m.find("larger"), std::string::npos) << m;
}

TEST(DepthResample, NearestAndBilinearAreExact) {
  Image d(2, 1, 1);
  d.at(0, 0) = 1.0f;
  d.at(1, 0) = std::numeric_limits<float>::infinity();
  const Image c(8, 4, 4, 0.5f);
  const Image n = io::resample_depth(d, c, io::DepthUpsample::nearest);
  for (int x = 0; x < 8; ++x) EXPECT_EQ(n.at(x, 2), x < 4 ? 1.0f : d.at(1, 0)) << x;
  // Bilinear in 1/z: colour x ↦ u = (x + 0.5)/4 − 0.5; w = 1 − u between the two samples.
  const Image b = io::resample_depth(d, c, io::DepthUpsample::bilinear);
  EXPECT_EQ(b.at(0, 0), 1.0f);  // clamped to the first sample
  EXPECT_EQ(b.at(1, 0), 1.0f);
  EXPECT_FLOAT_EQ(b.at(2, 0), static_cast<float>(1.0 / (1.0 - 0.125)));
  EXPECT_FLOAT_EQ(b.at(5, 0), static_cast<float>(1.0 / (1.0 - 0.875)));
  EXPECT_TRUE(std::isinf(b.at(7, 0)));
}

TEST(DepthResample, GuidedPutsTheDepthEdgeOnTheColourEdge) {
  const EdgeScene s;
  const Image g = io::resample_depth(s.low, s.color, io::DepthUpsample::guided);
  const Image b = io::resample_depth(s.low, s.color, io::DepthUpsample::bilinear);
  // Within 5 % of the true depth: guided gets (nearly) every pixel of the 24..35 band around the edge
  // right, bilinear smears the 4x mixed column over it.
  int guided_ok = 0, bilinear_ok = 0;
  for (int y = 0; y < 48; ++y)
    for (int x = 24; x < 36; ++x) {
      const float t = s.full.at(x, y);
      guided_ok += std::fabs(g.at(x, y) - t) <= 0.05f * t;
      bilinear_ok += std::fabs(b.at(x, y) - t) <= 0.05f * t;
    }
  EXPECT_GE(guided_ok, 48 * 12 * 9 / 10) << "guided " << guided_ok << ", bilinear " << bilinear_ok;
  EXPECT_LT(bilinear_ok, 48 * 12 / 2);
  // Far from the edge every method gives the flat depth.
  EXPECT_FLOAT_EQ(g.at(2, 10), 1.0f);
  EXPECT_FLOAT_EQ(g.at(60, 10), 4.0f);
}

TEST(DepthResample, GuidedNeverBlendsTheTwoSidesOfAnEdge) {
  // A faint colour edge (0.40 against 0.46): the colour alone cannot say which side a pixel is
  // on, yet no pixel may take a depth between the surfaces (a blend of two depths exists
  // nowhere and shows as a halo in the blur), and the mixed sample's average (column 7) must
  // not leak in.
  EdgeScene s;
  for (int y = 0; y < 48; ++y)
    for (int x = 0; x < 64; ++x)
      for (int c = 0; c < 3; ++c) s.color.at(x, y, c) = x < 30 ? 0.40f : 0.46f;
  const Image g = io::resample_depth(s.low, s.color, io::DepthUpsample::guided);
  int right = 0;
  for (int y = 0; y < 48; ++y)
    for (int x = 0; x < 64; ++x) {
      const float z = g.at(x, y);
      EXPECT_TRUE(std::fabs(z - 1.0f) <= 0.05f || std::fabs(z - 4.0f) <= 0.2f) << x << "," << y << ": " << z;
      right += std::fabs(z - s.full.at(x, y)) <= 0.05f * s.full.at(x, y);
    }
  EXPECT_GE(right, 48 * 64 - 48 * 2) << "at most two columns on the wrong side";
}

TEST(DepthRefine, ASoftEdgeIsSnappedBackToTheColourEdge) {
  // The full-resolution depth blurred over 9 px across the edge (in 1/z), as a phone's soft map.
  const EdgeScene s;
  Image soft(64, 48, 1);
  for (int y = 0; y < 48; ++y)
    for (int x = 0; x < 64; ++x) {
      double w = 0;
      for (int d = -4; d <= 4; ++d) w += 1.0 / s.full.at(std::clamp(x + d, 0, 63), y);
      soft.at(x, y) = static_cast<float>(9.0 / w);
    }
  const Image r = io::refine_depth(soft, s.color);
  ASSERT_TRUE(r.same_size(soft));
  int refined_ok = 0, soft_ok = 0;
  for (int y = 0; y < 48; ++y)
    for (int x = 22; x < 38; ++x) {
      const float t = s.full.at(x, y);
      refined_ok += std::fabs(r.at(x, y) - t) <= 0.05f * t;
      soft_ok += std::fabs(soft.at(x, y) - t) <= 0.05f * t;
    }
  EXPECT_GE(refined_ok, 48 * 16 * 9 / 10) << "refined " << refined_ok << ", soft " << soft_ok;
  EXPECT_LT(soft_ok, 48 * 16 * 2 / 3);
  // A flat map stays flat.
  const Image flat(64, 48, 1, 2.5f);
  const Image flat_refined = io::refine_depth(flat, s.color);
  for (const float z : flat_refined.data()) ASSERT_FLOAT_EQ(z, 2.5f);
}

TEST(DepthResample, SameOutputForAnyThreadCount) {
  const EdgeScene s;
  for (const auto how : {io::DepthUpsample::nearest, io::DepthUpsample::bilinear, io::DepthUpsample::guided,
                         io::DepthUpsample::guided_filter}) {
    Image one, two;
    {
      tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
      one = io::resample_depth(s.low, s.color, how);
    }
    {
      tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
      two = io::resample_depth(s.low, s.color, how);
    }
    EXPECT_EQ(one.data(), two.data()) << static_cast<int>(how);
  }
  Image one, two;
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
    one = io::refine_depth(s.full, s.color);
  }
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
    two = io::refine_depth(s.full, s.color);
  }
  EXPECT_EQ(one.data(), two.data()) << "refine";
}

TEST(DepthResample, UnknownNameIsAUsageError) {
  std::string m;
  EXPECT_EQ(code_of([] { io::parse_depth_upsample("cubic"); }, &m), 2);
  EXPECT_NE(m.find("--depth-upsample cubic"), std::string::npos) << m;
}
