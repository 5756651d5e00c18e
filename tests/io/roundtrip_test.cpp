// Colour round trips through every supported format, and the sRGB decode of integer files.
#include <OpenImageIO/imagebufalgo.h>
#include <gtest/gtest.h>

#include <filesystem>

#include "dofkit/error.hpp"
#include "io/image_io.hpp"
#include "io/io_test_util.hpp"

using namespace dofkit;
using namespace dofkit::test;
using dofkit::io::Encoding;
using dofkit::io::WriteOptions;

namespace {

// Largest |a − b| over all samples.
double max_diff(const Image& a, const Image& b) {
  EXPECT_TRUE(a.same_size(b));
  EXPECT_EQ(a.channels(), b.channels());
  double m = 0;
  for (std::size_t i = 0; i < a.data().size(); ++i) m = std::max(m, std::abs(double(a.data()[i]) - b.data()[i]));
  return m;
}

// Largest difference of the straight (un-premultiplied) colour in the sRGB-encoded domain, for
// pixels whose alpha is at least `min_alpha` (8/16-bit files store exactly that quantity).
double max_encoded_diff(const Image& a, const Image& b, double min_alpha = 0.0) {
  double m = 0;
  for (int y = 0; y < a.height(); ++y)
    for (int x = 0; x < a.width(); ++x) {
      const double aa = a.at(x, y, 3), ab = b.at(x, y, 3);
      if (aa < min_alpha) continue;
      for (int c = 0; c < 3; ++c) {
        const double va = ref_linear_to_srgb(a.at(x, y, c) / aa), vb = ref_linear_to_srgb(b.at(x, y, c) / ab);
        m = std::max(m, std::abs(va - vb));
      }
      m = std::max(m, std::abs(aa - ab));
    }
  return m;
}

// Planar image → interleaved samples, as OIIO's write_image takes them.
std::vector<float> interleave(const Image& img) {
  const int w = img.width(), h = img.height(), n = img.channels();
  std::vector<float> v(static_cast<std::size_t>(w) * h * n);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < n; ++c) v[(static_cast<std::size_t>(y) * w + x) * n + c] = img.at(x, y, c);
  return v;
}

}  // namespace

TEST(RoundTrip, ExrFloatRgbaIsExact) {
  ScratchDir dir;
  const Image img = test_rgba(37, 23, false, true);
  io::write_image(dir / "a.exr", img);  // default: 32-bit float
  const Image back = io::read_color(dir / "a.exr");
  EXPECT_EQ(max_diff(img, back), 0.0);
  auto in = OIIO::ImageInput::open(dir / "a.exr");
  ASSERT_TRUE(in);
  EXPECT_EQ(in->spec().format, OIIO::TypeDesc::FLOAT);
}

TEST(RoundTrip, ExrHalfRgba) {
  ScratchDir dir;
  const Image img = test_rgba(37, 23, false, true);
  WriteOptions o;
  o.bits = 16;
  io::write_image(dir / "a.exr", img, o);
  auto in = OIIO::ImageInput::open(dir / "a.exr");
  ASSERT_TRUE(in);
  EXPECT_EQ(in->spec().format, OIIO::TypeDesc::HALF);
  const Image back = io::read_color(dir / "a.exr");
  for (std::size_t i = 0; i < img.data().size(); ++i)
    EXPECT_NEAR(back.data()[i], img.data()[i],
                1e-3 * std::max(1.0f, std::abs(img.data()[i])));  // half: 11-bit mantissa
}

TEST(RoundTrip, ExrRgbWithoutAlphaReadsOpaque) {
  ScratchDir dir;
  const Image img = test_rgba(20, 10, true, true);
  WriteOptions o;
  o.keep_alpha = false;
  io::write_image(dir / "rgb.exr", img, o);
  auto in = OIIO::ImageInput::open(dir / "rgb.exr");
  ASSERT_TRUE(in);
  EXPECT_EQ(in->spec().nchannels, 3);
  EXPECT_EQ(max_diff(img, io::read_color(dir / "rgb.exr")), 0.0);
}

