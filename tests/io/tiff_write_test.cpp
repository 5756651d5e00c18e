// The direct TIFF writer (io/tiff_direct.hpp), checked against OpenImageIO's TIFF writer
// (libtiff): for grey, RGB and RGBA at 8, 16 and 32 bits, sRGB and linear, the same floats
// written by both give the same directory — every tag, type, count and value but the strip
// offsets and byte counts and the DateTime — the same EXIF directory, and strips that inflate
// to the same bytes (so the same quantisation and predictor) and equal, byte for byte, what
// libtiff writes for those bytes when each strip is one write call (libdeflate's stream, where
// OpenImageIO's row-by-row writes get zlib's); OpenImageIO reads both back to the same image.
// Small images check the samples against the quantisation rule instead (OpenImageIO rounds
// some halves differently there, see png_write_test.cpp).
#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>
#include <tiffio.h>
#include <zlib.h>

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "dofkit/error.hpp"
#include "io/image_io.hpp"
#include "io/io_test_util.hpp"
#include "io/tiff_direct.hpp"

using namespace dofkit;
using namespace dofkit::test;

namespace {

struct Tag {
  std::uint16_t type = 0;
  std::uint32_t count = 0;
  std::string value;  // the value bytes (inline or out of line)
  bool operator==(const Tag& o) const { return type == o.type && count == o.count && value == o.value; }
};

struct Tiff {
  std::map<std::uint16_t, Tag> tags, exif;
  std::vector<std::string> strips;
  std::uint32_t next_ifd = 1;
};

std::uint32_t le(const std::string& s, std::size_t at, int n) {
  std::uint32_t v = 0;
  for (int k = n - 1; k >= 0; --k) v = v << 8 | static_cast<unsigned char>(s.at(at + k));
  return v;
}

std::map<std::uint16_t, Tag> read_ifd(const std::string& b, std::size_t at, std::uint32_t* next) {
  std::map<std::uint16_t, Tag> out;
  const std::uint32_t n = le(b, at, 2);
  for (std::uint32_t i = 0; i < n; ++i) {
    const std::size_t e = at + 2 + 12 * i;
    Tag t;
    t.type = static_cast<std::uint16_t>(le(b, e + 2, 2));
    t.count = le(b, e + 4, 4);
    const std::size_t size = (t.type == 3 ? 2 : t.type == 2 || t.type == 1 ? 1 : 4) * static_cast<std::size_t>(t.count);
    t.value = size <= 4 ? b.substr(e + 8, size) : b.substr(le(b, e + 8, 4), size);
    EXPECT_EQ(t.value.size(), size) << "tag " << le(b, e, 2) << " runs past the file";
    out[static_cast<std::uint16_t>(le(b, e, 2))] = t;
  }
  *next = le(b, at + 2 + 12 * n, 4);
  return out;
}

Tiff parse(const std::string& path) {
  const std::string b = slurp(path);
  Tiff t;
  EXPECT_EQ(b.substr(0, 4), std::string("II*\0", 4));
  t.tags = read_ifd(b, le(b, 4, 4), &t.next_ifd);
  if (t.tags.count(34665)) {
    std::uint32_t next = 0;
    t.exif = read_ifd(b, le(t.tags[34665].value, 0, 4), &next);
  }
  const Tag& off = t.tags.at(273);
  const Tag& cnt = t.tags.at(279);
  EXPECT_EQ(off.count, cnt.count);
  for (std::uint32_t i = 0; i < off.count; ++i) {
    const std::uint32_t o = le(off.value, 4 * i, 4),
                        n = cnt.type == 3 ? le(cnt.value, 2 * i, 2) : le(cnt.value, 4 * i, 4);
    t.strips.push_back(b.substr(o, n));
    EXPECT_EQ(t.strips.back().size(), n) << "strip " << i << " runs past the file";
  }
  return t;
}

// The floats through OpenImageIO's TIFF writer, with the spec dofkit's module gives it
// (image_io.cpp, encode_image).
void write_oiio(const std::string& path, int w, int h, int c, int bits, bool srgb, const std::vector<float>& v) {
  OIIO::ImageSpec spec(w, h, c,
                       bits == 8    ? OIIO::TypeDesc::UINT8
                       : bits == 16 ? OIIO::TypeDesc::UINT16
                                    : OIIO::TypeDesc::FLOAT);
  if (c >= 3) {
    spec.channelnames = {"R", "G", "B"};
    if (c == 4) {
      spec.channelnames.push_back("A");
      spec.alpha_channel = 3;
    }
  } else {
    spec.channelnames = {"Y"};
  }
  if (c == 4 && bits != 32) spec.attribute("oiio:UnassociatedAlpha", 1);
  if (bits != 32) spec.attribute("oiio:ColorSpace", srgb ? "sRGB" : "Linear");
  auto out = OIIO::ImageOutput::create(path);
  ASSERT_TRUE(out && out->open(path, spec)) << OIIO::geterror();
  ASSERT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, v.data()));
  ASSERT_TRUE(out->close());
}

