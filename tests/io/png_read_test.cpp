// The PNG reader (io/png_direct.hpp), checked against OpenImageIO's reader (libpng): channel
// names, alpha index and every contiguous channel range bit for bit, for 8 and 16 bits, every
// channel count and all five row filters, and every other kind of PNG (palette, low bit
// depths, interlaced, tRNS, sBIT), which it reads too; the broken files it refuses, with the
// reason; the ancillary chunks it drops as libpng does; and the read_color / read_depth
// conventions on top.
#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <limits>
#include <zlib.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <random>
#include <set>

#include "dofkit/error.hpp"
#include "io/image_io.hpp"
#include "io/io_test_util.hpp"
#include "io/png_direct.hpp"
#include "io/srgb.hpp"

using namespace dofkit;
using namespace dofkit::test;

namespace {

void put32(std::string& s, std::uint32_t v) {
  for (int k = 3; k >= 0; --k) s.push_back(static_cast<char>((v >> (8 * k)) & 0xff));
}

void add_chunk(std::string& png, const std::string& type, const std::string& data) {
  put32(png, static_cast<std::uint32_t>(data.size()));
  const std::string td = type + data;
  png += td;
  put32(png,
        static_cast<std::uint32_t>(crc32(0, reinterpret_cast<const Bytef*>(td.data()), static_cast<uInt>(td.size()))));
}

// A PNG built by hand: IHDR (w, h, depth, colour type, interlace), the `extra` chunks, one
// IDAT of `rows` (already with their filter bytes) zlib-compressed, IEND.
std::string make_png(int w, int h, int depth, int ctype, int interlace, const std::string& rows,
                     const std::vector<std::pair<std::string, std::string>>& extra = {}) {
  std::string png("\x89PNG\r\n\x1a\n", 8);
  std::string ihdr;
  put32(ihdr, static_cast<std::uint32_t>(w));
  put32(ihdr, static_cast<std::uint32_t>(h));
  ihdr += static_cast<char>(depth);
  ihdr += static_cast<char>(ctype);
  ihdr += std::string(2, '\0');
  ihdr += static_cast<char>(interlace);
  add_chunk(png, "IHDR", ihdr);
  for (const auto& [t, d] : extra) add_chunk(png, t, d);
  std::vector<Bytef> z(compressBound(static_cast<uLong>(rows.size())));
  uLongf n = z.size();
  compress2(z.data(), &n, reinterpret_cast<const Bytef*>(rows.data()), static_cast<uLong>(rows.size()), 6);
  add_chunk(png, "IDAT", std::string(reinterpret_cast<const char*>(z.data()), n));
  add_chunk(png, "IEND", "");
  return png;
}

void write_file(const std::string& path, const std::string& bytes) {
  std::ofstream f(path, std::ios::binary);
  f.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

// Codes that make every row filter win somewhere: flat rows (None / Up), horizontal ramps
// (Sub), vertical ramps (Up), smooth 2-D ramps (Average / Paeth), noise.
std::vector<float> coded_samples(int w, int h, int c, int bits, int seed) {
  const int max = bits == 8 ? 255 : 65535;
  std::mt19937 rng(seed);
  std::vector<float> v(static_cast<std::size_t>(w) * h * c);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int k = 0; k < c; ++k) {
        long code;
        switch ((y / 4) % 5) {
          case 0:
            code = 40 * (k + 1);
            break;
          case 1:
            code = 3 * x + 7 * k;
            break;
          case 2:
            code = 5 * y + 11 * k;
            break;
          case 3:
            code = (x * x + 3 * y * y) / 40 + 13 * k;
            break;
          default:
            code = static_cast<long>(rng() % (max + 1));
            break;
        }
        if (bits == 16 && (y / 4) % 5 != 4) code *= 97;
        v[(static_cast<std::size_t>(y) * w + x) * c + k] = static_cast<float>(code % (max + 1)) / max;
      }
  return v;
}

std::unique_ptr<OIIO::ImageInput> open_oiio(const std::string& path) {
  OIIO::ImageSpec config;
  config.attribute("oiio:UnassociatedAlpha", 1);  // as dofkit's module opens files
  return OIIO::ImageInput::open(path, &config);
}

std::vector<int> filter_types(const std::string& png_bytes, int h, std::size_t stride) {
  // Concatenate the IDAT data and inflate it; the first byte of every row is its filter.
  std::string idat;
  for (std::size_t p = 8; p + 12 <= png_bytes.size();) {
    const std::uint32_t n = (static_cast<std::uint32_t>(static_cast<unsigned char>(png_bytes[p])) << 24) |
                            (static_cast<std::uint32_t>(static_cast<unsigned char>(png_bytes[p + 1])) << 16) |
                            (static_cast<std::uint32_t>(static_cast<unsigned char>(png_bytes[p + 2])) << 8) |
                            static_cast<unsigned char>(png_bytes[p + 3]);
    if (png_bytes.compare(p + 4, 4, "IDAT") == 0) idat += png_bytes.substr(p + 8, n);
    p += 12 + n;
  }
  std::vector<Bytef> rows(stride * h);
  uLongf got = rows.size();
  EXPECT_EQ(uncompress(rows.data(), &got, reinterpret_cast<const Bytef*>(idat.data()), idat.size()), Z_OK);
  std::vector<int> t;
  for (int y = 0; y < h; ++y) t.push_back(rows[y * stride]);
  return t;
}

}  // namespace

