#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <vector>

#include "dofkit/coc.hpp"
#include "dofkit/error.hpp"

using namespace dofkit;

TEST(ThinLens, WorkedExample) {
  // docs/coc.md: f = 50 mm, N = 2.8, z_F = 5 m, S_w = 36 mm, W = 1920 → K = 4.81 px.
  ThinLens lens{50, 2.8, 5.0, 36};
  EXPECT_NEAR(thin_lens_k_px(lens, 1920), 4.81, 0.005);
  CocFunction f(CameraModel{lens}, 1920);
  EXPECT_NEAR(f(1.0f), 19.24, 0.02);
  EXPECT_NEAR(f(2.5f), 4.81, 0.01);
  EXPECT_NEAR(f(10.0f), -2.405, 0.01);
  EXPECT_NEAR(f(std::numeric_limits<float>::infinity()), -4.81, 0.005);
  EXPECT_NEAR(f(5.0f), 0.0, 1e-6);
}

TEST(ThinLens, RadiiScaleWithWidth) {
  CameraModel cam{BlurAtInfinity{4.0, 24.0}};
  cam.reference_width_px = 1000;
  CocFunction a(cam, 1000), b(cam, 2000);
  EXPECT_NEAR(a(2.0f), 24.0, 1e-4);
  EXPECT_NEAR(b(2.0f), 48.0, 1e-4);
}

TEST(ThinLens, MaxCocClamps) {
  CameraModel cam{BlurAtInfinity{4.0, 24.0}};
  cam.max_coc_px = 40;
  CocFunction f(cam, 1920);
  EXPECT_FLOAT_EQ(f(0.5f), 40.0f);  // 24·(8 − 1) = 168 → 40
  EXPECT_FLOAT_EQ(f(1e9f), -24.0f + 24.0f * 4.0f / 1e9f);
}

TEST(FourPlane, Ramps) {
  FourPlane p{1, 2, 4, 8, 10, 6, false};
  CocFunction f(CameraModel{p}, 100);
  EXPECT_FLOAT_EQ(f(0.5f), 10);
  EXPECT_FLOAT_EQ(f(1.5f), 5);
  EXPECT_FLOAT_EQ(f(3.0f), 0);
  EXPECT_FLOAT_EQ(f(6.0f), -3);
  EXPECT_FLOAT_EQ(f(100.0f), -6);
}

TEST(Conversions, PhysicalToFourPlaneMatchesInBetween) {
  BlurAtInfinity lens{5.0, 10.0};
  FourPlane p = to_four_plane(lens, 20, 8);
  CocFunction phys(CameraModel{lens}, 500), art(CameraModel{p}, 500);
  for (float z : {2.5f, 3.0f, 4.0f, 7.0f, 12.0f, 20.0f}) EXPECT_NEAR(phys(z), art(z), 1e-3) << z;
  BlurAtInfinity back = to_thin_lens(p);
  EXPECT_NEAR(back.focus_distance_m, 5.0, 1e-9);
  EXPECT_NEAR(back.blur_at_infinity_px, 10.0, 1e-9);
}

TEST(Conversions, StarCraftToFourPlane) {
  StarCraft sc{10, 1, 5, 2, 12};
  FourPlane p = to_four_plane(sc);
  EXPECT_DOUBLE_EQ(p.near_sharp_m, 9);
  EXPECT_DOUBLE_EQ(p.far_sharp_m, 11);
  EXPECT_DOUBLE_EQ(p.near_blurry_m, 10 - 3);  // Δ = 1 + 4/2
  EXPECT_DOUBLE_EQ(p.far_blurry_m, 13);
  CocFunction a(CameraModel{sc}, 100), b(CameraModel{p}, 100);
  for (float z : {5.0f, 8.0f, 9.5f, 10.5f, 12.0f, 20.0f}) EXPECT_NEAR(a(z), b(z), 1e-4) << z;
  StarCraft back = to_starcraft(p);
  EXPECT_NEAR(back.focus_distance_m, 10, 1e-9);
  EXPECT_NEAR(back.full_focus_range_m, 1, 1e-9);
}

TEST(Validate, RejectsBadLens) {
  EXPECT_THROW(validate(CameraModel{ThinLens{50, 0, 5, 36}}), Error);
  EXPECT_THROW(validate(CameraModel{ThinLens{50, 2.8, 0.04, 36}}), Error);
  EXPECT_THROW(validate(CameraModel{FourPlane{2, 1, 4, 8, 10, 10, false}}), Error);
  try {
    validate(CameraModel{ThinLens{50, -1, 5, 36}});
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::usage);
    EXPECT_NE(std::string(e.what()).find("--f-number"), std::string::npos);
  }
}

TEST(CocFunction, BatchEvaluationMatchesScalarBitForBit) {
  const float inf = std::numeric_limits<float>::infinity();
  std::vector<float> z = {inf, -inf, 0.0f, -1.0f, std::numeric_limits<float>::quiet_NaN(), 1e-30f, 1e-3f, 0.05f};
  for (int i = 0; i < 400; ++i) z.push_back(0.01f * std::pow(1.04f, static_cast<float>(i)));
  std::vector<CameraModel> cams = {CameraModel{ThinLens{50, 2.8, 5.0, 36}}, CameraModel{BlurAtInfinity{4.0, 24.0}},
                                   CameraModel{FourPlane{1, 2, 4, 8, 10, 6, false}},
                                   CameraModel{StarCraft{10, 1, 5, 2, 12}}, CameraModel{NearFarBlend{}}};
  cams[1].max_coc_px = 40;
  for (const CameraModel& cam : cams) {
    const CocFunction f(cam, 1920);
    std::vector<float> r(z.size());
    f.evaluate(z.data(), r.data(), static_cast<int>(z.size()));
    for (std::size_t i = 0; i < z.size(); ++i) {
      const float want = f(z[i]);
      ASSERT_EQ(std::memcmp(&r[i], &want, sizeof want), 0) << describe(cam) << " z=" << z[i];
    }
  }
}
