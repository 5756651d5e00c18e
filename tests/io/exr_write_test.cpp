// The direct scanline EXR writer (io/exr_direct.hpp), checked with OpenImageIO's reader
// (OpenEXR's C++ library): every compression it writes, half and float, the channel sets
// write_image gives it, chunk-size edge cases, incompressible data (chunks stored raw) and
// special values, all read back bit for bit.
#include <Imath/half.h>
#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>

#include "dofkit/error.hpp"
#include "io/exr_direct.hpp"
#include "io/image_io.hpp"
#include "io/io_test_util.hpp"

using namespace dofkit;
using namespace dofkit::test;

namespace {

// A plane with smooth parts (compressible), random bit patterns (incompressible: their chunks
// are stored raw) and the special values.
std::vector<float> test_plane(int w, int h, int seed, bool random_bits) {
  std::mt19937 rng(seed);
  std::vector<float> p(static_cast<std::size_t>(w) * h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      float v;
      if (random_bits) {
        const std::uint32_t b = rng();
        std::memcpy(&v, &b, 4);
      } else {
        v = (y < h / 2) ? 0.25f * seed : std::sin(0.37f * x + 0.11f * y * seed) * 40.0f;
      }
      p[static_cast<std::size_t>(y) * w + x] = v;
    }
  const float specials[] = {std::numeric_limits<float>::infinity(),
                            -std::numeric_limits<float>::infinity(),
                            std::numeric_limits<float>::quiet_NaN(),
                            -0.0f,
                            1e-42f,
                            70000.0f,
                            6e-8f,
                            -3.5f};
  for (std::size_t i = 0; i < std::size(specials) && i < p.size(); ++i) p[i * 7 % p.size()] = specials[i];
  return p;
}

struct Case {
  const char* compression;
  bool half;
  std::vector<std::string> names;
  int w, h;
  bool random_bits;
};

void check_case(const Case& c) {
  SCOPED_TRACE(std::string("compression '") + c.compression + "' " + (c.half ? "half" : "float") + " " +
               std::to_string(c.names.size()) + " channels " + std::to_string(c.w) + "x" + std::to_string(c.h) +
               (c.random_bits ? " random bits" : ""));
  ScratchDir dir;
  std::vector<std::vector<float>> planes;
  std::vector<io::exr::OutChannel> ch;
  for (std::size_t i = 0; i < c.names.size(); ++i)
    planes.push_back(test_plane(c.w, c.h, static_cast<int>(i) + 1, c.random_bits));
  for (std::size_t i = 0; i < c.names.size(); ++i) ch.push_back({c.names[i], planes[i].data()});
  const std::string path = dir / "o.exr";
  io::exr::write_scanline(path, path, c.w, c.h, ch, c.half, c.compression);

  auto in = OIIO::ImageInput::open(path);
  ASSERT_TRUE(in) << OIIO::geterror();
  const OIIO::ImageSpec& spec = in->spec();
  ASSERT_EQ(spec.width, c.w);
  ASSERT_EQ(spec.height, c.h);
  ASSERT_EQ(spec.nchannels, static_cast<int>(c.names.size()));
  EXPECT_EQ(spec.format, c.half ? OIIO::TypeDesc::HALF : OIIO::TypeDesc::FLOAT);
  const std::string want_comp = *c.compression ? c.compression : "zip";
  EXPECT_EQ(spec.get_string_attribute("compression"), want_comp);
  std::vector<float> buf(static_cast<std::size_t>(c.w) * c.h * spec.nchannels);
  ASSERT_TRUE(in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, buf.data())) << in->geterror();
  for (std::size_t i = 0; i < c.names.size(); ++i) {
    int k = -1;
    for (int j = 0; j < spec.nchannels; ++j)
      if (spec.channelnames[j] == c.names[i]) k = j;
    ASSERT_GE(k, 0) << c.names[i];
    std::size_t wrong = 0;
    for (std::size_t p = 0; p < planes[i].size(); ++p) {
      const float want = c.half ? static_cast<float>(Imath::half(planes[i][p])) : planes[i][p];
      const float got = buf[p * spec.nchannels + k];
      const bool same = std::isnan(want) ? std::isnan(got) : bits_of(want) == bits_of(got);
      if (!same && wrong++ < 3) ADD_FAILURE() << c.names[i] << " sample " << p << ": " << got << " != " << want;
    }
    EXPECT_EQ(wrong, 0u) << c.names[i];
  }
}

}  // namespace

