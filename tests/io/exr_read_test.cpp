// The direct scanline EXR reader (io/exr_direct.hpp) against OpenImageIO's reader on files
// OpenImageIO wrote: the same channel order, alpha / Z indices and values bit for bit;
// the files it leaves to OpenImageIO; and the fall-back when a chunk does not decode.
#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

#include "dofkit/error.hpp"
#include "io/exr_direct.hpp"
#include "io/image_io.hpp"
#include "io/io_test_util.hpp"

using namespace dofkit;
using namespace dofkit::test;

namespace {

// Writes an EXR through OpenImageIO with per-channel formats, a compression, and optionally
// a data window offset from the origin or tiles.
void write_exr(const std::string& path, int w, int h, const std::vector<std::string>& names,
               const std::vector<OIIO::TypeDesc>& formats, const std::string& compression, int x0 = 0, int y0 = 0,
               int tile = 0) {
  const int nc = static_cast<int>(names.size());
  OIIO::ImageSpec spec(w, h, nc, OIIO::TypeDesc::FLOAT);
  spec.channelnames = names;
  spec.channelformats = formats;
  spec.x = x0;
  spec.y = y0;
  spec.full_x = 0;
  spec.full_y = 0;
  spec.full_width = w + x0;
  spec.full_height = h + y0;
  if (tile) spec.tile_width = spec.tile_height = tile;
  spec.attribute("compression", compression);
  std::vector<float> px(static_cast<std::size_t>(w) * h * nc);
  for (std::size_t i = 0; i < px.size(); ++i)
    px[i] = std::sin(0.013f * static_cast<float>(i)) * 3.0f + 0.001f * (i % 17);
  px[0] = std::numeric_limits<float>::infinity();
  if (px.size() > 5) px[5] = -0.0f;
  auto out = OIIO::ImageOutput::create(path);
  ASSERT_TRUE(out) << OIIO::geterror();
  ASSERT_TRUE(out->open(path, spec)) << out->geterror();
  ASSERT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, px.data())) << out->geterror();
  ASSERT_TRUE(out->close());
}

std::vector<OIIO::TypeDesc> all(int n, OIIO::TypeDesc t) { return std::vector<OIIO::TypeDesc>(n, t); }

// The direct reader and OpenImageIO agree on everything read_color / read_depth use.
void expect_same_as_oiio(const std::string& path) {
  SCOPED_TRACE(path);
  auto r = io::exr::ScanlineReader::open(path);
  ASSERT_TRUE(r) << "the direct reader should take this file";
  auto in = OIIO::ImageInput::open(path);
  ASSERT_TRUE(in) << OIIO::geterror();
  const OIIO::ImageSpec& spec = in->spec();
  ASSERT_EQ(r->width(), spec.width);
  ASSERT_EQ(r->height(), spec.height);
  ASSERT_EQ(r->names(), spec.channelnames);
  EXPECT_EQ(r->alpha_channel(), spec.alpha_channel);
  EXPECT_EQ(r->z_channel(), spec.z_channel);
  const int nc = spec.nchannels;
  // Every contiguous channel range read_channels can ask for.
  for (int cb = 0; cb < nc; ++cb)
    for (int ce = cb + 1; ce <= nc; ++ce) {
      const std::size_t n = static_cast<std::size_t>(spec.width) * spec.height * (ce - cb);
      std::vector<float> a(n, -7.0f), b(n, -9.0f);
      ASSERT_TRUE(r->read(cb, ce, a.data()));
      ASSERT_TRUE(in->read_image(0, 0, cb, ce, OIIO::TypeDesc::FLOAT, b.data())) << in->geterror();
      ASSERT_EQ(std::memcmp(a.data(), b.data(), n * sizeof(float)), 0) << "channels " << cb << ".." << ce;
    }
}

}  // namespace

TEST(ExrDirectRead, MatchesOpenImageIOForEveryCompressionItTakes) {
  ScratchDir dir;
  const auto H = OIIO::TypeDesc::HALF, F = OIIO::TypeDesc::FLOAT;
  int k = 0;
  for (const char* comp : {"none", "zips", "zip"})
    for (OIIO::TypeDesc t : {H, F}) {
      const std::string f = dir / ("c" + std::to_string(k++) + ".exr");
      write_exr(f, 37, 35, {"R", "G", "B", "A", "Z"}, all(5, t), comp);  // zip: 16 + 16 + 3 rows
      expect_same_as_oiio(f);
    }
}

TEST(ExrDirectRead, PresentsChannelsInOpenImageIOsOrder) {
  ScratchDir dir;
  const auto H = OIIO::TypeDesc::HALF, F = OIIO::TypeDesc::FLOAT;
  const std::vector<std::vector<std::string>> sets = {
      {"R", "G", "B"},
      {"Y", "A"},
      {"Z"},
      {"depth"},
      {"foo", "bar", "Z", "A"},
      {"r", "g", "b", "alpha", "Depth"},
      {"diffuse.R", "diffuse.G", "diffuse.B", "A", "depth.Z", "Y", "spec.A"},
      {"AR", "RA", "Green", "Red", "Blue", "zz", "Zback", "real", "imag"},
  };
  int k = 0;
  for (const auto& names : sets) {
    std::vector<OIIO::TypeDesc> formats;
    for (std::size_t i = 0; i < names.size(); ++i) formats.push_back(i % 2 ? H : F);  // mixed half / float
    const std::string f = dir / ("s" + std::to_string(k++) + ".exr");
    write_exr(f, 19, 18, names, formats, "zip");
    expect_same_as_oiio(f);
  }
}

