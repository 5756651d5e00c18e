// Depth files: channel selection and the depth-kind conversions of docs/cli.md "Depth".
#include <gtest/gtest.h>

#include <limits>

#include "dofkit/error.hpp"
#include "io/image_io.hpp"
#include "io/io_test_util.hpp"

using namespace dofkit;
using namespace dofkit::test;
using io::DepthKind;
using io::DepthOptions;

namespace {
constexpr float kInf = std::numeric_limits<float>::infinity();
const float kNaN = std::numeric_limits<float>::quiet_NaN();

Image depth_of(const ScratchDir& dir, const std::vector<float>& values, DepthOptions opt, int w = -1,
               const std::string& channel = "Z") {
  if (w < 0) w = static_cast<int>(values.size());
  const int h = static_cast<int>(values.size()) / w;
  raw_write(dir / "d.exr", w, h, {channel}, values);
  return io::read_depth(dir / "d.exr", opt);
}

std::string message_of(const std::function<void()>& fn, ErrorKind kind) {
  try {
    fn();
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), kind) << e.what();
    return e.what();
  }
  ADD_FAILURE() << "no error thrown";
  return {};
}
}  // namespace

class SingleChannelName : public ::testing::TestWithParam<const char*> {};

TEST_P(SingleChannelName, UsedWhateverItsName) {
  ScratchDir dir;
  const Image d = depth_of(dir, {1.5f, 2.5f, kInf, 7.0f}, {}, 2, GetParam());
  EXPECT_EQ(d.channels(), 1);
  EXPECT_EQ(d.width(), 2);
  EXPECT_EQ(d.at(0, 0), 1.5f);
  EXPECT_TRUE(std::isinf(d.at(0, 1)));
  EXPECT_EQ(d.at(1, 1), 7.0f);
}
INSTANTIATE_TEST_SUITE_P(Names, SingleChannelName, ::testing::Values("Y", "Z", "R", "depth.Z", "distance", "A"));

TEST(DepthFile, ZChannelOfMultiChannelExr) {
  ScratchDir dir;
  raw_write(dir / "m.exr", 2, 1, {"R", "G", "B", "Z"}, {9, 9, 9, 3.0f, 9, 9, 9, 4.0f});
  const Image d = io::read_depth(dir / "m.exr", {});
  EXPECT_EQ(d.at(0, 0), 3.0f);
  EXPECT_EQ(d.at(1, 0), 4.0f);
}

TEST(DepthFile, MultiChannelWithoutZIsRejected) {
  ScratchDir dir;
  raw_write(dir / "m.exr", 1, 1, {"R", "G", "B"}, {1.0f, 2.0f, 3.0f});
  const std::string m = message_of([&] { io::read_depth(dir / "m.exr", {}); }, ErrorKind::bad_input);
  EXPECT_NE(m.find("m.exr"), std::string::npos) << m;
  EXPECT_NE(m.find("Z"), std::string::npos) << m;
}

TEST(DepthFile, GreyRgbPngAcceptedAsOneChannel) {
  ScratchDir dir;
  raw_write(dir / "g.png", 2, 1, {"R", "G", "B"}, {0.5f, 0.5f, 0.5f, 1.0f, 1.0f, 1.0f}, OIIO::TypeDesc::UINT16);
  DepthOptions o;
  o.kind = DepthKind::disparity;
  o.disparity_scale = 2.0;
  const Image d = io::read_depth(dir / "g.png", o);
  EXPECT_NEAR(d.at(0, 0), 2.0 / (32768 / 65535.0), 1e-4);  // no sRGB decode for depth
  EXPECT_NEAR(d.at(1, 0), 2.0, 1e-6);
}

TEST(DepthKinds, PlanarZKeepsValuesAndInfinity) {
  ScratchDir dir;
  const Image d = depth_of(dir, {0.001f, 4.0f, kInf}, {});
  EXPECT_EQ(d.at(0, 0), 0.001f);
  EXPECT_EQ(d.at(1, 0), 4.0f);
  EXPECT_TRUE(std::isinf(d.at(2, 0)));
}