TEST(RoundTrip, ExrWithZChannel) {
  ScratchDir dir;
  const int w = 6, h = 4;
  std::vector<float> px;
  for (int i = 0; i < w * h; ++i) {
    const float z = 1.0f + i;
    px.insert(px.end(), {0.25f, 0.5f, 0.75f, 1.0f, z});
  }
  px[4] = std::numeric_limits<float>::infinity();  // +inf = infinitely far, valid
  raw_write(dir / "rgbaz.exr", w, h, {"R", "G", "B", "A", "Z"}, px);
  EXPECT_TRUE(io::has_depth_channel(dir / "rgbaz.exr"));
  const Frame f = io::load_frame(dir / "rgbaz.exr", "", {});
  EXPECT_EQ(f.color.channels(), 4);
  EXPECT_FLOAT_EQ(f.color.at(3, 2, 0), 0.25f);
  EXPECT_FLOAT_EQ(f.color.at(3, 2, 2), 0.75f);
  EXPECT_TRUE(std::isinf(f.depth.at(0, 0)));
  EXPECT_FLOAT_EQ(f.depth.at(3, 2), 1.0f + 2 * w + 3);
}

TEST(RoundTrip, ExrWithLayerQualifiedDepthZ) {
  ScratchDir dir;
  std::vector<float> px;
  for (int i = 0; i < 4; ++i) px.insert(px.end(), {0.1f, 0.2f, 0.3f, 2.0f + i});
  raw_write(dir / "c.exr", 2, 2, {"R", "G", "B", "depth.Z"}, px);
  EXPECT_TRUE(io::has_depth_channel(dir / "c.exr"));
  const Frame f = io::load_frame(dir / "c.exr", "", {});
  EXPECT_FLOAT_EQ(f.depth.at(1, 1), 5.0f);
  EXPECT_FLOAT_EQ(f.color.at(1, 1, 3), 1.0f);
}

TEST(RoundTrip, ColourWithoutZNeedsDepthFile) {
  ScratchDir dir;
  io::write_image(dir / "c.exr", test_rgba(4, 4));
  EXPECT_FALSE(io::has_depth_channel(dir / "c.exr"));
  try {
    io::load_frame(dir / "c.exr", "", {});
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::usage);
    EXPECT_NE(std::string(e.what()).find("--depth"), std::string::npos) << e.what();
  }
}

TEST(RoundTrip, Png8Rgba) {
  ScratchDir dir;
  const Image img = test_rgba(37, 23);
  io::write_image(dir / "a.png", img);
  const Image back = io::read_color(dir / "a.png");
  // 8-bit straight colour: half a code step in the encoded domain; alpha quantisation adds
  // error after dividing it out, so only well-covered pixels get the tight bound.
  EXPECT_LE(max_encoded_diff(img, back, 0.5), 0.5 / 255 + 0.5 / 255 / 0.5 + 1e-6);
  EXPECT_LE(max_encoded_diff(img, back, 0.0), 0.5 / 255 + 0.5 / 255 / 0.1 + 1e-6);
}

TEST(RoundTrip, Png16Rgba) {
  ScratchDir dir;
  const Image img = test_rgba(37, 23);
  WriteOptions o;
  o.bits = 16;
  io::write_image(dir / "a.png", img, o);
  auto in = OIIO::ImageInput::open(dir / "a.png");
  ASSERT_TRUE(in);
  EXPECT_EQ(in->spec().format, OIIO::TypeDesc::UINT16);
  const Image back = io::read_color(dir / "a.png");
  EXPECT_LE(max_encoded_diff(img, back), 0.5 / 65535 + 0.5 / 65535 / 0.1 + 1e-6);
}