// Files from dofkit's writer (all five filters) and from OpenImageIO's (libpng's choices),
// every channel count, 8 and 16 bits: the same names, alpha index and floats as OpenImageIO.
TEST(PngRead, EqualsOpenImageIOBitForBit) {
  ScratchDir dir;
  struct Size {
    int w, h;
  };
  std::set<int> filters_seen;
  for (const Size sz : {Size{1, 1}, Size{7, 3}, Size{301, 97}})
    for (int c = 1; c <= 4; ++c)
      for (int bits : {8, 16})
        for (bool ours : {true, false}) {
          SCOPED_TRACE(std::to_string(sz.w) + "x" + std::to_string(sz.h) + " c" + std::to_string(c) + " " +
                       std::to_string(bits) + (ours ? " bits, dofkit's file" : " bits, OpenImageIO's file"));
          const std::string path = dir / "t.png";
          const std::vector<float> v = coded_samples(sz.w, sz.h, c, bits, sz.w * c + bits);
          if (ours) {
            io::png::write(path, path, io::png::Layout{sz.w, sz.h, c, bits}, v.data(), 6, c >= 3);
            for (int t : filter_types(slurp(path), sz.h, 1 + static_cast<std::size_t>(sz.w) * c * bits / 8))
              filters_seen.insert(t);
          } else {
            OIIO::ImageSpec spec(sz.w, sz.h, c, bits == 8 ? OIIO::TypeDesc::UINT8 : OIIO::TypeDesc::UINT16);
            if (c == 2 || c == 4) spec.attribute("oiio:UnassociatedAlpha", 1);
            auto out = OIIO::ImageOutput::create(path);
            ASSERT_TRUE(out && out->open(path, spec) && out->write_image(OIIO::TypeDesc::FLOAT, v.data()) &&
                        out->close());
          }
          const auto r = io::png::Reader::open(path);
          ASSERT_TRUE(r);
          auto in = open_oiio(path);
          ASSERT_TRUE(in);
          const OIIO::ImageSpec& s = in->spec();
          EXPECT_EQ(r->width(), s.width);
          EXPECT_EQ(r->height(), s.height);
          EXPECT_EQ(r->names(), s.channelnames);
          EXPECT_EQ(r->alpha_channel(), s.alpha_channel);
          // image_io.cpp's spec_of takes PNG alpha as straight: so does OpenImageIO.
          if (r->alpha_channel() >= 0) EXPECT_EQ(s.get_int_attribute("oiio:UnassociatedAlpha", 0), 1);
          for (int cb = 0; cb < c; ++cb)
            for (int ce = cb + 1; ce <= c; ++ce) {
              const std::size_t n = static_cast<std::size_t>(sz.w) * sz.h * (ce - cb);
              std::vector<float> mine(n, -1.0f), theirs(n, -2.0f);
              ASSERT_TRUE(r->read(cb, ce, mine.data()));
              ASSERT_TRUE(in->read_image(0, 0, cb, ce, OIIO::TypeDesc::FLOAT, theirs.data()));
              std::size_t diff = 0;
              for (std::size_t i = 0; i < n; ++i) diff += bits_of(mine[i]) != bits_of(theirs[i]);
              EXPECT_EQ(diff, 0u) << "channels [" << cb << ", " << ce << ")";
            }
        }
  EXPECT_EQ(filters_seen, (std::set<int>{0, 1, 2, 3, 4})) << "the test data should make every filter win somewhere";
}

