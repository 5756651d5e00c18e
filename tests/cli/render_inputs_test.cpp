// `dofkit render` with inputs as renderers and users hold them: the depth channel of an AOV
// file chosen by name (or --depth-channel), the colour channels (--color-channels), depth
// units (--depth-scale / --depth-units) and the two sanity warnings. Tiny frames (64x48).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "dofkit/coc.hpp"
#include "dofkit/render.hpp"
#include "io/image_io.hpp"
#include "io/io_test_util.hpp"
#include "cli_common.hpp"
#include "render_cli_util.hpp"

using namespace dofkit;
using namespace dofkit::test;

namespace {

constexpr int W = 64, H = 48;

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

class RenderInputs : public ::testing::Test {
 protected:
  void SetUp() override {
    color_ = test_rgba(W, H, true, true);
    // 6 m background, a 1.25 m box, a 0.5 m corner: values exact in binary, in m and in cm.
    depth_ = Image(W, H, 1, 6.0f);
    for (int y = 12; y < 36; ++y)
      for (int x = 20; x < 44; ++x) depth_.at(x, y) = 1.25f;
    for (int y = 40; y < H; ++y)
      for (int x = 56; x < W; ++x) depth_.at(x, y) = 0.5f;
    io::write_image(dir_ / "c.exr", color_);
    io::WriteOptions z;
    z.channel_name = "Z";
    io::write_image(dir_ / "z.exr", depth_, z);
  }

  // An EXR with the colour and depth above in channels of these names, plus filler channels
  // (normals, positions) holding other values; `depth_name` "" = no depth channel.
  void write_aov(const std::string& file, const std::vector<std::string>& rgba, const std::string& depth_name,
                 const std::vector<std::string>& filler) {
    std::vector<std::string> names = rgba;
    if (!depth_name.empty()) names.push_back(depth_name);
    names.insert(names.end(), filler.begin(), filler.end());
    const std::size_t C = names.size(), n = depth_.plane_size();
    std::vector<float> v(n * C);
    for (std::size_t i = 0; i < n; ++i) {
      std::size_t k = 0;
      for (std::size_t c = 0; c < rgba.size(); ++c) v[i * C + k++] = color_.plane(static_cast<int>(c))[i];
      if (!depth_name.empty()) v[i * C + k++] = depth_.plane(0)[i];
      for (std::size_t c = 0; c < filler.size(); ++c) v[i * C + k++] = 0.25f + 0.5f * static_cast<float>(c);
    }
    raw_write(dir_ / file, W, H, names, v);
  }

  std::vector<std::string> camera() const {
    return {"--focus", "2", "--blur-at-infinity", "6", "--method", "reference"};
  }
  std::vector<std::string> call(std::vector<std::string> inputs, const std::string& out,
                                const std::string& coc = "") const {
    std::vector<std::string> c = camera();
    inputs.insert(inputs.end(), c.begin(), c.end());
    inputs.insert(inputs.end(), {"--output", dir_ / out});
    if (!coc.empty()) inputs.insert(inputs.end(), {"--output-coc", dir_ / coc});
    return inputs;
  }

  // The render with the separate colour and depth files: what every AOV layout must give.
  void render_separate() {
    const CliResult r =
        run_render(call({"--color", dir_ / "c.exr", "--depth", dir_ / "z.exr"}, "sep.exr", "sep_coc.exr"));
    ASSERT_EQ(r.code, 0) << r.message;
  }
  void expect_same_as_separate(const std::string& out, const std::string& coc) {
    EXPECT_EQ(io::read_color(dir_ / out).data(), io::read_color(dir_ / "sep.exr").data()) << out;
    const Image a = read_coc(coc), b = read_coc("sep_coc.exr");
    EXPECT_EQ(a.data(), b.data()) << coc;
  }
  Image read_coc(const std::string& file) const {
    // The CoC map is signed: read its one channel as colour (grey), plane 0.
    return io::read_color(dir_ / file);
  }

  // A failure with `code`, one line holding every part, and no file but `keep` in the folder.
  void expect_failure(const std::vector<std::string>& args, int code, std::initializer_list<const char*> parts,
                      std::vector<std::string> keep) {
    const CliResult r = run_render(args);
    EXPECT_EQ(r.code, code) << r.message;
    for (const char* p : parts) EXPECT_TRUE(contains(r.message, p)) << "missing '" << p << "' in: " << r.message;
    EXPECT_FALSE(contains(r.message, "\n")) << r.message;
    std::sort(keep.begin(), keep.end());
    EXPECT_EQ(dir_.entries(), keep) << "an output or temporary file was left behind";
  }

  ScratchDir dir_;
  Image color_, depth_;
};

}  // namespace

// --- the depth channel -------------------------------------------------------------------