TEST(RoundTrip, Png8OpaqueRgb) {
  ScratchDir dir;
  const Image img = test_rgba(16, 8, true);
  WriteOptions o;
  o.keep_alpha = false;
  io::write_image(dir / "a.png", img, o);
  auto in = OIIO::ImageInput::open(dir / "a.png");
  ASSERT_TRUE(in);
  EXPECT_EQ(in->spec().nchannels, 3);
  EXPECT_LE(max_encoded_diff(img, io::read_color(dir / "a.png")), 0.5 / 255 + 1e-6);
}

TEST(RoundTrip, JpegWithinTolerance) {
  ScratchDir dir;
  const Image img = test_rgba(64, 48, true);
  io::write_image(dir / "a.jpg", img);
  const Image back = io::read_color(dir / "a.jpg");
  ASSERT_TRUE(back.same_size(img));
  // Lossy: bound the mean error in the encoded domain (measured 0.0086 at quality 95 with
  // OIIO's default 4:2:0 chroma subsampling).
  double sum = 0;
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x)
      for (int c = 0; c < 3; ++c)
        sum += std::abs(ref_linear_to_srgb(img.at(x, y, c)) - ref_linear_to_srgb(back.at(x, y, c)));
  EXPECT_LT(sum / (img.plane_size() * 3), 0.01);
  EXPECT_EQ(back.at(5, 5, 3), 1.0f);
}

TEST(RoundTrip, Tiff8And16AndFloat) {
  ScratchDir dir;
  const Image img = test_rgba(21, 13);
  io::write_image(dir / "a8.tif", img);
  EXPECT_LE(max_encoded_diff(img, io::read_color(dir / "a8.tif"), 0.5), 0.5 / 255 + 0.5 / 255 / 0.5 + 1e-6);
  WriteOptions o16;
  o16.bits = 16;
  io::write_image(dir / "a16.tiff", img, o16);
  EXPECT_LE(max_encoded_diff(img, io::read_color(dir / "a16.tiff")), 0.5 / 65535 + 0.5 / 65535 / 0.1 + 1e-6);
  WriteOptions o32;
  o32.bits = 32;
  const Image hdr = test_rgba(21, 13, false, true);
  io::write_image(dir / "a32.tif", hdr, o32);
  EXPECT_EQ(max_diff(hdr, io::read_color(dir / "a32.tif")), 0.0);  // float TIFF is linear, premultiplied
}

TEST(RoundTrip, SingleChannelExrKeepsName) {
  ScratchDir dir;
  Image coc(5, 3, 1);
  for (std::size_t i = 0; i < coc.plane_size(); ++i) coc.plane(0)[i] = -20.0f + 3.5f * i;
  WriteOptions o;
  o.channel_name = "coc";
  io::write_image(dir / "coc.exr", coc, o);
  auto in = OIIO::ImageInput::open(dir / "coc.exr");
  ASSERT_TRUE(in);
  EXPECT_EQ(in->spec().nchannels, 1);
  EXPECT_EQ(in->spec().channelnames[0], "coc");
  EXPECT_EQ(in->spec().format, OIIO::TypeDesc::FLOAT);
  std::vector<float> v(15);
  ASSERT_TRUE(in->read_image(0, 0, 0, 1, OIIO::TypeDesc::FLOAT, v.data()));
  for (int i = 0; i < 15; ++i) EXPECT_EQ(v[i], coc.plane(0)[i]);
}

TEST(SrgbDecode, EightBitCodesDecodeExactly) {
  ScratchDir dir;
  const std::vector<int> codes = {0, 1, 10, 11, 64, 128, 200, 255};
  std::vector<float> px;
  for (int c : codes) px.insert(px.end(), {c / 255.0f, c / 255.0f, c / 255.0f});
  raw_write(dir / "g.png", static_cast<int>(codes.size()), 1, {"R", "G", "B"}, px, OIIO::TypeDesc::UINT8);
  const Image img = io::read_color(dir / "g.png");
  for (std::size_t i = 0; i < codes.size(); ++i) {
    const double want = ref_srgb_to_linear(codes[i] / 255.0);
    EXPECT_NEAR(img.at(static_cast<int>(i), 0, 0), want, 1e-7) << "code " << codes[i];
    EXPECT_EQ(img.at(static_cast<int>(i), 0, 3), 1.0f);
  }
  EXPECT_NEAR(img.at(5, 0, 1), 0.2158605, 1e-6);  // code 128 → 0.2158605 linear
}

