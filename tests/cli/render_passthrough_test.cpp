// `dofkit render` EXR passthrough: an EXR --output keeps the colour EXR's other channels (in
// their pixel types, unchanged) and its metadata; --rgba-only writes RGBA alone. The input
// files are made with OpenImageIO (not the code under test). Tiny frames (16x12).
#include <gtest/gtest.h>

#include <Imath/half.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <map>

#include "io/image_io.hpp"
#include "io/io_test_util.hpp"
#include "render_cli_util.hpp"

using namespace dofkit;
using namespace dofkit::test;

namespace {

constexpr int W = 16, H = 12;

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

struct Channel {
  std::string name;
  OIIO::TypeDesc type;
  std::vector<std::uint8_t> bytes;  // W·H samples of `type`
};

// A file as OpenImageIO reads it back: channels in the file's order with their types and
// samples, and every attribute as text.
struct ExrContents {
  std::vector<Channel> channels;
  std::map<std::string, std::string> attributes;
  const Channel* find(const std::string& n) const {
    for (const Channel& c : channels)
      if (c.name == n) return &c;
    return nullptr;
  }
  std::vector<std::string> names() const {
    std::vector<std::string> v;
    for (const Channel& c : channels) v.push_back(c.name);
    return v;
  }
};

ExrContents read_exr(const std::string& path) {
  ExrContents out;
  auto in = OIIO::ImageInput::open(path);
  EXPECT_TRUE(in) << path;
  if (!in) return out;
  const OIIO::ImageSpec& spec = in->spec();
  for (int c = 0; c < spec.nchannels; ++c) {
    Channel ch{spec.channelnames[c], spec.channelformat(c), {}};
    ch.bytes.resize(static_cast<std::size_t>(W) * H * ch.type.size());
    EXPECT_TRUE(in->read_image(0, 0, c, c + 1, ch.type, ch.bytes.data())) << in->geterror();
    out.channels.push_back(std::move(ch));
  }
  for (const auto& p : spec.extra_attribs) out.attributes[p.name().string()] = p.get_string(16);
  return out;
}

class RenderPassthrough : public ::testing::Test {
 protected:
  void SetUp() override {
    color_ = test_rgba(W, H, true, true);
    depth_ = Image(W, H, 1, 6.0f);
    for (int y = 3; y < 9; ++y)
      for (int x = 4; x < 11; ++x) depth_.at(x, y) = 1.25f;
    io::write_image(dir_ / "c.exr", color_);
    io::WriteOptions z;
    z.channel_name = "Z";
    io::write_image(dir_ / "z.exr", depth_, z);
  }