std::vector<float> read_floats(const std::string& path) {
  OIIO::ImageSpec config;
  config.attribute("oiio:UnassociatedAlpha", 1);
  auto in = OIIO::ImageInput::open(path, &config);
  if (!in) {
    ADD_FAILURE() << path << ": " << OIIO::geterror();
    return {};
  }
  std::vector<float> px(static_cast<std::size_t>(in->spec().image_pixels()) * in->spec().nchannels);
  EXPECT_TRUE(in->read_image(0, 0, 0, in->spec().nchannels, OIIO::TypeDesc::FLOAT, px.data())) << in->geterror();
  return px;
}

/// A zlib stream inflated (the strip's predicted samples).
std::string inflate_all(const std::string& z) {
  std::string out(z.size() * 1100 + 64, '\0');
  uLongf n = static_cast<uLongf>(out.size());
  EXPECT_EQ(uncompress(reinterpret_cast<Bytef*>(out.data()), &n, reinterpret_cast<const Bytef*>(z.data()),
                       static_cast<uLong>(z.size())),
            Z_OK);
  out.resize(n);
  return out;
}

/// The strips libtiff itself writes when each strip is one write call: a w×h TIFF of 32-row
/// strips, deflate, no predictor, given `raw` (already predicted samples, one string per strip).
std::vector<std::string> libtiff_whole_strips(const std::string& path, int w, int h, int c, int bits,
                                              const std::vector<std::string>& raw) {
  TIFF* t = TIFFOpen(path.c_str(), "wl");
  EXPECT_TRUE(t);
  if (!t) return {};
  TIFFSetField(t, TIFFTAG_IMAGEWIDTH, static_cast<std::uint32_t>(w));
  TIFFSetField(t, TIFFTAG_IMAGELENGTH, static_cast<std::uint32_t>(h));
  TIFFSetField(t, TIFFTAG_SAMPLESPERPIXEL, static_cast<std::uint16_t>(c));
  TIFFSetField(t, TIFFTAG_BITSPERSAMPLE, static_cast<std::uint16_t>(bits));
  TIFFSetField(t, TIFFTAG_PHOTOMETRIC, c >= 3 ? PHOTOMETRIC_RGB : PHOTOMETRIC_MINISBLACK);
  TIFFSetField(t, TIFFTAG_COMPRESSION, COMPRESSION_ADOBE_DEFLATE);
  TIFFSetField(t, TIFFTAG_ROWSPERSTRIP, 32u);
  for (std::size_t s = 0; s < raw.size(); ++s)
    EXPECT_GE(TIFFWriteEncodedStrip(t, static_cast<std::uint32_t>(s), const_cast<char*>(raw[s].data()),
                                    static_cast<tmsize_t>(raw[s].size())),
              0);
  TIFFClose(t);
  return parse(path).strips;
}

}  // namespace