TEST(SrgbDecode, SixteenBitAndStraightAlphaPremultipliedInLinear) {
  ScratchDir dir;
  // One pixel, code 32768 of 65535 with straight alpha 0.5: linear colour decoded first,
  // then premultiplied (not premultiplied in the encoded domain).
  const float v = 32768 / 65535.0f;
  raw_write(dir / "p.png", 1, 1, {"R", "G", "B", "A"}, {v, v, v, 0.5f}, OIIO::TypeDesc::UINT16, true);
  const Image img = io::read_color(dir / "p.png");
  const double a = std::round(0.5 * 65535) / 65535;
  EXPECT_NEAR(img.at(0, 0, 3), a, 1e-7);
  EXPECT_NEAR(img.at(0, 0, 0), ref_srgb_to_linear(32768 / 65535.0) * a, 1e-6);
}

TEST(SrgbDecode, ExrIsLinear) {
  ScratchDir dir;
  raw_write(dir / "l.exr", 1, 1, {"R", "G", "B"}, {0.5f, 2.0f, 0.001f});
  const Image img = io::read_color(dir / "l.exr");
  EXPECT_EQ(img.at(0, 0, 0), 0.5f);
  EXPECT_EQ(img.at(0, 0, 1), 2.0f);
  EXPECT_EQ(img.at(0, 0, 2), 0.001f);
}

TEST(SrgbDecode, GreyscalePngIsReplicated) {
  ScratchDir dir;
  raw_write(dir / "g.png", 2, 1, {"Y"}, {0.0f, 128 / 255.0f}, OIIO::TypeDesc::UINT8);
  const Image img = io::read_color(dir / "g.png");
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(img.at(1, 0, c), 0.2158605, 1e-6);
}

TEST(Write, LinearEncodingOptionKeepsValues) {
  ScratchDir dir;
  Image img(1, 1, 4, 1.0f);
  img.at(0, 0, 0) = 0.2f;
  WriteOptions o;
  o.encoding = Encoding::linear;
  o.bits = 16;
  io::write_image(dir / "lin.png", img, o);
  auto in = OIIO::ImageInput::open(dir / "lin.png");
  std::vector<float> v(4);
  ASSERT_TRUE(in->read_image(0, 0, 0, 4, OIIO::TypeDesc::FLOAT, v.data()));
  EXPECT_NEAR(v[0], 0.2, 1.0 / 65535);
}

TEST(Write, UnsupportedExtensionOrBitsIsUsageError) {
  ScratchDir dir;
  const Image img = test_rgba(4, 4);
  try {
    io::write_image(dir / "a.bmp", img);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::usage);
    EXPECT_NE(std::string(e.what()).find("a.bmp"), std::string::npos);
  }
  WriteOptions o;
  o.bits = 16;
  EXPECT_THROW(io::write_image(dir / "a.jpg", img, o), Error);
  EXPECT_TRUE(dir.entries().empty());
}

TEST(Write, FailedWriteLeavesExistingFileUntouchedAndNoTemporary) {
  ScratchDir dir;
  write_bytes(dir / "keep.png", "previous content");
  Image five(4, 4, 5, 0.5f);  // a 5-channel image cannot be a PNG: fails inside the encoder
  EXPECT_THROW(io::write_image(dir / "keep.png", five), Error);
  EXPECT_EQ(read_bytes(dir / "keep.png"), "previous content");
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"keep.png"});
}