  // An EXR holding the colour (channels `rgba`), depth (`depth_name`, float), the AOVs below
  // and metadata, written by OpenImageIO with per-channel pixel types.
  void write_aov_file(const std::string& file, const std::vector<std::string>& rgba, const std::string& depth_name,
                      bool bare_r_filler = false) {
    std::vector<Channel> ch;
    const std::size_t n = static_cast<std::size_t>(W) * H;
    auto add_float = [&](const std::string& name, const float* v) {
      Channel c{name, OIIO::TypeDesc::FLOAT, std::vector<std::uint8_t>(n * 4)};
      std::memcpy(c.bytes.data(), v, n * 4);
      ch.push_back(std::move(c));
    };
    for (std::size_t c = 0; c < rgba.size(); ++c) add_float(rgba[c], color_.plane(static_cast<int>(c)));
    add_float(depth_name, depth_.plane(0));
    // Normals as half (values exact in half), a cryptomatte-style id as uint with bits that a
    // float would lose, a position pass as float.
    for (int k = 0; k < 3; ++k) {
      Channel c{std::string("N.") + "XYZ"[k], OIIO::TypeDesc::HALF, std::vector<std::uint8_t>(n * 2)};
      for (std::size_t i = 0; i < n; ++i) {
        const std::uint16_t h = Imath::half(static_cast<float>((i % 7) - 3) * 0.25f + 0.125f * k).bits();
        std::memcpy(c.bytes.data() + 2 * i, &h, 2);
      }
      ch.push_back(std::move(c));
    }
    Channel id{"crypto.id", OIIO::TypeDesc::UINT32, std::vector<std::uint8_t>(n * 4)};
    for (std::size_t i = 0; i < n; ++i) {
      const std::uint32_t v = 0x9E3779B1u * static_cast<std::uint32_t>(i + 1);
      std::memcpy(id.bytes.data() + 4 * i, &v, 4);
    }
    ch.push_back(std::move(id));
    std::vector<float> pz(n);
    for (std::size_t i = 0; i < n; ++i) pz[i] = -0.1f * static_cast<float>(i);
    add_float("P.Z", pz.data());
    if (bare_r_filler) {
      std::vector<float> r(n, 0.75f);
      add_float("R", r.data());
    }

    OIIO::ImageSpec spec(W, H, static_cast<int>(ch.size()), OIIO::TypeDesc::FLOAT);
    spec.channelnames.clear();
    spec.channelformats.clear();
    for (const Channel& c : ch) {
      spec.channelnames.push_back(c.name);
      spec.channelformats.push_back(c.type);
    }
    spec.alpha_channel = -1;
    spec.z_channel = -1;
    spec.attribute("compression", "zip");
    spec.attribute("Copyright", "a studio");               // EXR owner
    spec.attribute("ImageDescription", "shot 10 take 3");  // EXR comments
    spec.attribute("studio:shot", "sh010");
    const float chroma[8] = {0.64f, 0.33f, 0.3f, 0.6f, 0.15f, 0.06f, 0.3127f, 0.329f};
    spec.attribute("chromaticities", OIIO::TypeDesc(OIIO::TypeDesc::FLOAT, 8), chroma);
    spec.attribute("camera:focal_mm", 35.0f);
    // OpenImageIO writes contiguous pixels: interleave the channels' native bytes.
    std::size_t pixel_bytes = 0;
    for (const Channel& c : ch) pixel_bytes += c.type.size();
    std::vector<std::uint8_t> pixels(n * pixel_bytes);
    for (std::size_t i = 0; i < n; ++i) {
      std::size_t off = 0;
      for (const Channel& c : ch) {
        std::memcpy(pixels.data() + i * pixel_bytes + off, c.bytes.data() + i * c.type.size(), c.type.size());
        off += c.type.size();
      }
    }
    inputs_[file] = ch;
    auto out = OIIO::ImageOutput::create(dir_ / file);
    ASSERT_TRUE(out);
    ASSERT_TRUE(out->open(dir_ / file, spec)) << out->geterror();
    ASSERT_TRUE(out->write_image(OIIO::TypeDesc::UNKNOWN, pixels.data())) << out->geterror();
    ASSERT_TRUE(out->close());
  }

  std::vector<std::string> call(std::vector<std::string> args, const std::string& out) const {
    for (const char* a : {"--focus", "2", "--blur-at-infinity", "4", "--method", "reference"}) args.push_back(a);
    args.push_back("--output");
    args.push_back(dir_ / out);
    return args;
  }

  ScratchDir dir_;
  Image color_, depth_;
  std::map<std::string, std::vector<Channel>> inputs_;
};

}  // namespace

TEST_F(RenderPassthrough, AovChannelsAndMetadataPassUnchangedAndRgbaIsAsWithoutThem) {
  write_aov_file("aov.exr", {"R", "G", "B", "A"}, "depth.Z");
  ASSERT_EQ(run_render(call({"--color", dir_ / "c.exr", "--depth", dir_ / "z.exr"}, "plain.exr")).code, 0);
  const CliResult r = run_render(call({"--color", dir_ / "aov.exr"}, "out.exr"));
  ASSERT_EQ(r.code, 0) << r.message;
  const CliResult only = run_render(call({"--color", dir_ / "aov.exr", "--rgba-only"}, "only.exr"));
  ASSERT_EQ(only.code, 0) << only.message;

  // RGBA: bit for bit the render of colour + separate depth, with or without passthrough.
  EXPECT_EQ(io::read_color(dir_ / "out.exr").data(), io::read_color(dir_ / "plain.exr").data());
  EXPECT_EQ(io::read_color(dir_ / "only.exr").data(), io::read_color(dir_ / "plain.exr").data());

  const ExrContents out = read_exr(dir_ / "out.exr");
  std::vector<std::string> want = {"A", "B", "G", "N.X", "N.Y", "N.Z", "P.Z", "R", "crypto.id", "depth.Z"};
  std::vector<std::string> got = out.names();
  std::sort(got.begin(), got.end());
  EXPECT_EQ(got, want);
  // Every other channel: its name, its pixel type and its samples, byte for byte.
  for (const Channel& in : inputs_["aov.exr"]) {
    if (in.name.size() == 1) continue;  // R, G, B, A: the render's
    const Channel* c = out.find(in.name);
    ASSERT_TRUE(c) << in.name;
    EXPECT_EQ(c->type, in.type) << in.name;
    EXPECT_EQ(c->bytes, in.bytes) << in.name;
  }
  EXPECT_EQ(out.find("R")->type, OIIO::TypeDesc::FLOAT);
  // Metadata: the owner, comments, chromaticities and custom attributes come back.
  const ExrContents in = read_exr(dir_ / "aov.exr");
  for (const char* k : {"Copyright", "ImageDescription", "studio:shot", "chromaticities", "camera:focal_mm"}) {
    ASSERT_TRUE(in.attributes.count(k)) << k;
    ASSERT_TRUE(out.attributes.count(k)) << k;
    EXPECT_EQ(out.attributes.at(k), in.attributes.at(k)) << k;
  }
  EXPECT_EQ(out.attributes.at("studio:shot"), "sh010");

  // --rgba-only: R, G, B, A and none of the input's metadata.
  const ExrContents o = read_exr(dir_ / "only.exr");
  got = o.names();
  std::sort(got.begin(), got.end());
  EXPECT_EQ(got, (std::vector<std::string>{"A", "B", "G", "R"}));
  EXPECT_FALSE(o.attributes.count("studio:shot"));
  EXPECT_FALSE(o.attributes.count("Copyright"));
}

