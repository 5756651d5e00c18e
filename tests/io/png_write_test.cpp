// The direct PNG writer (io/png_direct.hpp), checked against OpenImageIO (libpng): the same
// float samples written by both read back as the same integers, for 8 and 16 bits, every
// channel count, every zlib level, sizes that cut the rows into one or many deflate blocks
// and the rounding boundaries; the file itself is checked chunk by chunk (CRCs, the zlib
// stream inflated by zlib with its Adler-32, the colour-space chunks).
#include <OpenImageIO/imageio.h>
#include <OpenImageIO/strutil.h>
#include <gtest/gtest.h>
#include <zlib.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <random>

#include "dofkit/error.hpp"
#include "io/image_io.hpp"
#include "io/io_test_util.hpp"
#include "io/png_direct.hpp"

using namespace dofkit;
using namespace dofkit::test;

namespace {

// The same floats through OpenImageIO's PNG writer (the reference).
void write_oiio(const std::string& path, int w, int h, int c, int bits, const std::vector<float>& v) {
  OIIO::ImageSpec spec(w, h, c, bits == 8 ? OIIO::TypeDesc::UINT8 : OIIO::TypeDesc::UINT16);
  if (c == 2 || c == 4) spec.attribute("oiio:UnassociatedAlpha", 1);  // store the values as given
  auto out = OIIO::ImageOutput::create(path);
  ASSERT_TRUE(out && out->open(path, spec));
  ASSERT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, v.data()));
  ASSERT_TRUE(out->close());
}

std::uint32_t be32(const std::string& s, std::size_t at) {
  return (static_cast<std::uint32_t>(static_cast<unsigned char>(s[at])) << 24) |
         (static_cast<std::uint32_t>(static_cast<unsigned char>(s[at + 1])) << 16) |
         (static_cast<std::uint32_t>(static_cast<unsigned char>(s[at + 2])) << 8) |
         static_cast<std::uint32_t>(static_cast<unsigned char>(s[at + 3]));
}

struct Chunks {
  std::vector<std::string> types;
  std::map<std::string, std::string> data;  // the last chunk of each type
  std::string idat;                         // all IDAT data, concatenated
  int idat_chunks = 0;
};

// Parses a PNG file, checking the signature, every chunk's CRC-32 and that IEND ends it.
Chunks parse(const std::string& bytes) {
  Chunks out;
  EXPECT_EQ(bytes.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
  std::size_t p = 8;
  while (p + 12 <= bytes.size()) {
    const std::uint32_t n = be32(bytes, p);
    const std::string type = bytes.substr(p + 4, 4);
    EXPECT_LE(p + 12 + n, bytes.size());
    if (p + 12 + n > bytes.size()) break;
    const std::uint32_t crc = static_cast<std::uint32_t>(
        crc32(0, reinterpret_cast<const Bytef*>(bytes.data() + p + 4), static_cast<uInt>(n + 4)));
    EXPECT_EQ(crc, be32(bytes, p + 8 + n)) << type << " chunk at " << p;
    const std::string data = bytes.substr(p + 8, n);
    out.types.push_back(type);
    out.data[type] = data;
    if (type == "IDAT") out.idat += data, ++out.idat_chunks;
    p += 12 + n;
  }
  EXPECT_EQ(p, bytes.size());
  EXPECT_FALSE(out.types.empty());
  if (!out.types.empty()) EXPECT_EQ(out.types.back(), "IEND");
  return out;
}

}  // namespace