TEST(Write, MissingFolderIsBadInputAndCreatesNothing) {
  ScratchDir dir;
  try {
    io::write_image(dir / "no/such/out.exr", test_rgba(4, 4));
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::bad_input);
    EXPECT_NE(std::string(e.what()).find("does not exist"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(dir.entries().empty());
}

TEST(Write, ReplacesExistingFileAtomically) {
  ScratchDir dir;
  write_bytes(dir / "o.exr", "old");
  io::write_image(dir / "o.exr", test_rgba(4, 4));
  EXPECT_EQ(io::read_color(dir / "o.exr").width(), 4);
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"o.exr"});
}

// The EXR header walk that runs before OpenEXR (src/io/header_check.cpp) must accept every
// legitimate layout: scanline files with each compression's chunk height, tiled files with
// mip levels, multi-part files, and data windows that do not start at the origin.
TEST(RoundTrip, ExrLayoutsPassTheHeaderCheck) {
  ScratchDir dir;
  const Image img = test_rgba(53, 29, false, true);
  const std::vector<float> interleaved = interleave(img);
  struct Layout {
    const char* name;
    const char* compression;
    int tile;  // 0 = scanline
    bool mip;
    int x0, y0;  // data window origin
    int parts;
  };
  const Layout layouts[] = {
      {"none", "none", 0, false, 0, 0, 1}, {"zip", "zip", 0, false, 0, 0, 1},     {"piz", "piz", 0, false, 0, 0, 1},
      {"dwab", "dwab", 0, false, 0, 0, 1}, {"b44", "b44", 0, false, 0, 0, 1},     {"tiled", "zip", 16, false, 0, 0, 1},
      {"mip", "zip", 16, true, 0, 0, 1},   {"offset", "zip", 0, false, -7, 5, 1}, {"parts", "zip", 0, false, 0, 0, 2},
  };
  for (const Layout& l : layouts) {
    SCOPED_TRACE(l.name);
    const std::string path = dir / (std::string(l.name) + ".exr");
    const std::string written = l.mip ? path + ".src.exr" : path;  // the mip case converts it below
    OIIO::ImageSpec spec(53, 29, 4, OIIO::TypeDesc::HALF);
    spec.x = l.x0;
    spec.y = l.y0;
    spec.full_x = l.x0;
    spec.full_y = l.y0;
    spec.attribute("compression", l.compression);
    if (l.tile) spec.tile_width = spec.tile_height = l.tile;
    auto out = OIIO::ImageOutput::create(written);
    ASSERT_TRUE(out);
    if (l.parts > 1) {
      std::vector<OIIO::ImageSpec> specs(l.parts, spec);
      ASSERT_TRUE(out->open(written, l.parts, specs.data())) << out->geterror();
      ASSERT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, interleaved.data())) << out->geterror();
      ASSERT_TRUE(out->open(written, specs[1], OIIO::ImageOutput::AppendSubimage)) << out->geterror();
      ASSERT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, interleaved.data())) << out->geterror();
    } else {
      ASSERT_TRUE(out->open(written, spec, OIIO::ImageOutput::Create)) << out->geterror();
      ASSERT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, interleaved.data())) << out->geterror();
    }
    ASSERT_TRUE(out->close());
    if (l.mip) {
      // Rewrite it as a tiled, mip-mapped texture (what renderers' texture tools produce).
      OIIO::ImageBuf src(written);
      OIIO::ImageSpec config;
      config.tile_width = config.tile_height = l.tile;
      config.attribute("compression", l.compression);
      ASSERT_TRUE(OIIO::ImageBufAlgo::make_texture(OIIO::ImageBufAlgo::MakeTxTexture, src, path, config))
          << OIIO::geterror();
      auto in = OIIO::ImageInput::open(path);
      ASSERT_TRUE(in);
      EXPECT_TRUE(in->seek_subimage(0, 1)) << "no second mip level";
    }
    {  // the file really has the layout under test
      auto in = OIIO::ImageInput::open(path);
      ASSERT_TRUE(in);
      EXPECT_EQ(in->spec().tile_width, l.tile);
      EXPECT_EQ(in->spec().x, l.x0);
      EXPECT_EQ(in->seek_subimage(1, 0), l.parts > 1);
    }
    Image back;
    ASSERT_NO_THROW(back = io::read_color(path));
    ASSERT_EQ(back.width(), 53);
    ASSERT_EQ(back.height(), 29);
    double m = 0;
    for (std::size_t i = 0; i < img.data().size(); ++i)
      m = std::max(m, std::abs(double(img.data()[i]) - back.data()[i]));
    EXPECT_LT(m, l.name == std::string("dwab") || l.name == std::string("b44") ? 0.05 : 2e-3);
  }
}