TEST(DepthKinds, RadialDistanceToPlanar) {
  ScratchDir dir;
  // 8×6 image, 90° horizontal FOV → F = (8/2)/tan(45°) = 4 px.
  std::vector<float> v(48, 10.0f);
  DepthOptions o;
  o.kind = DepthKind::distance;
  o.fov_deg = 90;
  const Image d = depth_of(dir, v, o, 8);
  // Pixel (0,0): centre offset (−3.5, −2.5) → z = 10 / sqrt(1 + (12.25 + 6.25)/16).
  EXPECT_NEAR(d.at(0, 0), 10.0 / std::sqrt(1.0 + 18.5 / 16.0), 1e-5);
  // Pixel (4,3): offset (0.5, 0.5).
  EXPECT_NEAR(d.at(4, 3), 10.0 / std::sqrt(1.0 + 0.5 / 16.0), 1e-5);
  // Symmetric about the centre.
  EXPECT_NEAR(d.at(7, 5), d.at(0, 0), 1e-6);
  EXPECT_LT(d.at(0, 0), d.at(3, 2));
}

TEST(DepthKinds, DistanceNeedsFov) {
  ScratchDir dir;
  DepthOptions o;
  o.kind = DepthKind::distance;
  const std::string m = message_of([&] { depth_of(dir, {1.0f}, o); }, ErrorKind::usage);
  EXPECT_NE(m.find("--fov-deg"), std::string::npos) << m;
}

TEST(DepthKinds, DisparityFloat) {
  ScratchDir dir;
  DepthOptions o;
  o.kind = DepthKind::disparity;
  o.disparity_scale = 2.0;
  const Image d = depth_of(dir, {0.5f, 4.0f, 0.0f}, o);
  EXPECT_FLOAT_EQ(d.at(0, 0), 4.0f);
  EXPECT_FLOAT_EQ(d.at(1, 0), 0.5f);
  EXPECT_TRUE(std::isinf(d.at(2, 0)));  // zero disparity = infinitely far
}

TEST(DepthKinds, DisparityEightBitBrightIsNear) {
  ScratchDir dir;
  raw_write(dir / "d.png", 3, 1, {"Y"}, {1.0f, 0.5f, 0.0f}, OIIO::TypeDesc::UINT8);
  DepthOptions o;
  o.kind = DepthKind::disparity;
  o.disparity_scale = 1.5;
  const Image d = io::read_depth(dir / "d.png", o);
  EXPECT_FLOAT_EQ(d.at(0, 0), 1.5f);                   // white: d = 1 → z = scale
  EXPECT_NEAR(d.at(1, 0), 1.5 / (128 / 255.0), 1e-5);  // code 128
  EXPECT_TRUE(std::isinf(d.at(2, 0)));                 // black: far
  EXPECT_LT(d.at(0, 0), d.at(1, 0));
}

TEST(DepthKinds, NdcStandardFiniteAndInfinite) {
  ScratchDir dir;
  DepthOptions o;
  o.kind = DepthKind::ndc;
  o.clip_near = 0.1;
  o.clip_far = 100;
  Image d = depth_of(dir, {0.0f, 1.0f, 0.5f, 0.99f}, o);
  EXPECT_NEAR(d.at(0, 0), 0.1, 1e-6);
  EXPECT_NEAR(d.at(1, 0), 100.0, 1e-3);
  EXPECT_NEAR(d.at(2, 0), 0.1 * 100 / (100 - 0.5 * 99.9), 1e-5);
  EXPECT_NEAR(d.at(3, 0), 0.1 * 100 / (100 - 0.99 * 99.9), 1e-4);
  o.clip_far = std::numeric_limits<double>::infinity();
  d = depth_of(dir, {0.0f, 0.5f, 1.0f}, o);
  EXPECT_NEAR(d.at(0, 0), 0.1, 1e-6);
  EXPECT_NEAR(d.at(1, 0), 0.2, 1e-6);  // z = n / (1 − d)
  EXPECT_TRUE(std::isinf(d.at(2, 0)));
}