// Every channel count × bit depth × a size with one deflate block and one with many, at the
// default level: OpenImageIO reads back exactly the integers it stores itself for the same
// floats, and the stream inflates (zlib checks the Adler-32) to H rows of 1 + W·C·bytes.
TEST(PngDirect, SamplesEqualOpenImageIOsAndTheStreamIsValid) {
  ScratchDir dir;
  struct Size {
    int w, h;
  };
  for (const Size sz : {Size{1, 1}, Size{7, 3}, Size{333, 517}, Size{2, 3000}})
    for (int c = 1; c <= 4; ++c)
      for (int bits : {8, 16}) {
        SCOPED_TRACE(std::to_string(sz.w) + "x" + std::to_string(sz.h) + " c" + std::to_string(c) + " " +
                     std::to_string(bits) + " bits");
        const std::vector<float> v = boundary_samples(sz.w, sz.h, c, sz.w + c + bits);
        io::png::write(dir / "d.png", "d.png", io::png::Layout{sz.w, sz.h, c, bits}, v.data(), 6, c >= 3);
        int w = 0, h = 0, n = 0;
        const std::vector<long> want = quantise_rule(v, bits);
        EXPECT_EQ(read_as_long(dir / "d.png", bits, &w, &h, &n), want);
        // OpenImageIO's writer follows this rule on large images (its vector conversion; the
        // 333×517 case here, and 1080p frames) but not on small ones (1×1, 7×3, 2×3000 here),
        // where it computes trunc(v·max + ½) in float and so rounds v·max = k + ½ − 1 ulp
        // up: compare with it on the large case.
        if (sz.w * sz.h >= 333 * 517) {
          write_oiio(dir / "o.png", sz.w, sz.h, c, bits, v);
          EXPECT_EQ(read_as_long(dir / "o.png", bits), want);
        }
        EXPECT_EQ(w, sz.w);
        EXPECT_EQ(h, sz.h);
        EXPECT_EQ(n, c);

        const Chunks ch = parse(slurp(dir / "d.png"));
        const std::string& ihdr = ch.data.at("IHDR");
        ASSERT_EQ(ihdr.size(), 13u);
        EXPECT_EQ(be32(ihdr, 0), static_cast<std::uint32_t>(sz.w));
        EXPECT_EQ(be32(ihdr, 4), static_cast<std::uint32_t>(sz.h));
        EXPECT_EQ(ihdr[8], bits);
        EXPECT_EQ(ihdr[9], c == 1 ? 0 : c == 2 ? 4 : c == 3 ? 2 : 6);
        const std::size_t stride = 1 + static_cast<std::size_t>(sz.w) * c * bits / 8;
        std::vector<Bytef> rows(stride * sz.h + 1);
        uLongf got = rows.size();
        ASSERT_EQ(uncompress(rows.data(), &got, reinterpret_cast<const Bytef*>(ch.idat.data()), ch.idat.size()), Z_OK);
        EXPECT_EQ(got, stride * sz.h);
        for (int y = 0; y < sz.h; ++y) EXPECT_LE(rows[y * stride], 4) << "filter type of row " << y;
        // The 2×3000 and 333×517 images are cut into several blocks: one IDAT chunk each.
        if (stride * sz.h > 300 * 1024) EXPECT_GT(ch.idat_chunks, 1);
      }
}

// Every zlib level gives the same samples; level 0 stores (the file is larger than the
// data), and higher levels do not give larger files on smooth data.
TEST(PngDirect, EveryLevelGivesTheSameSamples) {
  ScratchDir dir;
  const int w = 640, h = 480, c = 4;
  const std::vector<float> v = boundary_samples(w, h, c, 5);
  write_oiio(dir / "o.png", w, h, c, 8, v);
  const std::vector<std::uint8_t> want = read_oiio<std::uint8_t>(dir / "o.png");
  std::uintmax_t previous = 0;
  for (int level = 0; level <= 9; ++level) {
    const std::string f = dir / ("l" + std::to_string(level) + ".png");
    io::png::write(f, f, io::png::Layout{w, h, c, 8}, v.data(), level, true);
    EXPECT_EQ(read_oiio<std::uint8_t>(f), want) << "level " << level;
    const std::uintmax_t size = fs::file_size(f);
    if (level == 0) EXPECT_GT(size, static_cast<std::uintmax_t>(w) * h * c);
    if (level == 9) EXPECT_LE(size, previous) << "level 9 against level 1";
    if (level == 1) previous = size;
  }
}