// Every 8-bit and 16-bit code converts to OpenImageIO's float.
TEST(PngRead, EveryCodeConvertsAsOpenImageIO) {
  ScratchDir dir;
  for (int bits : {8, 16}) {
    const int max = bits == 8 ? 255 : 65535;
    std::string rows;
    const int w = 256, h = (max + 1) / w;
    for (int y = 0; y < h; ++y) {
      rows += '\0';
      for (int x = 0; x < w; ++x) {
        const int code = y * w + x;
        if (bits == 16) rows += static_cast<char>(code >> 8);
        rows += static_cast<char>(code & 0xff);
      }
    }
    const std::string path = dir / "codes.png";
    write_file(path, make_png(w, h, bits, 0, 0, rows));
    const auto r = io::png::Reader::open(path);
    ASSERT_TRUE(r);
    std::vector<float> mine(static_cast<std::size_t>(w) * h), theirs(mine.size());
    ASSERT_TRUE(r->read(0, 1, mine.data()));
    auto in = open_oiio(path);
    ASSERT_TRUE(in && in->read_image(0, 0, 0, 1, OIIO::TypeDesc::FLOAT, theirs.data()));
    for (std::size_t i = 0; i < mine.size(); ++i)
      ASSERT_EQ(bits_of(mine[i]), bits_of(theirs[i])) << bits << " bits, code " << i;
  }
}