TEST(DepthChannelChoice, ByNameInTheDocumentedOrderNeverAPass) {
  auto pick = [](std::vector<std::string> names) {
    const io::DepthChannelChoice c = io::choose_depth_channel(names, "");
    return c.index < 0 ? std::string("-") : names[c.index];
  };
  EXPECT_EQ(pick({"R", "G", "B", "A", "N.X", "N.Y", "N.Z", "depth.Z"}), "depth.Z");
  EXPECT_EQ(pick({"R", "G", "B", "A", "P.X", "P.Y", "P.Z", "depth.Z"}), "depth.Z");
  EXPECT_EQ(pick({"depth.Z", "Z", "N.Z"}), "Z");
  EXPECT_EQ(pick({"ViewLayer.Combined.R", "ViewLayer.Depth.Z", "ViewLayer.Normal.Z", "ViewLayer.Vector.Z"}),
            "ViewLayer.Depth.Z");
  EXPECT_EQ(pick({"R", "G", "B", "RenderLayer.Z", "N.Z"}), "RenderLayer.Z");      // any other layer's Z, last
  EXPECT_EQ(pick({"R", "G", "B", "myDEPTHpass.z", "other.Z"}), "myDEPTHpass.z");  // *depth*.Z before <layer>.Z
  EXPECT_EQ(pick({"Y"}), "Y");                                                    // a lone channel, whatever its name
  EXPECT_EQ(pick({"R", "G", "B", "A", "N.Z", "P.Z"}), "-");                       // passes only: none
  EXPECT_EQ(pick({"R", "G", "B", "a.depth.Z", "b.depth.Z"}), "-");                // two in one tier: ambiguous
  EXPECT_EQ(pick({"R", "G", "B", "Motion.Z", "ViewLayer.Position.Z", "velocity.Z"}), "-");
  const io::DepthChannelChoice amb = io::choose_depth_channel({"R", "a.depth.Z", "b.depth.Z"}, "");
  EXPECT_TRUE(contains(amb.problem, "a.depth.Z, b.depth.Z")) << amb.problem;
  EXPECT_TRUE(contains(amb.problem, "--depth-channel")) << amb.problem;
  // --depth-channel: exact, else the one equal ignoring case; a pass may be named.
  EXPECT_EQ(io::choose_depth_channel({"R", "N.Z", "P.Z"}, "P.Z").index, 2);
  EXPECT_EQ(io::choose_depth_channel({"R", "N.Z", "P.Z"}, "p.z").index, 2);
  EXPECT_EQ(io::choose_depth_channel({"R", "N.Z", "P.Z"}, "Q.Z").index, -1);
}

TEST_F(RenderInputs, AovFileRendersExactlyAsWithASeparateDepthFile) {
  render_separate();
  write_aov("aov.exr", {"R", "G", "B", "A"}, "depth.Z", {"N.X", "N.Y", "N.Z"});
  const CliResult r = run_render(call({"--color", dir_ / "aov.exr"}, "aov_out.exr", "aov_coc.exr"));
  ASSERT_EQ(r.code, 0) << r.message;
  expect_same_as_separate("aov_out.exr", "aov_coc.exr");
  // Positions beside it change nothing either.
  write_aov("aovp.exr", {"R", "G", "B", "A"}, "depth.Z", {"P.X", "P.Y", "P.Z"});
  const CliResult p = run_render(call({"--color", dir_ / "aovp.exr"}, "p_out.exr", "p_coc.exr"));
  ASSERT_EQ(p.code, 0) << p.message;
  expect_same_as_separate("p_out.exr", "p_coc.exr");
}

TEST_F(RenderInputs, BlenderViewLayerFileRendersExactlyAsWithASeparateDepthFile) {
  render_separate();
  write_aov("blender.exr",
            {"ViewLayer.Combined.R", "ViewLayer.Combined.G", "ViewLayer.Combined.B", "ViewLayer.Combined.A"},
            "ViewLayer.Depth.Z", {"ViewLayer.Normal.X", "ViewLayer.Normal.Y", "ViewLayer.Normal.Z"});
  const CliResult r = run_render(call({"--color", dir_ / "blender.exr"}, "b_out.exr", "b_coc.exr"));
  ASSERT_EQ(r.code, 0) << r.message;
  expect_same_as_separate("b_out.exr", "b_coc.exr");
}