TEST(TiffDirect, EqualsOpenImageIOsFileTagForTagAndLibtiffsStripForStrip) {
  ScratchDir dir;
  struct Size {
    int w, h;
  };
  // 333×545: OpenImageIO's vector conversion (the rule); 18 strips, the last one a single row (libdeflate).
  // 7×3 and 5×33: one strip, and two with a one-row last strip.
  for (const Size sz : {Size{333, 545}, Size{7, 3}, Size{5, 33}})
    for (int c : {1, 3, 4})
      for (int bits : {8, 16, 32})
        for (bool srgb : {false, true}) {
          if (srgb && (c == 1 || bits == 32)) continue;  // grey and float files are linear
          SCOPED_TRACE(std::to_string(sz.w) + "x" + std::to_string(sz.h) + " c" + std::to_string(c) + " " +
                       std::to_string(bits) + " bits" + (srgb ? " sRGB" : ""));
          const std::vector<float> v = boundary_samples(sz.w, sz.h, c, sz.w + c + bits);
          io::tiff::write(dir / "d.tif", "d.tif", io::tiff::Layout{sz.w, sz.h, c, bits, srgb}, v.data());
          write_oiio(dir / "o.tif", sz.w, sz.h, c, bits, srgb, v);
          const Tiff d = parse(dir / "d.tif"), o = parse(dir / "o.tif");
          EXPECT_EQ(d.next_ifd, 0u);
          const bool same_rule = bits == 32 || sz.w * sz.h >= 333 * 545;  // same samples as OpenImageIO's
          for (const auto& [tag, t] : o.tags) {
            ASSERT_TRUE(d.tags.count(tag)) << "tag " << tag << " missing";
            if (tag == 273 || tag == 279 || tag == 34665) {  // offsets; sizes (another deflate)
              EXPECT_EQ(d.tags.at(tag).count, t.count) << "tag " << tag;
              EXPECT_EQ(d.tags.at(tag).type, t.type) << "tag " << tag;
            } else if (tag == 306) {
              EXPECT_EQ(d.tags.at(tag).value.size(), 20u);
            } else {
              EXPECT_TRUE(d.tags.at(tag) == t) << "tag " << tag;
            }
          }
          EXPECT_EQ(d.tags.size(), o.tags.size());
          EXPECT_EQ(d.exif.size(), o.exif.size());
          for (const auto& [tag, t] : o.exif)
            EXPECT_TRUE(d.exif.count(tag) && d.exif.at(tag) == t) << "EXIF tag " << tag;
          ASSERT_EQ(d.strips.size(), o.strips.size());
          if (same_rule) {
            // The same predicted samples as OpenImageIO's strips, deflated as libtiff deflates
            // a strip handed over in one call.
            std::vector<std::string> raw;
            for (std::size_t s = 0; s < o.strips.size(); ++s) {
              raw.push_back(inflate_all(o.strips[s]));
              EXPECT_TRUE(inflate_all(d.strips[s]) == raw.back()) << "samples of strip " << s;
            }
            const std::vector<std::string> lt = libtiff_whole_strips(dir / "l.tif", sz.w, sz.h, c, bits, raw);
            ASSERT_EQ(lt.size(), d.strips.size());
            for (std::size_t s = 0; s < d.strips.size(); ++s) EXPECT_TRUE(d.strips[s] == lt[s]) << "strip " << s;
            EXPECT_EQ(bit_differences(read_floats(dir / "d.tif"), read_floats(dir / "o.tif")), 0u);
          } else {
            EXPECT_EQ(read_as_long(dir / "d.tif", bits), quantise_rule(v, bits));
          }
        }
}

// write_image sends .tif here for 1, 3 and 4 channels; other counts still go to
// OpenImageIO; a write error names the file on one line; OpenImageIO reads what dofkit
// wrote as sRGB / linear and straight alpha.
TEST(TiffDirect, WriteImageUsesItAndErrorsNameTheFile) {
  ScratchDir dir;
  Image img(9, 40, 4, 0.25f);
  io::write_image(dir / "w.tif", img);
  const Tiff t = parse(dir / "w.tif");
  EXPECT_EQ(t.strips.size(), 2u);
  EXPECT_EQ(t.exif.count(40961), 1u);
  {
    auto in = OIIO::ImageInput::open(dir / "w.tif");
    ASSERT_TRUE(in);
    EXPECT_EQ(in->spec().get_string_attribute("oiio:ColorSpace"), "sRGB");
    EXPECT_EQ(in->spec().get_int_attribute("tiff:UnassociatedAlpha"), 1);
    EXPECT_EQ(in->spec().alpha_channel, 3);
  }
  Image two(6, 5, 2, 0.5f);
  io::WriteOptions opt;
  opt.bits = 32;
  io::write_image(dir / "two.tif", two, opt);  // OpenImageIO's
  EXPECT_EQ(read_floats(dir / "two.tif").size(), 6u * 5u * 2u);
  const std::string m = bad_input_message([&] {
    io::tiff::write(dir / "no/such/dir/x.tif", "shown.tif", io::tiff::Layout{9, 5, 4, 8, true},
                    std::vector<float>(180).data());
  });
  EXPECT_NE(m.find("shown.tif"), std::string::npos) << m;
  EXPECT_FALSE(io::tiff::writes(2, 8));
  EXPECT_FALSE(io::tiff::writes(4, 12));
}