TEST(DepthKinds, NdcReversedFiniteAndInfinite) {
  ScratchDir dir;
  DepthOptions o;
  o.kind = DepthKind::ndc_reversed;
  o.clip_near = 0.1;
  o.clip_far = 100;
  Image d = depth_of(dir, {1.0f, 0.0f, 0.5f}, o);
  EXPECT_NEAR(d.at(0, 0), 0.1, 1e-6);
  EXPECT_NEAR(d.at(1, 0), 100.0, 1e-3);
  EXPECT_NEAR(d.at(2, 0), 0.1 * 100 / (0.1 + 0.5 * 99.9), 1e-6);
  o.clip_far = std::numeric_limits<double>::infinity();
  d = depth_of(dir, {1.0f, 0.25f, 0.0f}, o);
  EXPECT_NEAR(d.at(0, 0), 0.1, 1e-6);
  EXPECT_NEAR(d.at(1, 0), 0.4, 1e-6);  // z = n / d
  EXPECT_TRUE(std::isinf(d.at(2, 0)));
}

TEST(DepthKinds, NdcOutsideUnitRangeIsInvalid) {
  ScratchDir dir;
  DepthOptions o;
  o.kind = DepthKind::ndc;
  const std::string m = message_of([&] { depth_of(dir, {0.5f, 1.5f, -0.1f}, o); }, ErrorKind::bad_input);
  EXPECT_NE(m.find("2 invalid"), std::string::npos) << m;
  EXPECT_NE(m.find("(1, 0)"), std::string::npos) << m;
}

TEST(DepthKinds, BadClipIsUsageError) {
  ScratchDir dir;
  DepthOptions o;
  o.kind = DepthKind::ndc;
  o.clip_near = 10;
  o.clip_far = 1;
  const std::string m = message_of([&] { depth_of(dir, {0.5f}, o); }, ErrorKind::usage);
  EXPECT_NE(m.find("--clip"), std::string::npos) << m;
}

TEST(DepthKinds, ParseNames) {
  EXPECT_EQ(io::parse_depth_kind("ndc-reversed"), DepthKind::ndc_reversed);
  EXPECT_EQ(io::parse_depth_kind("distance"), DepthKind::distance);
  EXPECT_STREQ(io::depth_kind_name(DepthKind::disparity), "disparity");
  EXPECT_THROW(io::parse_depth_kind("inverse"), Error);
}

TEST(InvalidDepth, NanAndNegativeReportCountAndFirstPixel) {
  ScratchDir dir;
  // 4×2: invalid at (2,0) NaN, (1,1) −3, (3,1) 0.
  const std::vector<float> v = {1, 2, kNaN, 4, 5, -3, 7, 0};
  const std::string m = message_of([&] { depth_of(dir, v, {}, 4); }, ErrorKind::bad_input);
  EXPECT_NE(m.find("d.exr"), std::string::npos) << m;
  EXPECT_NE(m.find("3 invalid"), std::string::npos) << m;
  EXPECT_NE(m.find("first at pixel (2, 0)"), std::string::npos) << m;
  EXPECT_NE(m.find("--invalid-depth far"), std::string::npos) << m;
  EXPECT_EQ(m.find('\n'), std::string::npos);
}

TEST(InvalidDepth, AsFarBecomesInfinity) {
  ScratchDir dir;
  DepthOptions o;
  o.invalid_as_far = true;
  const Image d = depth_of(dir, {1, 2, kNaN, 4, 5, -3, 7, 0}, o, 4);
  EXPECT_TRUE(std::isinf(d.at(2, 0)) && d.at(2, 0) > 0);
  EXPECT_TRUE(std::isinf(d.at(1, 1)));
  EXPECT_TRUE(std::isinf(d.at(3, 1)));
  EXPECT_EQ(d.at(0, 1), 5.0f);
}

TEST(Mask, SingleChannelOrAlpha) {
  ScratchDir dir;
  raw_write(dir / "m.png", 2, 1, {"Y"}, {0.0f, 1.0f}, OIIO::TypeDesc::UINT8);
  Image m = io::read_mask(dir / "m.png");
  EXPECT_EQ(m.at(0, 0), 0.0f);
  EXPECT_EQ(m.at(1, 0), 1.0f);
  raw_write(dir / "m.exr", 1, 1, {"R", "G", "B", "A"}, {1, 1, 1, 0.25f});
  m = io::read_mask(dir / "m.exr");
  EXPECT_EQ(m.at(0, 0), 0.25f);
}