TEST_F(RenderInputs, NormalAndPositionZAloneAreRefusedThenDepthChannelNamesOne) {
  write_aov("np.exr", {"R", "G", "B", "A"}, "", {"N.Z", "P.Z"});
  expect_failure(call({"--color", dir_ / "np.exr"}, "out.exr"), 3, {"np.exr", "N.Z", "P.Z", "--depth-channel"},
                 {"c.exr", "z.exr", "np.exr"});
  // P.Z holds 0.75 everywhere (the filler's second value): named, it is the depth.
  const CliResult r = run_render(call({"--color", dir_ / "np.exr", "--depth-channel", "P.Z"}, "out.exr", "coc.exr"));
  ASSERT_EQ(r.code, 0) << r.message;
  const Image coc = read_coc("coc.exr");
  CameraModel cam;
  cam.model = BlurAtInfinity{2.0, 6.0};
  const float want = CocFunction(cam, W)(0.75f);
  for (std::size_t i = 0; i < coc.plane_size(); ++i) ASSERT_FLOAT_EQ(coc.plane(0)[i], want) << i;
}

TEST_F(RenderInputs, BadDepthChannelChoicesAreOneLineErrorsWithoutOutput) {
  write_aov("aov.exr", {"R", "G", "B", "A"}, "depth.Z", {"N.Z"});
  const std::vector<std::string> keep = {"c.exr", "z.exr", "aov.exr"};
  // Unknown name: exit 3 naming the flag and listing the channels.
  expect_failure(call({"--color", dir_ / "aov.exr", "--depth-channel", "Depth.W"}, "out.exr"), 3,
                 {"--depth-channel Depth.W", "no such channel", "depth.Z"}, keep);
  // ... also for a separate depth file.
  expect_failure(call({"--color", dir_ / "c.exr", "--depth", dir_ / "aov.exr", "--depth-channel", "zz"}, "out.exr"), 3,
                 {"--depth-channel zz", "N.Z"}, keep);
  // Two candidates of one tier: ambiguous.
  write_aov("two.exr", {"R", "G", "B", "A"}, "a.depth.Z", {"b.depth.Z"});
  expect_failure(call({"--color", dir_ / "two.exr"}, "out.exr"), 3, {"a.depth.Z, b.depth.Z", "--depth-channel"},
                 {"c.exr", "z.exr", "aov.exr", "two.exr"});
}

// --- the colour channels -----------------------------------------------------------------

TEST_F(RenderInputs, ColorChannelsChooseALayerAndSeveralLayersAreAmbiguous) {
  render_separate();
  // Two colour layers: the beauty in "beauty.*", something else in "albedo.*".
  write_aov("layers.exr", {"beauty.R", "beauty.G", "beauty.B", "beauty.A"}, "Z", {"albedo.R", "albedo.G", "albedo.B"});
  // "beauty" is preferred by name...
  CliResult r = run_render(call({"--color", dir_ / "layers.exr"}, "l_out.exr", "l_coc.exr"));
  ASSERT_EQ(r.code, 0) << r.message;
  expect_same_as_separate("l_out.exr", "l_coc.exr");
  // ... and two layers without such a name are ambiguous.
  write_aov("amb.exr", {"diffuse.R", "diffuse.G", "diffuse.B", "diffuse.A"}, "Z", {"spec.R", "spec.G", "spec.B"});
  expect_failure(call({"--color", dir_ / "amb.exr"}, "out.exr"), 3, {"amb.exr", "diffuse, spec", "--color-channels"},
                 {"c.exr", "z.exr", "layers.exr", "l_out.exr", "l_coc.exr", "sep.exr", "sep_coc.exr", "amb.exr"});
  r = run_render(call({"--color", dir_ / "amb.exr", "--color-channels", "diffuse.R,diffuse.G,diffuse.B,diffuse.A"},
                      "d_out.exr", "d_coc.exr"));
  ASSERT_EQ(r.code, 0) << r.message;
  expect_same_as_separate("d_out.exr", "d_coc.exr");
  // spec.*: 0.25, 0.75, 1.25 everywhere, opaque (no alpha named).
  r = run_render(call({"--color", dir_ / "amb.exr", "--color-channels", "spec.R,spec.G,spec.B"}, "s_out.exr"));
  ASSERT_EQ(r.code, 0) << r.message;
  const Image s = io::read_color(dir_ / "s_out.exr");
  EXPECT_NEAR(s.at(W / 2, H / 2, 1), 0.75f, 1e-5f);  // a constant plane, blurred
  EXPECT_FLOAT_EQ(s.at(W / 2, H / 2, 3), 1.0f);
}

TEST_F(RenderInputs, BadColorChannelsAreOneLineErrorsWithoutOutput) {
  const std::vector<std::string> keep = {"c.exr", "z.exr"};
  expect_failure(call({"--color", dir_ / "c.exr", "--depth", dir_ / "z.exr", "--color-channels", "R,G"}, "out.exr"), 2,
                 {"--color-channels R,G", "R,G,B"}, keep);
  expect_failure(call({"--color", dir_ / "c.exr", "--depth", dir_ / "z.exr", "--color-channels", "R,,B"}, "out.exr"), 2,
                 {"--color-channels R,,B"}, keep);
  expect_failure(call({"--color", dir_ / "c.exr", "--depth", dir_ / "z.exr", "--color-channels", "R,G,X"}, "out.exr"),
                 3, {"c.exr", "--color-channels", "no channel X"}, keep);
}

