// The direct PNG reader (io/png_direct.hpp), checked against OpenImageIO's reader (libpng):
// channel names, alpha index and every contiguous channel range bit for bit, for 8 and 16
// bits, every channel count and all five row filters; the files it must leave to
// OpenImageIO (palette, low bit depths, interlaced, tRNS, sBIT, truncation, bytes after IEND,
// non-PNG); the broken files it refuses itself, with the reason; what libpng tolerates; and the
// whole read_color / read_depth path gives what it gives through OpenImageIO.
#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>
#include <zlib.h>

#include <cstdint>
#include <cstring>
#include <fstream>
#include <random>
#include <set>

#include "dofkit/error.hpp"
#include "io/image_io.hpp"
#include "io/io_test_util.hpp"
#include "io/png_direct.hpp"

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

// The files this reader leaves to OpenImageIO.
TEST(PngRead, LeavesOtherFilesToOpenImageIO) {
  ScratchDir dir;
  const std::string rgb_rows =
      std::string(1, '\0') + std::string(6, '\x40') + std::string(1, '\0') + std::string(6, '\x80');
  const std::string ok = make_png(2, 2, 8, 2, 0, rgb_rows);
  write_file(dir / "ok.png", ok);
  EXPECT_TRUE(io::png::Reader::open(dir / "ok.png")) << "the control file must be taken";

  const auto refused = [&](const std::string& name, const std::string& bytes) {
    write_file(dir / name, bytes);
    std::string broken;
    EXPECT_FALSE(io::png::Reader::open(dir / name, &broken)) << name;
    EXPECT_EQ(broken, "") << name << ": OpenImageIO's to judge, not broken";
  };
  refused("palette.png", make_png(2, 2, 8, 3, 0, std::string(3, '\0') + std::string(3, '\0'),
                                  {{"PLTE", std::string("\x10\x20\x30", 3)}}));
  refused("depth4.png", make_png(2, 2, 4, 0, 0, std::string(2, '\0') + std::string(2, '\0')));
  refused("interlaced.png", make_png(2, 2, 8, 2, 1, rgb_rows));
  refused("trns.png", make_png(2, 2, 8, 2, 0, rgb_rows, {{"tRNS", std::string(6, '\0')}}));
  refused("sbit.png", make_png(2, 2, 8, 2, 0, rgb_rows, {{"sBIT", std::string("\x08\x08\x08", 3)}}));
  refused("critical.png", make_png(2, 2, 8, 2, 0, rgb_rows, {{"ABCD", "x"}}));
  refused("truncated.png", ok.substr(0, ok.size() - 5));
  refused("after_iend.png", ok + "x");
  refused("not_png.png", "GIF89a....");
  EXPECT_FALSE(io::png::Reader::open(dir / "missing.png"));
  // Ancillary chunks that change nothing are fine (text, gamma, sRGB).
  write_file(dir / "text.png",
             make_png(2, 2, 8, 2, 0, rgb_rows, {{"tEXt", std::string("k\0v", 3)}, {"gAMA", std::string(4, '\1')}}));
  EXPECT_TRUE(io::png::Reader::open(dir / "text.png"));
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
    // And libpng (through OpenImageIO) refuses it too: nothing it would read is refused here.
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

// What libpng may tolerate stays OpenImageIO's to judge, as before: an ancillary chunk with a
// bad CRC is dropped (here as there: even a tRNS); a stream with a wrong Adler-32 makes this
// reader's read() fail without a reason, so the file goes to OpenImageIO (libpng errors on it
// when it meets the checksum with the rows, warns when it meets it after the last row).
TEST(PngRead, WhatLibpngToleratesIsStillRead) {
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
  // A stream with a third row after the two declared: libpng warns ("extra compressed data")
  // and reads the two.
  // Both files below are taken by open() and fail read() without a reason (OpenImageIO's call).
  const auto read_fails_without_reason = [&](const std::string& name) {
    const auto r = io::png::Reader::open(dir / name);
    ASSERT_TRUE(r) << name;
    std::vector<float> px(2 * 2 * 3);
    std::string broken;
    EXPECT_FALSE(r->read(0, 3, px.data(), &broken)) << name;
    EXPECT_EQ(broken, "") << name;
  };
  write_file(dir / "extra.png", make_png(2, 2, 8, 2, 0, rgb_rows + std::string(1, '\0') + std::string(6, '\x20')));
  read_fails_without_reason("extra.png");
  same_as_ok("extra.png");
  // A wrong Adler-32 (the stream's last 4 bytes, just before IDAT's CRC): rebuild IDAT with it.
  {
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
    read_fails_without_reason("adler.png");
    try {
      (void)io::read_color(dir / "adler.png");
      ADD_FAILURE() << "libpng errs on this file: so must read_color";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("PNG read error"), std::string::npos) << e.what();
    }
  }
}

// The whole path: read_color and read_depth of a PNG read here equal those of the same pixels
// in a file OpenImageIO reads (the same PNG with a no-op sBIT chunk, which this reader
// refuses), bit for bit: RGB, RGBA (straight alpha, premultiplied on the way in), grey; depth
// from a 16-bit grey disparity map.
TEST(PngRead, ReadColorAndDepthEqualTheOpenImageIOPath) {
  ScratchDir dir;
  const int w = 67, h = 41;
  for (int c : {1, 2, 3, 4})
    for (int bits : {8, 16}) {
      SCOPED_TRACE("c" + std::to_string(c) + " " + std::to_string(bits) + " bits");
      const std::vector<float> v = coded_samples(w, h, c, bits, 3 * c + bits);
      const std::string direct = dir / "direct.png", via = dir / "via_oiio.png";
      io::png::write(direct, direct, io::png::Layout{w, h, c, bits}, v.data(), 6, true);
      // The same file with an sBIT chunk (every sample significant) after IHDR.
      std::string bytes = slurp(direct);
      std::string sbit_file = bytes.substr(0, 8 + 25);
      add_chunk(sbit_file, "sBIT", std::string(static_cast<std::size_t>(c), static_cast<char>(bits)));
      sbit_file += bytes.substr(8 + 25);
      write_file(via, sbit_file);
      ASSERT_TRUE(io::png::Reader::open(direct));
      ASSERT_FALSE(io::png::Reader::open(via));
      EXPECT_EQ(bit_differences(io::read_color(direct), io::read_color(via)), 0u) << "read_color";
      if (c == 1) {
        io::DepthOptions o;
        o.kind = io::DepthKind::disparity;
        o.disparity_scale = 1.0;
        o.invalid_as_far = true;
        EXPECT_EQ(bit_differences(io::read_depth(direct, o), io::read_depth(via, o)), 0u) << "read_depth";
      }
    }
}