// Every PNG is read here (OpenImageIO never sees one): palette images with and without
// transparency, 1/2/4-bit grey, interlaced images of every colour type, a tRNS key colour,
// sBIT — each the floats, names and alpha OpenImageIO (libpng's expansion) gives.
TEST(PngRead, ReadsEveryKindOfPngAsOpenImageIO) {
  ScratchDir dir;
  struct Case {
    std::string name;
    int w, h, depth, ctype, interlace;
    std::vector<std::pair<std::string, std::string>> extra;
  };
  const std::string plte("\x10\x20\x30\x80\x90\xa0\xff\x00\x40\x00\xff\x00\x05\x06\x07\xfe\xfd\xfc", 18);
  std::vector<Case> cases = {
      {"palette8", 13, 7, 8, 3, 0, {{"PLTE", plte}}},
      {"palette4_trns", 13, 7, 4, 3, 0, {{"PLTE", plte}, {"tRNS", std::string("\x00\x80\xff\x10", 4)}}},
      {"palette2_interlaced", 13, 11, 2, 3, 1, {{"PLTE", plte.substr(0, 12)}}},
      {"palette1", 9, 3, 1, 3, 0, {{"PLTE", plte.substr(0, 6)}}},
      {"grey1", 19, 5, 1, 0, 0, {}},
      {"grey2", 19, 5, 2, 0, 0, {}},
      {"grey4_interlaced", 19, 13, 4, 0, 1, {}},
      {"grey4_key", 19, 5, 4, 0, 0, {{"tRNS", std::string("\x00\x05", 2)}}},
      {"grey8_key", 17, 5, 8, 0, 0, {{"tRNS", std::string("\x01\x25", 2)}}},
      {"grey16_key", 17, 5, 16, 0, 0, {{"tRNS", std::string("\x25\x0b", 2)}}},
      {"rgb8_key", 9, 6, 8, 2, 0, {{"tRNS", std::string("\x00\x25\x00\x48\x00\x6b", 6)}}},
      {"rgb16_key_interlaced", 9, 9, 16, 2, 1, {{"tRNS", std::string("\x25\x0b\x4a\x16\x6f\x21", 6)}}},
      {"rgb8_sbit", 9, 6, 8, 2, 0, {{"sBIT", std::string("\x05\x06\x05", 3)}}},
      {"grey8_interlaced", 1, 1, 8, 0, 1, {}},
      {"grey_alpha8_interlaced", 10, 9, 8, 4, 1, {}},
      {"rgba16_interlaced", 3, 17, 16, 6, 1, {}},
      {"rgba8_interlaced_wide", 33, 2, 8, 6, 1, {}},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const int channels = c.ctype == 0 || c.ctype == 3 ? 1 : c.ctype == 4 ? 2 : c.ctype == 2 ? 3 : 4;
    const int bits = channels * c.depth;
    // Rows of pseudo-random bytes (palette indices kept inside the palette), passes for Adam7.
    std::string rows;
    std::mt19937 rng(static_cast<unsigned>(c.w * 131 + c.h + c.depth));
    const int entries = c.ctype == 3 ? static_cast<int>(c.extra[0].second.size() / 3) : 0;
    auto add_rows = [&](int pw, int ph) {
      if (pw == 0 || ph == 0) return;
      const int bytes = (pw * bits + 7) / 8;
      for (int y = 0; y < ph; ++y) {
        rows += '\0';
        for (int x = 0; x < bytes; ++x) {
          unsigned v = rng() & 0xff;
          if (c.ctype == 3) {
            // every packed index below `entries`
            unsigned packed = 0;
            for (int k = 0; k < 8 / c.depth; ++k) packed = packed << c.depth | (rng() % entries);
            v = c.depth == 8 ? rng() % entries : packed;
          } else if (c.ctype == 0 && c.depth <= 8 && (x + y) % 3 == 0) {
            v = c.depth == 8 ? 0x25 : c.depth == 4 ? 0x55 : v;  // some pixels equal the key
          }
          rows += static_cast<char>(v);
        }
      }
    };
    if (!c.interlace) {
      add_rows(c.w, c.h);
    } else {
      const int pass[7][4] = {{0, 0, 8, 8}, {4, 0, 8, 8}, {0, 4, 4, 8}, {2, 0, 4, 4},
                              {0, 2, 2, 4}, {1, 0, 2, 2}, {0, 1, 1, 2}};
      for (const auto& p : pass)
        add_rows(c.w > p[0] ? (c.w - p[0] + p[2] - 1) / p[2] : 0, c.h > p[1] ? (c.h - p[1] + p[3] - 1) / p[3] : 0);
    }
    const std::string path = dir / (c.name + ".png");
    write_file(path, make_png(c.w, c.h, c.depth, c.ctype, c.interlace, rows, c.extra));
    std::string broken;
    const auto r = io::png::Reader::open(path, &broken);
    ASSERT_TRUE(r) << broken;
    auto in = open_oiio(path);
    ASSERT_TRUE(in);
    const OIIO::ImageSpec& spec = in->spec();
    EXPECT_EQ(r->width(), spec.width);
    EXPECT_EQ(r->height(), spec.height);
    ASSERT_EQ(r->names(), spec.channelnames);
    EXPECT_EQ(r->alpha_channel(), spec.alpha_channel);
    const int n = spec.nchannels;
    const std::size_t count = static_cast<std::size_t>(c.w) * c.h * n;
    std::vector<float> mine(count, -1.0f), theirs(count, -2.0f);
    ASSERT_TRUE(r->read(0, n, mine.data(), &broken)) << broken;
    ASSERT_TRUE(in->read_image(0, 0, 0, n, OIIO::TypeDesc::FLOAT, theirs.data()));
    std::size_t diff = 0;
    for (std::size_t i = 0; i < count; ++i) diff += bits_of(mine[i]) != bits_of(theirs[i]);
    EXPECT_EQ(diff, 0u);
    // read_color takes it the same way (and never loads OpenImageIO for it).
    EXPECT_NO_THROW(io::read_color(path));
  }
  // What is not a PNG is left to the other readers; a file that is missing too.
  write_file(dir / "not_png.png", "GIF89a....");
  std::string broken;
  EXPECT_FALSE(io::png::Reader::open(dir / "not_png.png", &broken));
  EXPECT_EQ(broken, "");
  EXPECT_FALSE(io::png::Reader::open(dir / "missing.png"));
  // Ancillary chunks that change nothing are fine (text, gamma), and so are bytes after IEND.
  const std::string rgb_rows =
      std::string(1, '\0') + std::string(6, '\x40') + std::string(1, '\0') + std::string(6, '\x80');
  write_file(dir / "text.png",
             make_png(2, 2, 8, 2, 0, rgb_rows, {{"tEXt", std::string("k\0v", 3)}, {"gAMA", std::string(4, '\1')}}));
  EXPECT_TRUE(io::png::Reader::open(dir / "text.png"));
  write_file(dir / "after_iend.png", make_png(2, 2, 8, 2, 0, rgb_rows) + "x");
  EXPECT_TRUE(io::png::Reader::open(dir / "after_iend.png"));
}