// --- units -------------------------------------------------------------------------------

TEST_F(RenderInputs, DepthInCentimetresWithItsScaleGivesTheSameCocMapBitForBit) {
  render_separate();
  Image cm = depth_;
  for (float& v : cm.data()) v *= 100.0f;  // exact: 600, 125, 50
  io::WriteOptions z;
  z.channel_name = "Z";
  io::write_image(dir_ / "cm.exr", cm, z);
  for (const std::vector<std::string>& flag :
       {std::vector<std::string>{"--depth-scale", "0.01"}, std::vector<std::string>{"--depth-units", "cm"}}) {
    std::vector<std::string> in = {"--color", dir_ / "c.exr", "--depth", dir_ / "cm.exr"};
    in.insert(in.end(), flag.begin(), flag.end());
    const CliResult r = run_render(call(in, "cm_out.exr", "cm_coc.exr"));
    ASSERT_EQ(r.code, 0) << r.message;
    EXPECT_EQ(read_coc("cm_coc.exr").data(), read_coc("sep_coc.exr").data()) << flag[0];
    EXPECT_EQ(io::read_color(dir_ / "cm_out.exr").data(), io::read_color(dir_ / "sep.exr").data()) << flag[0];
    EXPECT_FALSE(contains(r.err, "warning")) << r.err;
  }
}

TEST_F(RenderInputs, BadDepthScalesAreUsageErrorsWithoutOutput) {
  const std::vector<std::string> keep = {"c.exr", "z.exr"};
  for (const char* bad : {"0", "-1", "inf", "nan", "1e400", "x"})
    expect_failure(call({"--color", dir_ / "c.exr", "--depth", dir_ / "z.exr", "--depth-scale", bad}, "out.exr"), 2,
                   {"--depth-scale"}, keep);
  expect_failure(call({"--color", dir_ / "c.exr", "--depth", dir_ / "z.exr", "--depth-units", "furlong"}, "out.exr"), 2,
                 {"--depth-units"}, keep);
  expect_failure(
      call({"--color", dir_ / "c.exr", "--depth", dir_ / "z.exr", "--depth-units", "cm", "--depth-scale", "0.01"},
           "out.exr"),
      2, {"--depth-scale and --depth-units"}, keep);
}

TEST_F(RenderInputs, CentimetresReadAsMetresWarnOnceAndRenderUnchanged) {
  Image cm = depth_;
  for (float& v : cm.data()) v *= 100.0f;
  io::WriteOptions z;
  z.channel_name = "Z";
  io::write_image(dir_ / "cm.exr", cm, z);
  // A 50 mm f/2.8 lens focused at "200" (the user's centimetres): every radius is far below
  // half a pixel.
  const std::vector<std::string> lens = {"--color",    dir_ / "c.exr", "--depth",  dir_ / "cm.exr",
                                         "--f-number", "2.8",          "--focus",  "200",
                                         "--method",   "reference",    "--output", dir_ / "out.exr"};
  const CliResult r = run_render(lens);
  ASSERT_EQ(r.code, 0) << r.message;
  EXPECT_TRUE(contains(r.err, "warning: every CoC radius is below 0.5 px")) << r.err;
  EXPECT_TRUE(contains(r.err, "--depth-units")) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 2) << r.err;  // "wrote …" and the warning
  // The picture is what the library renders from the same numbers.
  RenderSettings s;
  s.method = "reference";
  ThinLens t;
  t.f_number = 2.8;
  t.focus_distance_m = 200;
  s.camera.model = t;
  const RenderResult want = render(Frame{color_, cm, {}, {}}, s);
  EXPECT_EQ(io::read_color(dir_ / "out.exr").data(), want.image.data());
  // In metres, no warning.
  const CliResult m = run_render({"--color", dir_ / "c.exr", "--depth", dir_ / "z.exr", "--f-number", "2.8", "--focus",
                                  "2", "--method", "reference", "--output", dir_ / "m.exr"});
  ASSERT_EQ(m.code, 0) << m.message;
  EXPECT_FALSE(contains(m.err, "warning")) << m.err;
}