// The header walk refuses a file whose pixel data is too short for its declared pixels even
// at the compression's largest ratio (deflate 1032:1, EXR RLE 64:1, PXR24 1376:1). The most
// compressible files there are — one constant value, at the highest level — must still read:
// a too-small bound would refuse real files. Each file's ratio is asserted to come close to
// its bound, so the case is a real test of it.
TEST(RoundTrip, MostCompressibleFilesPassThePayloadBound) {
  ScratchDir dir;
  const int W = 2048, H = 1024;
  Image zero(W, H, 4);  // all 0: the longest runs
  struct Case {
    const char* name;
    io::WriteOptions opt;
    double min_ratio;  // raw pixel bytes / file bytes, at least
  };
  const auto png = [](int bits) {
    io::WriteOptions o;
    o.bits = bits;
    o.png_level = 9;
    return o;
  };
  const auto exr = [](const char* compression, int bits) {
    io::WriteOptions o;
    o.bits = bits;
    o.compression = compression;
    return o;
  };
  const Case cases[] = {
      // measured: 899, 903, 1.0, 60, 62, 296 (one row per chunk: the chunk heads dominate), 927, 1231
      {"p8.png", png(8), 850},
      {"p16.png", png(16), 850},
      {"none.exr", exr("none", 32), 0.9},
      {"rle.exr", exr("rle", 16), 55},
      {"rle32.exr", exr("rle", 32), 55},
      {"zips.exr", exr("zips", 16), 250},
      {"zip.exr", exr("zip", 32), 850},
      {"pxr24.exr", exr("pxr24", 32), 1100},
  };
  const auto check = [&](const std::string& path, double raw, double min_ratio) {
    const double ratio = raw / static_cast<double>(std::filesystem::file_size(path));
    EXPECT_GT(ratio, min_ratio) << "not close enough to the bound to test it";
    Image back;
    ASSERT_NO_THROW(back = io::read_color(path));
    EXPECT_EQ(back.width(), W);
    EXPECT_EQ(back.height(), H);
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const std::string path = dir / c.name;
    io::write_image(path, zero, c.opt);
    check(path, double(W) * H * 4 * (c.opt.bits / 8), c.min_ratio);
  }
  // TIFF (bounds 1032 deflate, 3641 LZW, 64 PackBits): dofkit's writer (deflate), and
  // OpenImageIO's with the other compressions and the largest strips it writes.
  {
    SCOPED_TRACE("t8.tif");
    io::WriteOptions o;
    o.bits = 8;
    io::write_image(dir / "t8.tif", zero, o);
    check(dir / "t8.tif", double(W) * H * 4, 850);  // measured 897 (32-row strips, each its own stream)
  }
  const std::vector<float> zeros(static_cast<std::size_t>(W) * H * 4, 0.0f);
  struct TiffCase {
    const char* compression;
    int rows_per_strip;
    double min_ratio;
  };
  // measured: 999 (one-strip zip), 1121 (LZW), 63.8 (PackBits)
  for (const TiffCase& t : {TiffCase{"zip", H, 950}, TiffCase{"lzw", H, 1000}, TiffCase{"packbits", 64, 60}}) {
    SCOPED_TRACE(t.compression);
    const std::string path = dir / (std::string(t.compression) + ".tif");
    OIIO::ImageSpec spec(W, H, 4, OIIO::TypeDesc::UINT8);
    spec.attribute("compression", t.compression);
    spec.attribute("tiff:RowsPerStrip", t.rows_per_strip);
    auto out = OIIO::ImageOutput::create(path);
    ASSERT_TRUE(out && out->open(path, spec)) << OIIO::geterror();
    ASSERT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, zeros.data()));
    ASSERT_TRUE(out->close());
    check(path, double(W) * H * 4, t.min_ratio);
  }
}