// The rounding rule alone, on every boundary of both scales (9 floats around each k + ½).
TEST(PngDirect, RoundingAtEveryBoundaryAndNaN) {
  ScratchDir dir;
  for (int bits : {8, 16}) {
    const double max = bits == 8 ? 255.0 : 65535.0;
    std::vector<float> v;
    for (int k = 0; k < static_cast<int>(max); ++k) {
      float f = static_cast<float>((k + 0.5) / max);
      for (int d = 0; d < 4; ++d) f = std::nextafter(f, 0.0f);
      for (int d = 0; d < 9; ++d, f = std::nextafter(f, 1.0f)) v.push_back(f);
    }
    const int w = static_cast<int>(v.size());
    io::png::write(dir / "d.png", "d.png", io::png::Layout{w, 1, 1, bits}, v.data(), 1, false);
    EXPECT_EQ(read_as_long(dir / "d.png", bits), quantise_rule(v, bits));
    if (bits == 16) {  // a large image: OpenImageIO's writer follows the rule (see above)
      write_oiio(dir / "o.png", w, 1, 1, bits, v);
      EXPECT_EQ(read_as_long(dir / "o.png", bits), quantise_rule(v, bits));
    }
    // The rule on its own examples: the largest float whose product with max is below ½ in
    // float (stores 0; v·max + ½ would round to 1), ½ / max (stores 1), NaN, < 0, > 1.
    const float fmax = static_cast<float>(max);
    float below = 0.5f / fmax;
    while (below * fmax >= 0.5f) below = std::nextafter(below, 0.0f);
    const std::vector<float> probe = {below, 0.5f / fmax, std::numeric_limits<float>::quiet_NaN(), -0.4f, 7.0f};
    io::png::write(dir / "p.png", "p.png", io::png::Layout{5, 1, 1, bits}, probe.data(), 6, false);
    const std::vector<long> got = read_as_long(dir / "p.png", bits);
    const std::vector<long> want = {0, 1, 0, 0, static_cast<long>(max)};
    EXPECT_EQ(got, want) << bits << " bits";
  }
}

// The colour-space chunks: sRGB files get gAMA 1/2.2, sRGB and cHRM before the pixels (as
// OpenImageIO's writer gives them, so readers that colour-manage treat both alike), linear
// ones gAMA 1.0; OpenImageIO reads the colour space back from them.
TEST(PngDirect, ColourSpaceChunks) {
  ScratchDir dir;
  const std::vector<float> v(4 * 4 * 3, 0.5f);
  io::png::write(dir / "s.png", "s.png", io::png::Layout{4, 4, 3, 8}, v.data(), 6, true);
  io::png::write(dir / "l.png", "l.png", io::png::Layout{4, 4, 3, 16}, v.data(), 6, false);
  const Chunks s = parse(slurp(dir / "s.png"));
  EXPECT_EQ(s.types, (std::vector<std::string>{"IHDR", "gAMA", "sRGB", "cHRM", "IDAT", "IEND"}));
  EXPECT_EQ(be32(s.data.at("gAMA"), 0), 45455u);
  const Chunks l = parse(slurp(dir / "l.png"));
  EXPECT_EQ(l.types, (std::vector<std::string>{"IHDR", "gAMA", "IDAT", "IEND"}));
  EXPECT_EQ(be32(l.data.at("gAMA"), 0), 100000u);
  for (const auto& [file, want] : {std::pair<std::string, std::string>{"s.png", "sRGB"}, {"l.png", "Linear"}}) {
    auto in = OIIO::ImageInput::open(dir / file);
    ASSERT_TRUE(in);
    EXPECT_TRUE(OIIO::Strutil::iequals(in->spec().get_string_attribute("oiio:ColorSpace"), want)) << file;
  }
}

// write_image picks this writer for PNG outputs (no OpenImageIO text chunk), and a file that
// cannot be created is a one-line bad-input error naming the display path.
TEST(PngDirect, WriteImageUsesItAndErrorsNameTheFile) {
  ScratchDir dir;
  Image img(9, 5, 4, 0.25f);
  io::write_image(dir / "w.png", img);
  const Chunks ch = parse(slurp(dir / "w.png"));
  EXPECT_EQ(ch.data.count("tEXt"), 0u);
  EXPECT_EQ(ch.types[1], "gAMA");
  const std::string m = bad_input_message([&] {
    io::png::write(dir / "no/such/dir/x.png", "shown.png", io::png::Layout{9, 5, 4, 8}, std::vector<float>(180).data(),
                   6, true);
  });
  EXPECT_NE(m.find("shown.png"), std::string::npos) << m;
  // A row longer than 1 GiB (2^27 RGBA 16-bit pixels) is refused before any pixel is read
  // (the buffer passed here is far too small for the layout: reading it would be caught by
  // the sanitizer build).
  const std::vector<float> tiny(4);
  try {
    io::png::write(dir / "wide.png", "wide.png", io::png::Layout{1 << 27, 1, 4, 16}, tiny.data(), 6, true);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::bad_input);
    EXPECT_NE(std::string(e.what()).find("1 GiB"), std::string::npos) << e.what();
  }
}