TEST_F(RenderInputs, SixteenBitDepthReadAsZWarnsAndDisparityDoesNot) {
  // A normalised disparity map (bright = near) as a 16-bit PNG.
  Image disp(W, H, 1);
  for (std::size_t i = 0; i < disp.plane_size(); ++i) disp.plane(0)[i] = 0.5f / depth_.plane(0)[i];
  io::WriteOptions png;
  png.bits = 16;
  io::write_image(dir_ / "disp.png", disp, png);
  const CliResult r = run_render(call({"--color", dir_ / "c.exr", "--depth", dir_ / "disp.png"}, "out.exr"));
  ASSERT_EQ(r.code, 0) << r.message;
  EXPECT_TRUE(contains(r.err, "disp.png: 8/16-bit depth read as z")) << r.err;
  EXPECT_TRUE(contains(r.err, "--depth-kind disparity")) << r.err;
  const CliResult d = run_render(
      call({"--color", dir_ / "c.exr", "--depth", dir_ / "disp.png", "--depth-kind", "disparity"}, "out2.exr"));
  ASSERT_EQ(d.code, 0) << d.message;
  EXPECT_FALSE(contains(d.err, "warning")) << d.err;
}

// --- the focus-zone picture and outputs without --output -----------------------------------

TEST(FocusZonePicture, NearOrangeFarBlueInFocusGreyScaledByTheLargestRadius) {
  Image coc(5, 1, 1);
  const float r[5] = {0.0f, 0.49f, 8.0f, -4.0f, -2.0f};
  std::copy(r, r + 5, coc.plane(0));
  const Image pic = cli::focus_zone_picture(coc);
  ASSERT_EQ(pic.channels(), 3);
  auto px = [&](int x) { return std::vector<float>{pic.at(x, 0, 0), pic.at(x, 0, 1), pic.at(x, 0, 2)}; };
  EXPECT_EQ(px(0), (std::vector<float>{0.5f, 0.5f, 0.5f}));
  EXPECT_EQ(px(1), (std::vector<float>{0.5f, 0.5f, 0.5f}));
  EXPECT_EQ(px(2), (std::vector<float>{1.0f, 0.55f, 0.0f}));           // the largest |r|: the full hue
  EXPECT_EQ(px(3), (std::vector<float>{0.0f, 0.45f * 0.5f, 0.5f}));    // half of it, far
  EXPECT_EQ(px(4), (std::vector<float>{0.0f, 0.45f * 0.25f, 0.25f}));  // a quarter
}

TEST_F(RenderInputs, OutputCocPngIsTheFocusZonePictureIn8And16Bits) {
  const CliResult e = run_render(call({"--color", dir_ / "c.exr", "--depth", dir_ / "z.exr"}, "out.exr", "coc.exr"));
  ASSERT_EQ(e.code, 0) << e.message;
  const Image want = cli::focus_zone_picture(read_coc("coc.exr"));
  for (const char* bits : {"8", "16"}) {
    std::vector<std::string> a = {"--color", dir_ / "c.exr", "--depth", dir_ / "z.exr", "--coc-bits", bits};
    const CliResult r = run_render(call(a, "out.exr", std::string("coc") + bits + ".png"));
    ASSERT_EQ(r.code, 0) << r.message;
    // Read back as stored codes (PNG colour is sRGB-decoded by read_color; read as depth: raw).
    const double q = std::string(bits) == "8" ? 255.0 : 65535.0;
    auto in = OIIO::ImageInput::open(dir_ / (std::string("coc") + bits + ".png"));
    ASSERT_TRUE(in);
    EXPECT_EQ(in->spec().format, std::string(bits) == "8" ? OIIO::TypeDesc::UINT8 : OIIO::TypeDesc::UINT16);
    ASSERT_EQ(in->spec().nchannels, 3);
    std::vector<float> v(static_cast<std::size_t>(W) * H * 3);
    ASSERT_TRUE(in->read_image(0, 0, 0, 3, OIIO::TypeDesc::FLOAT, v.data()));
    for (std::size_t i = 0; i < want.plane_size(); ++i)
      for (int c = 0; c < 3; ++c)
        ASSERT_NEAR(v[i * 3 + c], want.plane(c)[i], 0.5 / q + 1e-7) << bits << "-bit, pixel " << i << " channel " << c;
  }
  // The box (1.25 m, in front of the 2 m focus) is orange, the 6 m background blue.
  EXPECT_GT(want.at(32, 24, 0), want.at(32, 24, 2));
  EXPECT_GT(want.at(2, 2, 2), want.at(2, 2, 0));
}