// Files libpng refuses with an error are refused here with the reason, on one line that
// names the file, and libpng is never asked (it would print its own "libpng error" line).
TEST(PngRead, BrokenFilesAreRefusedWithTheirReason) {
  ScratchDir dir;
  const std::string rgb_rows =
      std::string(1, '\0') + std::string(6, '\x40') + std::string(1, '\0') + std::string(6, '\x80');
  const std::string ok = make_png(2, 2, 8, 2, 0, rgb_rows);
  const auto ihdr_with = [&](std::size_t at, char v) {  // `at` within IHDR's 13 data bytes
    std::string b = ok, data = ok.substr(8 + 8, 13);
    data[at] = v;
    std::string fixed("\x89PNG\r\n\x1a\n", 8);
    add_chunk(fixed, "IHDR", data);
    return fixed + b.substr(8 + 25);
  };
  std::string ihdr_crc = ok, idat_crc = ok;
  ihdr_crc[8 + 8 + 13] ^= 1;
  idat_crc[ok.size() - 12 - 1] ^= 1;  // the last byte of IDAT's CRC (IEND is 12 bytes)
  std::string first_text("\x89PNG\r\n\x1a\n", 8);
  add_chunk(first_text, "tEXt", std::string("k\0v", 3));
  first_text += ok.substr(8);
  std::string first_text_crc = first_text;
  first_text_crc[8 + 8 + 3 + 3] ^= 1;  // that tEXt chunk's CRC: still not IHDR first
  const std::string short_rows = std::string(1, '\0') + std::string(6, '\x40');  // one row of two
  const std::string bad_filter =
      std::string(1, '\x07') + std::string(6, '\x40') + std::string(1, '\0') + std::string(6, '\x80');
  struct Case {
    const char* name;
    std::string bytes;
    const char* reason;
    bool at_open;  // refused by open() (else by read())
  };
  const Case cases[] = {
      {"ihdr_crc.png", ihdr_crc, "chunk 'IHDR' fails its CRC check", true},
      {"idat_crc.png", idat_crc, "chunk 'IDAT' fails its CRC check", true},
      {"zero_width.png", ihdr_with(3, 0), "zero width or height", true},
      {"depth4_rgb.png", ihdr_with(8, 4), "colour type 2 with bit depth 4, which PNG does not allow", true},
      {"ctype5.png", ihdr_with(9, 5), "colour type 5 with bit depth 8", true},
      {"compression1.png", ihdr_with(10, 1), "compression method 1", true},
      {"filter1.png", ihdr_with(11, 1), "filter method 1", true},
      {"interlace2.png", ihdr_with(12, 2), "interlace method 2", true},
      {"text_first.png", first_text, "the first chunk is 'tEXt', not IHDR", true},
      {"text_first_crc.png", first_text_crc, "the first chunk is 'tEXt', not IHDR", true},
      {"short.png", make_png(2, 2, 8, 2, 0, short_rows), "inflates to 7 of the 14 bytes", false},
      {"filter.png", make_png(2, 2, 8, 2, 0, bad_filter), "row 0 has filter type 7", false},
      // Issue 37: what went to OpenImageIO before, where libpng printed its own line first.
      {"critical.png", make_png(2, 2, 8, 2, 0, rgb_rows, {{"ABCD", "x"}}), "unknown critical chunk 'ABCD'", true},
      {"truncated.png", ok.substr(0, ok.size() - 5), "truncated", true},
      {"no_plte.png", make_png(2, 2, 8, 3, 0, std::string(3, '\0') + std::string(3, '\0')),
       "a palette image without a PLTE chunk", true},
      {"index_beyond.png",
       make_png(2, 2, 8, 3, 0, std::string(1, '\0') + "\x00\x02" + std::string(1, '\0') + "\x01\x00",
                {{"PLTE", std::string("\x10\x20\x30\x40\x50\x60", 6)}}),
       "palette index 2, beyond its 2 entries", false},
      {"trns_alpha.png",
       make_png(2, 2, 8, 6, 0,
                std::string(1, '\0') + std::string(8, '\x40') + std::string(1, '\0') + std::string(8, '\x80'),
                {{"tRNS", std::string(6, '\0')}}),
       "a tRNS chunk in an image that has an alpha channel", true},
      {"extra.png", make_png(2, 2, 8, 2, 0, rgb_rows + std::string(1, '\0') + std::string(6, '\x20')),
       "inflates to more bytes than its rows", false},
  };
  for (const Case& c : cases) {
    write_file(dir / c.name, c.bytes);
    std::string broken;
    const auto r = io::png::Reader::open(dir / c.name, &broken);
    if (c.at_open) {
      EXPECT_FALSE(r) << c.name;
      EXPECT_NE(broken.find(c.reason), std::string::npos) << c.name << ": " << broken;
    } else {
      ASSERT_TRUE(r) << c.name;
      std::vector<float> px(2 * 2 * 3);
      EXPECT_FALSE(r->read(0, 3, px.data(), &broken)) << c.name;
      EXPECT_NE(broken.find(c.reason), std::string::npos) << c.name << ": " << broken;
    }
    testing::internal::CaptureStderr();
    try {
      (void)io::read_color(dir / c.name);
      ADD_FAILURE() << c.name << ": no error";
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::bad_input) << e.what();
      const std::string m = e.what();
      EXPECT_NE(m.find(dir / c.name), std::string::npos) << m;
      EXPECT_NE(m.find(c.reason), std::string::npos) << m;
      EXPECT_EQ(m.find('\n'), std::string::npos) << m;
    }
    const std::string err = testing::internal::GetCapturedStderr();
    EXPECT_EQ(err, "") << c.name << ": something else printed";
    // And libpng (through OpenImageIO) refuses the first ones too; the issue 37 cases are
    // damage libpng only warns about (or decodes as grey) and are refused here on purpose.
    if (std::string(c.name) == "critical.png") break;
    bool oiio_read = false;
    if (auto in = open_oiio(dir / c.name)) {
      std::vector<float> px(static_cast<std::size_t>(in->spec().image_pixels()) * in->spec().nchannels);
      oiio_read = in->read_image(0, 0, 0, in->spec().nchannels, OIIO::TypeDesc::FLOAT, px.data());
      (void)in->geterror();
    }
    (void)OIIO::geterror();
    EXPECT_FALSE(oiio_read) << c.name << ": OpenImageIO reads it";
  }
}

