// render_masked(): the transparency entry point (docs/methods/starcraft.md).
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "dofkit/render.hpp"

using namespace dofkit;

namespace {

Frame wall_frame(int w, int h, float z) {
  Frame f;
  f.color = Image(w, h, 4, 1.0f);
  f.depth = Image(w, h, 1, z);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      f.color.at(x, y, 0) = ((x / 4 + y / 4) % 2) ? 0.9f : 0.1f;  // checker, 4 px
      f.color.at(x, y, 1) = 0.5f;
      f.color.at(x, y, 2) = 0.2f + 0.6f * x / w;
    }
  return f;
}

RenderSettings starcraft_settings() {
  RenderSettings s;
  s.method = "starcraft";
  s.camera.model = BlurAtInfinity{4.0, 10.0};
  s.threads = 2;
  return s;
}

}  // namespace

TEST(RenderMasked, EmptyMaskIsAPlainRender) {
  const Frame f = wall_frame(96, 64, 10.0f);
  const Image mask(96, 64, 1, 0.0f), zmask(96, 64, 1, 1.0f);
  const RenderResult a = render(f, starcraft_settings());
  const RenderResult b = render_masked(f, mask, zmask, starcraft_settings());
  EXPECT_EQ(a.image.data(), b.image.data());
}

TEST(RenderMasked, FullMaskRendersWithTheSubstituteDepth) {
  const Frame f = wall_frame(96, 64, 4.0f);  // in focus
  const Image mask(96, 64, 1, 1.0f), zmask(96, 64, 1, 1.0f);
  Frame g = f;
  g.depth = zmask;
  const RenderResult expect = render(g, starcraft_settings());
  const RenderResult got = render_masked(f, mask, zmask, starcraft_settings());
  EXPECT_EQ(expect.image.data(), got.image.data());
  EXPECT_EQ(expect.coc.data(), got.coc.data());
}

TEST(RenderMasked, TranslucentPaneGetsItsOwnBlur) {
  // An in-focus checker wall at 4 m seen through a 50 % white pane at 1 m (CoC 30 px, out of
  // focus). The colour already holds the pane composited over the wall; the depth is the
  // wall's, so a plain render leaves everything seen through the pane crisp (the chapter's
  // "crisp egg"). With the pane's footprint as mask and its depth as mask depth, the area
  // the pane covers is re-rendered with the pane's blur.
  const int w = 160, h = 96;
  Frame f = wall_frame(w, h, 4.0f);
  Image mask(w, h, 1, 0.0f), zmask(w, h, 1, 1.0f);
  for (int y = 0; y < h; ++y)
    for (int x = 70; x < w; ++x) {
      mask.at(x, y) = 1.0f;
      for (int c = 0; c < 4; ++c) f.color.at(x, y, c) = 0.5f * f.color.at(x, y, c) + 0.5f * 1.0f;
    }
  const RenderResult plain = render(f, starcraft_settings());
  const RenderResult masked = render_masked(f, mask, zmask, starcraft_settings());
  EXPECT_EQ(plain.image.data(), f.color.data());  // all at the wall's depth: in focus
  // Contrast of the checker seen through the pane (interior, away from the pane's edge):
  // mean |horizontal difference| of the red channel.
  auto contrast = [&](const Image& img) {
    double s = 0;
    int n = 0;
    for (int y = 10; y < h - 10; ++y)
      for (int x = 100; x < 150; ++x, ++n) s += std::fabs(img.at(x + 1, y, 0) - img.at(x, y, 0));
    return s / n;
  };
  EXPECT_GT(contrast(plain.image), 0.08);
  EXPECT_LT(contrast(masked.image), 0.1 * contrast(plain.image));
  // The blur stays inside the mask: outside it nothing changes (documented limitation).
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < 70; ++x) ASSERT_EQ(masked.image.at(x, y, 0), plain.image.at(x, y, 0));
}

TEST(RenderMasked, WorksForAnyMethod) {
  const Frame f = wall_frame(64, 48, 4.0f);
  Image mask(64, 48, 1, 0.0f), zmask(64, 48, 1, 1.0f);
  for (int y = 10; y < 30; ++y)
    for (int x = 10; x < 30; ++x) mask.at(x, y) = 1.0f;
  RenderSettings s = starcraft_settings();
  s.method = "reference";
  const RenderResult r = render_masked(f, mask, zmask, s);
  EXPECT_EQ(r.image.width(), 64);
  EXPECT_NE(r.image.data(), render(f, s).image.data());
}

TEST(RenderMasked, BadMaskIsRejectedWithItsName) {
  const Frame f = wall_frame(32, 32, 4.0f);
  auto expect_error = [&](const Image& m, const Image& z, const std::string& name) {
    try {
      render_masked(f, m, z, starcraft_settings());
      FAIL() << "expected an error naming " << name;
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::bad_input);
      EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
    }
  };
  expect_error(Image(16, 32, 1, 0.5f), Image(32, 32, 1, 1.0f), "--mask");
  expect_error(Image(32, 32, 1, 0.5f), Image(32, 31, 1, 1.0f), "--mask-depth");
  expect_error(Image(32, 32, 1, 1.5f), Image(32, 32, 1, 1.0f), "--mask");
  expect_error(Image(32, 32, 1, 0.5f), Image(32, 32, 1, -1.0f), "--mask-depth");
  Image ok_z(32, 32, 1, 1.0f);
  ok_z.at(3, 3) = -1.0f;  // not covered by the mask: ignored
  Image m(32, 32, 1, 0.0f);
  EXPECT_NO_THROW(render_masked(f, m, ok_z, starcraft_settings()));
}