TEST_F(RenderInputs, DebugViewAndCocMapNeedNoOutput) {
  CliResult r = run_render({"--color", dir_ / "c.exr", "--depth", dir_ / "z.exr", "--focus", "2", "--blur-at-infinity",
                            "6", "--method", "mcguire", "--debug-view", "coc", "--debug-output", dir_ / "d.exr"});
  ASSERT_EQ(r.code, 0) << r.message;
  r = run_render({"--color", dir_ / "c.exr", "--depth", dir_ / "z.exr", "--focus", "2", "--blur-at-infinity", "6",
                  "--output-coc", dir_ / "zones.png"});
  ASSERT_EQ(r.code, 0) << r.message;
  EXPECT_EQ(dir_.entries(), (std::vector<std::string>{"c.exr", "d.exr", "z.exr", "zones.png"}));
  // Nothing to write at all is still a usage error; --coc-bits needs a picture CoC output.
  expect_failure({"--color", dir_ / "c.exr", "--depth", dir_ / "z.exr", "--focus", "2", "--blur-at-infinity", "6"}, 2,
                 {"--output: required"}, {"c.exr", "d.exr", "z.exr", "zones.png"});
  expect_failure(call({"--color", dir_ / "c.exr", "--depth", dir_ / "z.exr", "--coc-bits", "16"}, "o.exr", "c2.exr"), 2,
                 {"--coc-bits 16"}, {"c.exr", "d.exr", "z.exr", "zones.png"});
}

// --- focus animation -----------------------------------------------------------------------

// The documented ease, written out independently: smoothstep between the keys.
double expected_focus(long f) {
  const double f0 = 1, f1 = 24, z0 = 1.5, z1 = 6;
  if (f <= f0) return z0;
  if (f >= f1) return z1;
  const double t = (f - f0) / (f1 - f0);
  return z0 + (z1 - z0) * (3 * t * t - 2 * t * t * t);
}

TEST(FocusEase, KeysHoldOutsideAndEaseBetween) {
  const std::vector<double> z = {1.5, 6, 2};
  const std::vector<long> f = {1, 24, 30};
  EXPECT_EQ(cli::eased_focus(z, f, 0), 1.5);
  EXPECT_EQ(cli::eased_focus(z, f, 1), 1.5);
  EXPECT_EQ(cli::eased_focus(z, f, 24), 6.0);
  EXPECT_EQ(cli::eased_focus(z, f, 99), 2.0);
  EXPECT_NEAR(cli::eased_focus(z, f, 27), 4.0, 1e-12);  // the middle of 24..30: half way
  for (long k = 2; k < 24; ++k) {
    EXPECT_NEAR(cli::eased_focus(z, f, k), expected_focus(k), 1e-12) << k;
    EXPECT_GT(cli::eased_focus(z, f, k), cli::eased_focus(z, f, k - 1)) << k;  // monotone between keys
  }
}

TEST_F(RenderInputs, FocusKeysOnOneStillPlateWriteFramesWhoseCocFollowsTheEase) {
  const std::string K = "6";
  const CliResult r =
      run_render({"--color", dir_ / "c.exr", "--depth", dir_ / "z.exr", "--frames", "1-24", "--focus-keys",
                  "1:1.5,24:6", "--blur-at-infinity", K, "--output-coc", dir_ / "coc.####.exr"});
  ASSERT_EQ(r.code, 0) << r.message;
  EXPECT_EQ(dir_.entries().size(), 2u + 24u);
  for (const long f : {1L, 2L, 7L, 12L, 13L, 23L, 24L}) {
    char name[32];
    std::snprintf(name, sizeof name, "coc.%04ld.exr", f);
    const Image coc = read_coc(name);
    CameraModel cam;
    cam.model = BlurAtInfinity{expected_focus(f), 6.0};
    const CocFunction fn(cam, W);
    for (std::size_t i = 0; i < coc.plane_size(); ++i)
      ASSERT_EQ(coc.plane(0)[i], fn(depth_.plane(0)[i])) << "frame " << f << " pixel " << i;
  }
}

TEST_F(RenderInputs, FocusKeysGiveTheSameFramesForAnyChunking) {
  auto run = [&](const std::string& dir, std::vector<std::string> extra) {
    std::filesystem::create_directories(dir_ / dir);
    std::vector<std::string> a = {"--color",         dir_ / "c.exr",
                                  "--depth",         dir_ / "z.exr",
                                  "--frames",        "1-7",
                                  "--focus-at-keys", "1:32,24,7:2,2",
                                  "--f-number",      "2",
                                  "--method",        "sterna",
                                  "--output",        dir_ / (dir + "/o.####.exr")};
    a.insert(a.end(), extra.begin(), extra.end());
    const CliResult r = run_render(a);
    ASSERT_EQ(r.code, 0) << r.message;
  };
  run("whole", {});
  for (const char* i : {"0", "1", "2"}) run("chunks", {"--chunk-count", "3", "--chunk-index", i});
  for (long f = 1; f <= 7; ++f) {
    const std::string n = "/o.000" + std::to_string(f) + ".exr";
    EXPECT_EQ(io::read_color(dir_ / ("whole" + n)).data(), io::read_color(dir_ / ("chunks" + n)).data()) << f;
  }
  // The focus moves: the first and last frames differ.
  EXPECT_NE(io::read_color(dir_ / "whole/o.0001.exr").data(), io::read_color(dir_ / "whole/o.0007.exr").data());
}