TEST(ExrDirectRead, DataWindowOffsetReadsTheDataWindow) {
  ScratchDir dir;
  write_exr(dir / "o.exr", 23, 20, {"R", "G", "B", "A"}, all(4, OIIO::TypeDesc::HALF), "zip", 7, 11);
  expect_same_as_oiio(dir / "o.exr");
}

TEST(ExrDirectRead, LeavesOtherFilesToOpenImageIO) {
  ScratchDir dir;
  write_exr(dir / "piz.exr", 16, 16, {"R", "G", "B"}, all(3, OIIO::TypeDesc::HALF), "piz");
  write_exr(dir / "rle.exr", 16, 16, {"R", "G", "B"}, all(3, OIIO::TypeDesc::FLOAT), "rle");
  write_exr(dir / "tiled.exr", 40, 40, {"R", "G", "B"}, all(3, OIIO::TypeDesc::FLOAT), "zip", 0, 0, 16);
  write_exr(dir / "uint.exr", 16, 16, {"R", "G", "B"}, all(3, OIIO::TypeDesc::UINT), "zip");
  io::write_image(dir / "a.png", test_rgba(8, 8));
  for (const char* f : {"piz.exr", "rle.exr", "tiled.exr", "uint.exr", "a.png", "missing.exr"})
    EXPECT_FALSE(io::exr::ScanlineReader::open(dir / f)) << f;
  // ... and read_color still reads them (through OpenImageIO).
  for (const char* f : {"piz.exr", "rle.exr", "tiled.exr"}) {
    const Image img = io::read_color(dir / f);
    EXPECT_EQ(img.width(), f == std::string("tiled.exr") ? 40 : 16) << f;
  }
}

TEST(ExrDirectRead, ACorruptChunkFallsBackToOpenImageIOsError) {
  ScratchDir dir;
  io::write_image(dir / "ok.exr", test_rgba(64, 64, false, true));
  std::string bytes = read_bytes(dir / "ok.exr");
  // Overwrite the middle of the pixel data: the zlib streams there no longer decode.
  for (std::size_t i = bytes.size() / 2; i < bytes.size() / 2 + 64; ++i) bytes[i] = '\x5a';
  write_bytes(dir / "bad.exr", bytes);
  auto r = io::exr::ScanlineReader::open(dir / "bad.exr");
  ASSERT_TRUE(r) << "the header is intact";
  std::vector<float> buf(64 * 64 * 4);
  EXPECT_FALSE(r->read(0, 4, buf.data()));
  const std::string m = bad_input_message([&] { io::read_color(dir / "bad.exr"); });
  EXPECT_NE(m.find("bad.exr: cannot read colour pixels"), std::string::npos) << m;
}

TEST(ExrDirectRead, ReadColorAndDepthGiveTheSameFrameThroughEitherReader) {
  // read_color / read_depth on a zip file (direct) and on the same pixels as piz (OpenImageIO).
  ScratchDir dir;
  const std::vector<std::vector<std::string>> sets = {
      {"R", "G", "B", "A", "Z"}, {"R", "G", "B"}, {"Y"}, {"Y", "A"}, {"diffuse.R", "diffuse.G", "diffuse.B", "A"},
      {"u", "v", "w", "A"}};
  int k = 0;
  for (const auto& names : sets)
    for (OIIO::TypeDesc t : {OIIO::TypeDesc::FLOAT, OIIO::TypeDesc::HALF}) {
      const std::string z = dir / ("z" + std::to_string(k) + ".exr"), p = dir / ("p" + std::to_string(k++) + ".exr");
      write_exr(z, 33, 17, names, all(static_cast<int>(names.size()), t), "zip");
      write_exr(p, 33, 17, names, all(static_cast<int>(names.size()), t), "piz");
      ASSERT_TRUE(io::exr::ScanlineReader::open(z));
      const Image ca = io::read_color(z), cb = io::read_color(p);
      ASSERT_EQ(ca.data().size(), cb.data().size());
      EXPECT_EQ(std::memcmp(ca.data().data(), cb.data().data(), ca.data().size() * sizeof(float)), 0) << z;
    }
  for (const char* comp : {"zip", "piz"})
    write_exr(dir / (std::string(comp) + ".exr"), 33, 17, {"R", "G", "B", "A", "Z"}, all(5, OIIO::TypeDesc::FLOAT),
              comp);
  io::DepthOptions o;
  o.invalid_as_far = true;
  const Image da = io::read_depth(dir / "zip.exr", o), db = io::read_depth(dir / "piz.exr", o);
  EXPECT_EQ(std::memcmp(da.data().data(), db.data().data(), da.data().size() * sizeof(float)), 0);
  EXPECT_TRUE(io::has_depth_channel(dir / "zip.exr"));
}