// An ancillary chunk with a bad CRC is dropped (as libpng drops it: even a tRNS) and the file
// read; a stream with a wrong Adler-32 or more data than the rows is damage, refused with the
// reason (libpng errs or warns, and OpenImageIO used to read such a file).
TEST(PngRead, DroppedChunksAndDamagedStreams) {
  ScratchDir dir;
  const std::string rgb_rows =
      std::string(1, '\0') + std::string(6, '\x40') + std::string(1, '\0') + std::string(6, '\x80');
  const std::string ok = make_png(2, 2, 8, 2, 0, rgb_rows);
  write_file(dir / "ok.png", ok);
  const Image want = io::read_color(dir / "ok.png");
  const auto same_as_ok = [&](const std::string& name) {
    const Image got = io::read_color(dir / name);
    ASSERT_EQ(got.data().size(), want.data().size()) << name;
    for (std::size_t i = 0; i < got.data().size(); ++i)
      ASSERT_EQ(bits_of(got.data()[i]), bits_of(want.data()[i])) << name << " sample " << i;
  };
  for (const char* type : {"tEXt", "tRNS"}) {
    std::string b = make_png(2, 2, 8, 2, 0, rgb_rows, {{type, std::string(6, '\0')}});
    b[8 + 25 + 8 + 6] ^= 1;  // the chunk's CRC
    const std::string name = std::string(type) + "_crc.png";
    write_file(dir / name, b);
    EXPECT_TRUE(io::png::Reader::open(dir / name)) << name << ": the chunk is dropped, the file taken";
    same_as_ok(name);
    auto in = open_oiio(dir / name);  // libpng drops it too: no alpha channel from the tRNS
    ASSERT_TRUE(in) << name;
    EXPECT_EQ(in->spec().nchannels, 3) << name;
  }
  // A wrong Adler-32 (the stream's last 4 bytes, just before IDAT's CRC): rebuild IDAT with it.
  const std::size_t idat_at = 8 + 25;
  const std::uint32_t n =
      (static_cast<unsigned char>(ok[idat_at]) << 24) | (static_cast<unsigned char>(ok[idat_at + 1]) << 16) |
      (static_cast<unsigned char>(ok[idat_at + 2]) << 8) | static_cast<unsigned char>(ok[idat_at + 3]);
  std::string stream = ok.substr(idat_at + 8, n);
  stream.back() ^= 1;
  std::string b = ok.substr(0, idat_at);
  add_chunk(b, "IDAT", stream);
  add_chunk(b, "IEND", "");
  write_file(dir / "adler.png", b);
  try {
    (void)io::read_color(dir / "adler.png");
    ADD_FAILURE() << "a damaged stream was read";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::bad_input);
    EXPECT_NE(std::string(e.what()).find("does not inflate (a corrupt zlib stream or checksum)"), std::string::npos)
        << e.what();
  }
}