TEST_F(RenderInputs, BadFocusKeysAreUsageErrorsWithoutOutput) {
  const std::vector<std::string> keep = {"c.exr", "z.exr"};
  auto keyed = [&](const std::string& flag, const std::string& keys) {
    return std::vector<std::string>{
        "--color", dir_ / "c.exr",       "--depth", dir_ / "z.exr", "--frames",         "1-4", flag,
        keys,      "--blur-at-infinity", "6",       "--output",     dir_ / "o.####.exr"};
  };
  expect_failure(keyed("--focus-keys", "4:2,1:3"), 2, {"--focus-keys 4:2,1:3", "increasing frame order"}, keep);
  expect_failure(keyed("--focus-keys", "1:2,1:3"), 2, {"--focus-keys", "frame 1 is given twice"}, keep);
  expect_failure(keyed("--focus-keys", "1:inf,4:3"), 2, {"--focus-keys", "frame 1"}, keep);
  expect_failure(keyed("--focus-keys", "1:nan,4:3"), 2, {"--focus-keys"}, keep);
  expect_failure(keyed("--focus-keys", "1:-2,4:3"), 2, {"--focus-keys"}, keep);
  expect_failure(keyed("--focus-keys", "x:2"), 2, {"--focus-keys", "not a frame number"}, keep);
  expect_failure(keyed("--focus-keys", "1:2,"), 2, {"--focus-keys"}, keep);
  expect_failure(keyed("--focus-at-keys", "1:3"), 2, {"--focus-at-keys", "FRAME:X,Y"}, keep);
  expect_failure(keyed("--focus-at-keys", "2:3,4,1:5,6"), 2, {"--focus-at-keys", "increasing"}, keep);
  std::vector<std::string> both = keyed("--focus-keys", "1:2");
  both.insert(both.end(), {"--focus", "3"});
  expect_failure(both, 2, {"--focus and --focus-keys"}, keep);
  // Without --frames.
  expect_failure(call({"--color", dir_ / "c.exr", "--depth", dir_ / "z.exr", "--focus-keys", "1:2"}, "o.exr"), 2,
                 {"--focus and --focus-keys"}, keep);
  expect_failure({"--color", dir_ / "c.exr", "--depth", dir_ / "z.exr", "--focus-keys", "1:2", "--blur-at-infinity",
                  "6", "--output", dir_ / "o.exr"},
                 2, {"need --frames"}, keep);
}

TEST_F(RenderInputs, FNumberAndBlurAtInfinityKeysAnimateTheLensLikeTheFocus) {
  const std::vector<double> n = {2, 8}, k = {3, 9};
  const std::vector<long> f = {1, 5};
  const CliResult r =
      run_render({"--color", dir_ / "c.exr", "--depth", dir_ / "z.exr", "--frames", "1-5", "--f-number-keys", "1:2,5:8",
                  "--focus", "2", "--focal-length", "35", "--output-coc", dir_ / "n.####.exr"});
  ASSERT_EQ(r.code, 0) << r.message;
  const CliResult s =
      run_render({"--color", dir_ / "c.exr", "--depth", dir_ / "z.exr", "--frames", "1-5", "--blur-at-infinity-keys",
                  "1:3,5:9", "--focus-keys", "1:1.5,5:6", "--output-coc", dir_ / "k.####.exr"});
  ASSERT_EQ(s.code, 0) << s.message;
  for (long fr = 1; fr <= 5; ++fr) {
    const std::string tag = std::to_string(fr);
    CameraModel thin;
    ThinLens t;
    t.f_number = cli::eased_focus(n, f, fr);
    t.focal_length_mm = 35;
    t.focus_distance_m = 2;
    thin.model = t;
    CameraModel blur;
    blur.model = BlurAtInfinity{cli::eased_focus({1.5, 6}, f, fr), cli::eased_focus(k, f, fr)};
    const Image a = read_coc("n.000" + tag + ".exr"), b = read_coc("k.000" + tag + ".exr");
    const CocFunction fa(thin, W), fb(blur, W);
    for (std::size_t i = 0; i < a.plane_size(); ++i) {
      ASSERT_EQ(a.plane(0)[i], fa(depth_.plane(0)[i])) << "frame " << fr << " pixel " << i;
      ASSERT_EQ(b.plane(0)[i], fb(depth_.plane(0)[i])) << "frame " << fr << " pixel " << i;
    }
  }
  EXPECT_NE(read_coc("n.0001.exr").data(), read_coc("n.0003.exr").data());
}