// The TIFF directory walk (src/io/header_check.cpp) must accept strip and tile layouts,
// compressed strips and multi-page files as OIIO/libtiff write them.
TEST(RoundTrip, TiffLayoutsPassTheHeaderCheck) {
  ScratchDir dir;
  const Image img = test_rgba(45, 31, false, false);
  const std::vector<float> interleaved = interleave(img);
  struct Layout {
    const char* name;
    const char* compression;
    int tile;
    int pages;
  };
  for (const Layout& l : {Layout{"strips", "none", 0, 1}, Layout{"zip", "zip", 0, 1}, Layout{"lzw_tiles", "lzw", 16, 1},
                          Layout{"pages", "zip", 0, 3}}) {
    SCOPED_TRACE(l.name);
    const std::string path = dir / (std::string(l.name) + ".tif");
    OIIO::ImageSpec spec(45, 31, 4, OIIO::TypeDesc::FLOAT);
    spec.attribute("compression", l.compression);
    spec.attribute("tiff:RowsPerStrip", 4);  // several strips
    if (l.tile) spec.tile_width = spec.tile_height = l.tile;
    auto out = OIIO::ImageOutput::create(path);
    ASSERT_TRUE(out);
    std::vector<OIIO::ImageSpec> specs(l.pages, spec);
    ASSERT_TRUE(l.pages > 1 ? out->open(path, l.pages, specs.data()) : out->open(path, spec)) << out->geterror();
    for (int p = 0; p < l.pages; ++p) {
      if (p > 0) ASSERT_TRUE(out->open(path, spec, OIIO::ImageOutput::AppendSubimage)) << out->geterror();
      ASSERT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, interleaved.data())) << out->geterror();
    }
    ASSERT_TRUE(out->close());
    {
      auto in = OIIO::ImageInput::open(path);
      ASSERT_TRUE(in);
      EXPECT_EQ(in->spec().tile_width, l.tile);
      EXPECT_EQ(in->seek_subimage(l.pages - 1, 0), true);
    }
    Image back;
    ASSERT_NO_THROW(back = io::read_color(path));
    double m = 0;
    for (std::size_t i = 0; i < img.data().size(); ++i)
      m = std::max(m, std::abs(double(img.data()[i]) - back.data()[i]));
    EXPECT_LT(m, 1e-6);
  }
}

// The EXR header walk reads the header in growing blocks (64 KiB first): a header far larger
// than that (a 300 KB comment attribute) must still be walked to its end and load.
TEST(RoundTrip, ExrWithAHeaderLargerThanTheFirstReadBlock) {
  ScratchDir dir;
  const Image img = test_rgba(21, 13, false, true);
  const std::string path = dir / "big_header.exr";
  OIIO::ImageSpec spec(21, 13, 4, OIIO::TypeDesc::FLOAT);
  spec.attribute("ImageDescription", std::string(300000, 'x'));
  auto out = OIIO::ImageOutput::create(path);
  ASSERT_TRUE(out && out->open(path, spec)) << OIIO::geterror();
  const std::vector<float> interleaved = interleave(img);
  ASSERT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, interleaved.data())) << out->geterror();
  ASSERT_TRUE(out->close());
  ASSERT_GT(fs::file_size(path), 300000u);
  Image back;
  ASSERT_NO_THROW(back = io::read_color(path));
  double m = 0;
  for (std::size_t i = 0; i < img.data().size(); ++i) m = std::max(m, std::abs(double(img.data()[i]) - back.data()[i]));
  EXPECT_EQ(m, 0.0);
}