TEST_F(RenderPassthrough, HalfOutputKeepsTheRgbaOfRgbaOnly) {
  write_aov_file("aov.exr", {"R", "G", "B", "A"}, "Z");
  const CliResult h16 =
      run_render(call({"--color", dir_ / "aov.exr", "--bits", "16", "--compression", "piz"}, "h.exr"));
  ASSERT_EQ(h16.code, 0) << h16.message;
  ASSERT_EQ(run_render(call({"--color", dir_ / "aov.exr", "--bits", "16", "--rgba-only"}, "ho.exr")).code, 0);
  const ExrContents h = read_exr(dir_ / "h.exr"), ho = read_exr(dir_ / "ho.exr");
  for (const char* c : {"R", "G", "B", "A"}) {
    ASSERT_TRUE(h.find(c) && ho.find(c)) << c;
    EXPECT_EQ(h.find(c)->type, OIIO::TypeDesc::HALF);
    EXPECT_EQ(h.find(c)->bytes, ho.find(c)->bytes) << c;
  }
  ASSERT_TRUE(h.find("Z"));
  EXPECT_EQ(h.find("Z")->type, OIIO::TypeDesc::FLOAT);  // the depth keeps its own type
  EXPECT_EQ(h.find("Z")->bytes, inputs_["aov.exr"][4].bytes);
}

TEST_F(RenderPassthrough, ALayerColourReplacedByRgbaAndAClashingBareChannelIsDroppedWithANote) {
  write_aov_file("layer.exr", {"beauty.R", "beauty.G", "beauty.B", "beauty.A"}, "Z", /*bare_r_filler=*/true);
  const CliResult r = run_render(
      call({"--color", dir_ / "layer.exr", "--color-channels", "beauty.R,beauty.G,beauty.B,beauty.A"}, "out.exr"));
  ASSERT_EQ(r.code, 0) << r.message;
  EXPECT_TRUE(contains(r.err, "channel(s) R not passed through")) << r.err;
  const ExrContents out = read_exr(dir_ / "out.exr");
  std::vector<std::string> got = out.names();
  std::sort(got.begin(), got.end());
  EXPECT_EQ(got, (std::vector<std::string>{"A", "B", "G", "N.X", "N.Y", "N.Z", "P.Z", "R", "Z", "crypto.id"}));
  ASSERT_EQ(run_render(call({"--color", dir_ / "c.exr", "--depth", dir_ / "z.exr"}, "plain.exr")).code, 0);
  EXPECT_EQ(io::read_color(dir_ / "out.exr").data(), io::read_color(dir_ / "plain.exr").data());
}

TEST_F(RenderPassthrough, RgbaOnlyNeedsAnExrOutput) {
  const CliResult r =
      run_render(call({"--color", dir_ / "c.exr", "--depth", dir_ / "z.exr", "--rgba-only"}, "out.png"));
  EXPECT_EQ(r.code, 2);
  EXPECT_TRUE(contains(r.message, "--rgba-only")) << r.message;
  EXPECT_FALSE(contains(r.message, "\n"));
  std::vector<std::string> keep = {"c.exr", "z.exr"};
  EXPECT_EQ(dir_.entries(), keep);
}