TEST_F(RenderInputs, BadLensKeysAreUsageErrorsWithoutOutput) {
  const std::vector<std::string> keep = {"c.exr", "z.exr"};
  auto keyed = [&](const std::string& flag, const std::string& keys) {
    return std::vector<std::string>{
        "--color", dir_ / "c.exr", "--depth", dir_ / "z.exr", "--frames",         "1-4", flag,
        keys,      "--focus",      "2",       "--output",     dir_ / "o.####.exr"};
  };
  expect_failure(keyed("--f-number-keys", "1:0,4:2"), 2, {"--f-number-keys 1:0,4:2", "frame 1", "0.1 to 10000"}, keep);
  expect_failure(keyed("--f-number-keys", "4:2,1:3"), 2, {"--f-number-keys", "increasing frame order"}, keep);
  expect_failure(keyed("--blur-at-infinity-keys", "1:-1"), 2, {"--blur-at-infinity-keys", "frame 1"}, keep);
  expect_failure(keyed("--blur-at-infinity-keys", "1:3,1:4"), 2, {"--blur-at-infinity-keys", "given twice"}, keep);
  expect_failure(keyed("--blur-at-infinity-keys", "1:nan"), 2, {"--blur-at-infinity-keys"}, keep);
  std::vector<std::string> both = keyed("--f-number-keys", "1:2");
  both.insert(both.end(), {"--f-number", "2"});
  expect_failure(both, 2, {"--f-number and --f-number-keys", "exactly one CoC model"}, keep);
  expect_failure({"--color", dir_ / "c.exr", "--depth", dir_ / "z.exr", "--f-number-keys", "1:2", "--focus", "2",
                  "--output", dir_ / "o.exr"},
                 2, {"need --frames"}, keep);
}

// --- depth at another resolution ------------------------------------------------------------

TEST_F(RenderInputs, QuarterSizeDepthIsUpsampledAndOtherAspectsRefusedUnlessStretched) {
  Image low(16, 12, 1, 6.0f), odd(16, 16, 1, 6.0f);
  io::WriteOptions z;
  z.channel_name = "Z";
  io::write_image(dir_ / "low.exr", low, z);
  io::write_image(dir_ / "odd.exr", odd, z);
  // A flat quarter-size depth gives the same CoC map as the flat full-size one, by every method.
  Image flat(W, H, 1, 6.0f);
  io::write_image(dir_ / "flat.exr", flat, z);
  ASSERT_EQ(run_render(call({"--color", dir_ / "c.exr", "--depth", dir_ / "flat.exr"}, "f.exr", "f_coc.exr")).code, 0);
  for (const char* how : {"nearest", "bilinear", "guided", "guided-filter"}) {
    const CliResult r = run_render(
        call({"--color", dir_ / "c.exr", "--depth", dir_ / "low.exr", "--depth-upsample", how}, "l.exr", "l_coc.exr"));
    ASSERT_EQ(r.code, 0) << how << ": " << r.message;
    EXPECT_EQ(read_coc("l_coc.exr").data(), read_coc("f_coc.exr").data()) << how;
  }
  const std::vector<std::string> keep = {"c.exr", "z.exr",     "low.exr", "odd.exr",  "flat.exr",
                                         "f.exr", "f_coc.exr", "l.exr",   "l_coc.exr"};
  expect_failure(call({"--color", dir_ / "c.exr", "--depth", dir_ / "odd.exr"}, "o.exr"), 3,
                 {"odd.exr: depth is 16x16", "64x48", "--depth-fit stretch"}, keep);
  const CliResult s = run_render(
      call({"--color", dir_ / "c.exr", "--depth", dir_ / "odd.exr", "--depth-fit", "stretch"}, "s.exr", "s_coc.exr"));
  ASSERT_EQ(s.code, 0) << s.message;
  EXPECT_EQ(read_coc("s_coc.exr").data(), read_coc("f_coc.exr").data());
  expect_failure(call({"--color", dir_ / "low.exr", "--depth", dir_ / "c.exr"}, "o.exr"), 3, {"larger"},
                 {"c.exr", "z.exr", "low.exr", "odd.exr", "flat.exr", "f.exr", "f_coc.exr", "l.exr", "l_coc.exr",
                  "s.exr", "s_coc.exr"});
  expect_failure(call({"--color", dir_ / "c.exr", "--depth", dir_ / "low.exr", "--depth-upsample", "cubic"}, "o.exr"),
                 2, {"--depth-upsample"},
                 {"c.exr", "z.exr", "low.exr", "odd.exr", "flat.exr", "f.exr", "f_coc.exr", "l.exr", "l_coc.exr",
                  "s.exr", "s_coc.exr"});
}