// The whole path: read_color of a PNG read here is the file's codes as OpenImageIO gives them
// (code / max), sRGB-decoded, premultiplied by the straight alpha; read_depth of a 16-bit grey
// disparity map is scale / (code / max) — bit for bit, for RGB, RGBA, grey and grey + alpha.
TEST(PngRead, ReadColorAndDepthFollowTheConventions) {
  ScratchDir dir;
  const int w = 67, h = 41;
  for (int c : {1, 2, 3, 4})
    for (int bits : {8, 16}) {
      SCOPED_TRACE("c" + std::to_string(c) + " " + std::to_string(bits) + " bits");
      const std::vector<float> v = coded_samples(w, h, c, bits, 3 * c + bits);
      const std::string path = dir / "direct.png";
      io::png::write(path, path, io::png::Layout{w, h, c, bits}, v.data(), 6, true);
      const Image got = io::read_color(path);
      const bool alpha = c == 2 || c == 4;
      // The reader's float for a stored code: code · (1 / max), as OpenImageIO converts.
      const float max = bits == 8 ? 255.0f : 65535.0f;
      const auto as_read = [&](float v) { return std::nearbyint(v * max) * (1.0f / max); };
      std::size_t diff = 0;
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
          const float* p = &v[(static_cast<std::size_t>(y) * w + x) * c];
          const float a = alpha ? as_read(p[c - 1]) : 1.0f;
          for (int k = 0; k < 3; ++k) {
            float want = io::decode_srgb(as_read(p[c >= 3 ? k : 0]));
            if (alpha) want *= a;
            diff += bits_of(got.at(x, y, k)) != bits_of(want);
          }
          diff += bits_of(got.at(x, y, 3)) != bits_of(a);
        }
      EXPECT_EQ(diff, 0u) << "read_color";
      if (c == 1) {
        io::DepthOptions o;
        o.kind = io::DepthKind::disparity;
        o.disparity_scale = 1.0;
        o.invalid_as_far = true;
        const Image z = io::read_depth(path, o);
        std::size_t zdiff = 0;
        for (std::size_t i = 0; i < z.plane_size(); ++i) {
          const float d = as_read(v[i]);
          const float want = d == 0 ? std::numeric_limits<float>::infinity() : static_cast<float>(1.0 / d);
          zdiff += bits_of(z.plane(0)[i]) != bits_of(want);
        }
        EXPECT_EQ(zdiff, 0u) << "read_depth";
      }
    }
}
