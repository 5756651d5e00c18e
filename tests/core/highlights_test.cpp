// Highlight recovery (src/render/highlights.hpp): which clipped pixels get their energy back,
// the inverse used by --highlight-restore, and the same result for any thread count.
#include <gtest/gtest.h>

#include <cstring>

#include "core/parallel.hpp"
#include "dofkit/aperture.hpp"
#include "dofkit/image.hpp"
#include "render/highlights.hpp"

namespace dofkit::detail {
namespace {

// A 96x64 dark frame (linear 0.02, display ~0.15) with a 3x3 clipped light at (20, 20), a
// 56x40 clipped wall at x >= 40, y >= 24 (large: not a light) and a 2x2 clipped speck at (12, 50)
// on a bright patch (linear 0.6, display ~0.8: not standing out).
Image frame() {
  Image img(96, 64, 4, 0.0f);
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 96; ++x) {
      float v = 0.02f;
      if (x >= 40 && y >= 24) v = 1.0f;                      // the wall
      if (x >= 19 && x < 22 && y >= 19 && y < 22) v = 1.0f;  // the light
      if (x >= 4 && x < 24 && y >= 42 && y < 62) v = 0.6f;   // bright patch
      if (x >= 12 && x < 14 && y >= 50 && y < 52) v = 1.0f;  // the speck
      for (int c = 0; c < 3; ++c) img.at(x, y, c) = v;
      img.at(x, y, 3) = 1.0f;
    }
  return img;
}

HighlightRecovery boost(double g) {
  HighlightRecovery h;
  h.boost = g;
  return h;
}

TEST(Highlights, OnlySmallRegionsOnADarkSurroundAreBoosted) {
  const Image src = frame();
  Image dst, mask;
  boost_highlights(src, boost(64), dst, &mask);
  ASSERT_EQ(mask.channels(), 1);
  // The light: fully clipped, small, dark surround: gain 1 + 64.
  EXPECT_FLOAT_EQ(mask.at(20, 20, 0), 1.0f);
  EXPECT_FLOAT_EQ(dst.at(20, 20, 0), 65.0f);
  EXPECT_FLOAT_EQ(dst.at(20, 20, 3), 1.0f);  // alpha untouched
  // The wall (2240 px, far over A0 = 16 px at this size) gets a small fraction of it.
  EXPECT_LT(mask.at(60, 40, 0), 0.02f);
  // The speck on the bright patch: no boost at all.
  EXPECT_FLOAT_EQ(mask.at(12, 50, 0), 0.0f);
  EXPECT_FLOAT_EQ(dst.at(12, 50, 1), 1.0f);
  // Below the threshold nothing changes.
  EXPECT_FLOAT_EQ(dst.at(5, 5, 2), 0.02f);
  EXPECT_FLOAT_EQ(dst.at(8, 50, 2), 0.6f);
  EXPECT_FLOAT_EQ(mask.at(5, 5, 0), 0.0f);
}

TEST(Highlights, RestoreInvertsTheBoostOfAFullWeightPixel) {
  const Image src = frame();
  Image dst;
  const HighlightRecovery h = boost(64);
  boost_highlights(src, h, dst);
  restore_highlights(dst, h);
  EXPECT_NEAR(dst.at(20, 20, 0), 1.0f, 1e-5f);  // the light returns to the clip level
  EXPECT_FLOAT_EQ(dst.at(5, 5, 0), 0.02f);      // below the threshold: unchanged
  // A value between threshold and clip maps below itself, monotonically.
  Image px(2, 1, 4, 1.0f);
  px.at(0, 0, 0) = px.at(0, 0, 1) = px.at(0, 0, 2) = 3.0f;
  px.at(1, 0, 0) = px.at(1, 0, 1) = px.at(1, 0, 2) = 30.0f;
  restore_highlights(px, h);
  EXPECT_LT(px.at(0, 0, 0), px.at(1, 0, 0));
  EXPECT_LT(px.at(1, 0, 0), 1.0f);
  EXPECT_GT(px.at(0, 0, 0), 0.787f);  // at least the threshold's linear value
}

TEST(Highlights, ZeroBoostIsTheIdentity) {
  const Image src = frame();
  Image dst;
  boost_highlights(src, boost(0), dst);
  for (int c = 0; c < 4; ++c)
    for (int y = 0; y < src.height(); ++y)
      EXPECT_EQ(std::memcmp(src.row(c, y), dst.row(c, y), sizeof(float) * src.width()), 0);
}

TEST(Highlights, SameResultForAnyThreadCount) {
  const Image src = frame();
  Image one, two, m1, m2;
  core::with_threads(1, [&] { boost_highlights(src, boost(48), one, &m1); });
  core::with_threads(2, [&] { boost_highlights(src, boost(48), two, &m2); });
  for (int c = 0; c < 4; ++c)
    for (int y = 0; y < src.height(); ++y)
      EXPECT_EQ(std::memcmp(one.row(c, y), two.row(c, y), sizeof(float) * src.width()), 0);
  for (int y = 0; y < src.height(); ++y)
    EXPECT_EQ(std::memcmp(m1.row(0, y), m2.row(0, y), sizeof(float) * src.width()), 0);
}

}  // namespace
}  // namespace dofkit::detail