TEST(ExrDirectWrite, EveryCompressionTypeAndChannelSetReadsBackExactly) {
  const std::vector<std::string> rgba = {"R", "G", "B", "A"}, rgb = {"R", "G", "B"}, z = {"Z"}, coc = {"coc"};
  for (const char* comp : {"", "none", "zips", "zip"})
    for (bool half : {false, true}) {
      check_case({comp, half, rgba, 37, 23, false});  // 16-line chunks: one full, one partial
      check_case({comp, half, rgb, 5, 16, false});    // exactly one zip chunk
      check_case({comp, half, z, 1, 1, false});
      check_case({comp, half, coc, 64, 33, false});  // 16 + 16 + 1 rows
    }
}

TEST(ExrDirectWrite, IncompressibleChunksAreStoredRawAndReadBack) {
  for (const char* comp : {"zips", "zip"})
    for (bool half : {false, true}) check_case({comp, half, {"A", "B", "G", "R"}, 129, 35, true});
  // Random float bits do not shrink: the file is no smaller than the raw samples.
  ScratchDir dir;
  const int w = 200, h = 40;
  const std::vector<float> p = test_plane(w, h, 9, true);
  io::exr::write_scanline(dir / "r.exr", "r.exr", w, h, {{"Y", p.data()}}, false, "zip");
  EXPECT_GE(fs::file_size(dir / "r.exr"), static_cast<std::uintmax_t>(w) * h * 4);
}

TEST(ExrDirectWrite, ChannelsAreStoredInExrOrderWhateverTheOrderGiven) {
  ScratchDir dir;
  const int w = 9, h = 4;
  std::vector<float> r(w * h, 1.0f), g(w * h, 2.0f), b(w * h, 3.0f), a(w * h, 0.5f);
  io::exr::write_scanline(dir / "o.exr", "o.exr", w, h,
                          {{"R", r.data()}, {"G", g.data()}, {"B", b.data()}, {"A", a.data()}}, false, "zip");
  // write_image's colour path: R, G, B, A come back as premultiplied RGBA.
  const Image back = io::read_color(dir / "o.exr");
  EXPECT_EQ(back.at(3, 2, 0), 1.0f);
  EXPECT_EQ(back.at(3, 2, 1), 2.0f);
  EXPECT_EQ(back.at(3, 2, 2), 3.0f);
  EXPECT_EQ(back.at(3, 2, 3), 0.5f);
}

TEST(ExrDirectWrite, WriteImageTakesTheDirectPathForItsDefaultsAndOpenImageIOForTheRest) {
  ScratchDir dir;
  Image img(21, 19, 4);
  for (std::size_t i = 0; i < img.data().size(); ++i) img.data()[i] = 0.001f * static_cast<float>(i % 997);
  for (const char* comp : {"", "zips", "none", "piz", "rle"}) {
    io::WriteOptions o;
    o.compression = comp;
    const std::string f = dir / (std::string("c_") + comp + ".exr");
    io::write_image(f, img, o);
    const Image back = io::read_color(f);
    for (std::size_t i = 0; i < img.data().size(); ++i) ASSERT_EQ(back.data()[i], img.data()[i]) << comp << " " << i;
  }
  // Which writer ran: OpenImageIO stamps a DateTime attribute, the direct writer does not.
  for (const char* comp : {"", "zips", "none", "piz", "rle"}) {
    auto in = OIIO::ImageInput::open(dir / (std::string("c_") + comp + ".exr"));
    ASSERT_TRUE(in);
    const bool direct = io::exr::writes_compression(comp);
    EXPECT_EQ(in->spec().get_string_attribute("DateTime").empty(), direct) << comp;
  }
}

TEST(ExrDirectWrite, AnUnwritableFileIsAOneLineErrorNamingIt) {
  ScratchDir dir;
  std::vector<float> p(16, 1.0f);
  const std::string m = bad_input_message([&] {
    io::exr::write_scanline(dir / "missing/o.exr", "shown/o.exr", 4, 4, {{"Y", p.data()}}, false, "zip");
  });
  EXPECT_NE(m.find("shown/o.exr: cannot write"), std::string::npos) << m;
  EXPECT_FALSE(fs::exists(dir / "missing"));
}
