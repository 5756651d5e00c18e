// The direct JPEG reader and writer (io/jpeg_direct.hpp), checked against OpenImageIO: files
// written by it, by OpenImageIO and by libjpeg with other settings (progressive, 4:4:4, grey)
// read back bit for bit as OpenImageIO reads them; the writer's files decode to the pixels of
// OpenImageIO's at the same quality; CMYK and non-JPEG files are left to OpenImageIO, and a
// truncated or corrupt file is refused with libjpeg's message (issue 37: OpenImageIO read it
// as grey below the cut, exit 0).
#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <cmath>
#include <csetjmp>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>

extern "C" {
#include <jpeglib.h>
}

#include "dofkit/error.hpp"
#include "io/image_io.hpp"
#include "io/io_test_util.hpp"
#include "io/jpeg_direct.hpp"

using namespace dofkit;
using namespace dofkit::test;

namespace {

// A photograph-like test image in [0, 1]: smooth gradients, edges and noise.
std::vector<float> picture(int w, int h, int c, int seed) {
  std::vector<float> v(static_cast<std::size_t>(w) * h * c);
  std::uint32_t s = 12345u + seed;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int k = 0; k < c; ++k) {
        s = s * 1664525u + 1013904223u;
        float f = 0.5f + 0.4f * std::sin(0.031f * x + 0.017f * y * (k + 1));
        if ((x / 37 + y / 23) % 2) f = 0.2f + 0.1f * k;
        if (y % 29 < 3) f = static_cast<float>(s >> 8) / 16777216.0f;
        v[(static_cast<std::size_t>(y) * w + x) * c + k] = f;
      }
  return v;
}

std::vector<std::uint8_t> oiio_u8(const std::string& path, int* c = nullptr) {
  auto in = OIIO::ImageInput::open(path);
  EXPECT_TRUE(in) << path << ": " << OIIO::geterror();
  if (!in) return {};
  const OIIO::ImageSpec& s = in->spec();
  if (c) *c = s.nchannels;
  std::vector<std::uint8_t> px(static_cast<std::size_t>(s.width) * s.height * s.nchannels);
  EXPECT_TRUE(in->read_image(0, 0, 0, s.nchannels, OIIO::TypeDesc::UINT8, px.data())) << in->geterror();
  return px;
}

// libjpeg directly, for files neither writer makes: progressive, 4:4:4 chroma, CMYK.
struct JpegOptions {
  bool progressive = false;
  bool full_chroma = false;
  bool cmyk = false;
};

void libjpeg_write(const std::string& path, int w, int h, int c, const std::vector<std::uint8_t>& px, JpegOptions o) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  ASSERT_TRUE(f);
  jpeg_compress_struct cinfo;
  jpeg_error_mgr jerr;
  cinfo.err = jpeg_std_error(&jerr);
  jpeg_create_compress(&cinfo);
  jpeg_stdio_dest(&cinfo, f);
  cinfo.image_width = w;
  cinfo.image_height = h;
  cinfo.input_components = c;
  cinfo.in_color_space = c == 1 ? JCS_GRAYSCALE : c == 3 ? JCS_RGB : JCS_CMYK;
  jpeg_set_defaults(&cinfo);
  jpeg_set_quality(&cinfo, 90, TRUE);
  if (o.full_chroma)
    for (int i = 0; i < cinfo.num_components; ++i)
      cinfo.comp_info[i].h_samp_factor = cinfo.comp_info[i].v_samp_factor = 1;
  if (o.progressive) jpeg_simple_progression(&cinfo);
  jpeg_start_compress(&cinfo, TRUE);
  while (cinfo.next_scanline < cinfo.image_height) {
    JSAMPROW row = const_cast<JSAMPLE*>(px.data()) + static_cast<std::size_t>(cinfo.next_scanline) * w * c;
    jpeg_write_scanlines(&cinfo, &row, 1);
  }
  jpeg_finish_compress(&cinfo);
  jpeg_destroy_compress(&cinfo);
  std::fclose(f);
}

std::vector<std::uint8_t> to_u8(const std::vector<float>& v) {
  std::vector<std::uint8_t> u(v.size());
  for (std::size_t i = 0; i < v.size(); ++i) u[i] = static_cast<std::uint8_t>(std::lround(v[i] * 255.0f));
  return u;
}

// The reader against OpenImageIO on one file: names and every channel range, bit for bit.
void expect_reads_as_oiio(const std::string& path) {
  SCOPED_TRACE(path);
  const auto r = io::jpeg::Reader::open(path);
  ASSERT_TRUE(r);
  auto in = OIIO::ImageInput::open(path);
  ASSERT_TRUE(in);
  const OIIO::ImageSpec& s = in->spec();
  EXPECT_EQ(r->width(), s.width);
  EXPECT_EQ(r->height(), s.height);
  EXPECT_EQ(r->names(), s.channelnames);
  EXPECT_EQ(s.alpha_channel, -1);
  const int c = static_cast<int>(r->names().size());
  for (int cb = 0; cb < c; ++cb)
    for (int ce = cb + 1; ce <= c; ++ce) {
      const std::size_t n = static_cast<std::size_t>(s.width) * s.height * (ce - cb);
      std::vector<float> mine(n, -1.0f), theirs(n, -2.0f);
      ASSERT_TRUE(r->read(cb, ce, mine.data()));
      ASSERT_TRUE(in->read_image(0, 0, cb, ce, OIIO::TypeDesc::FLOAT, theirs.data()));
      std::size_t diff = 0;
      for (std::size_t i = 0; i < n; ++i) diff += bits_of(mine[i]) != bits_of(theirs[i]);
      EXPECT_EQ(diff, 0u) << "channels [" << cb << ", " << ce << ")";
    }
}

}  // namespace

// The writer's files decode to the same pixels as OpenImageIO's writer's for the same floats
// (grey and RGB, three qualities; a large image, where OpenImageIO quantises with the rule
// the writer uses: see png_write_test.cpp).
TEST(Jpeg, WriterMatchesOpenImageIOsPixels) {
  ScratchDir dir;
  const int w = 333, h = 517;
  double previous_err = 0;
  for (int c : {1, 3})
    for (int quality : {50, 95, 100}) {
      SCOPED_TRACE("c" + std::to_string(c) + " quality " + std::to_string(quality));
      const std::vector<float> v = picture(w, h, c, c + quality);
      io::jpeg::write(dir / "d.jpg", "d.jpg", w, h, c, v.data(), quality);
      OIIO::ImageSpec spec(w, h, c, OIIO::TypeDesc::UINT8);
      spec.attribute("Compression", "jpeg:" + std::to_string(quality));
      auto out = OIIO::ImageOutput::create(dir / "o.jpg");
      ASSERT_TRUE(out && out->open(dir / "o.jpg", spec) && out->write_image(OIIO::TypeDesc::FLOAT, v.data()) &&
                  out->close());
      int cd = 0, co = 0;
      const std::vector<std::uint8_t> a = oiio_u8(dir / "d.jpg", &cd), b = oiio_u8(dir / "o.jpg", &co);
      EXPECT_EQ(cd, c);
      EXPECT_EQ(co, c);
      ASSERT_EQ(a.size(), b.size());
      std::size_t diff = 0;
      for (std::size_t i = 0; i < a.size(); ++i) diff += a[i] != b[i];
      EXPECT_EQ(diff, 0u);
      // and the quality is honoured: the error against the input falls as it rises
      double err = 0;
      for (std::size_t i = 0; i < a.size(); ++i) err += std::abs(a[i] - v[i] * 255.0);
      err /= static_cast<double>(a.size());
      if (quality > 50) EXPECT_LT(err, previous_err) << "mean |error| in codes";
      previous_err = err;
    }
}

// The reader against OpenImageIO: its own files, OpenImageIO's, progressive, 4:4:4, grey,
// sizes that are not multiples of the 8×8 / 16×16 blocks.
TEST(Jpeg, ReaderEqualsOpenImageIOBitForBit) {
  ScratchDir dir;
  for (const auto& [w, h] : {std::pair{1, 1}, std::pair{17, 9}, std::pair{301, 97}})
    for (int c : {1, 3}) {
      SCOPED_TRACE(std::to_string(w) + "x" + std::to_string(h) + " c" + std::to_string(c));
      const std::vector<float> v = picture(w, h, c, w + c);
      io::jpeg::write(dir / "ours.jpg", "ours.jpg", w, h, c, v.data(), 95);
      expect_reads_as_oiio(dir / "ours.jpg");
      OIIO::ImageSpec spec(w, h, c, OIIO::TypeDesc::UINT8);
      auto out = OIIO::ImageOutput::create(dir / "oiio.jpg");
      ASSERT_TRUE(out && out->open(dir / "oiio.jpg", spec) && out->write_image(OIIO::TypeDesc::FLOAT, v.data()) &&
                  out->close());
      expect_reads_as_oiio(dir / "oiio.jpg");
      libjpeg_write(dir / "prog.jpg", w, h, c, to_u8(v), JpegOptions{true, false, false});
      expect_reads_as_oiio(dir / "prog.jpg");
      libjpeg_write(dir / "444.jpg", w, h, c, to_u8(v), JpegOptions{false, true, false});
      expect_reads_as_oiio(dir / "444.jpg");
    }
}

// CMYK (OpenImageIO converts it), non-JPEG and missing files are not taken. A truncated file
// is refused by the header walk (no end-of-image marker) before libjpeg sees it; one whose
// entropy data is damaged but complete opens (its header is whole) and is refused by read()
// with libjpeg's warning, on one line — never read as OpenImageIO read it (grey rows, exit 0).
TEST(Jpeg, TruncatedOrDamagedFilesAreRefused) {
  ScratchDir dir;
  const int w = 64, h = 48;
  libjpeg_write(dir / "cmyk.jpg", w, h, 4, to_u8(picture(w, h, 4, 1)), JpegOptions{});
  EXPECT_FALSE(io::jpeg::Reader::open(dir / "cmyk.jpg"));
  std::ofstream(dir / "not.jpg") << "GIF89a not a jpeg";
  EXPECT_FALSE(io::jpeg::Reader::open(dir / "not.jpg"));
  EXPECT_FALSE(io::jpeg::Reader::open(dir / "missing.jpg"));

  const std::vector<float> v = picture(640, 480, 3, 7);
  io::jpeg::write(dir / "whole.jpg", "whole.jpg", 640, 480, 3, v.data(), 95);
  const std::string bytes = slurp(dir / "whole.jpg");
  // Cut anywhere after the header: every one of these is refused, naming the file.
  for (std::size_t keep : {bytes.size() / 2, bytes.size() - 2, bytes.size() - 1, std::size_t{700}}) {
    std::ofstream(dir / "cut.jpg", std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(keep));
    const std::string m = bad_input_message([&] { io::read_color(dir / "cut.jpg"); });
    EXPECT_NE(m.find("cut.jpg"), std::string::npos) << m;
    EXPECT_NE(m.find("truncated"), std::string::npos) << keep << ": " << m;
  }
  // Damage inside the entropy-coded data of a complete file: libjpeg decodes it with a
  // warning ("Corrupt JPEG data: …"); read() fails and says so.
  std::string damaged = bytes;
  const std::size_t sos = damaged.find("\xff\xda");
  ASSERT_NE(sos, std::string::npos);
  for (std::size_t i = sos + 400; i < sos + 460; ++i)
    if (static_cast<unsigned char>(damaged[i]) != 0xff && static_cast<unsigned char>(damaged[i - 1]) != 0xff)
      damaged[i] = static_cast<char>(0xff), damaged[i + 1] = static_cast<char>(0xd3), ++i;  // stray restart markers
  std::ofstream(dir / "damaged.jpg", std::ios::binary)
      .write(damaged.data(), static_cast<std::streamsize>(damaged.size()));
  const auto r = io::jpeg::Reader::open(dir / "damaged.jpg");
  ASSERT_TRUE(r);
  std::vector<float> px(640 * 480 * 3);
  std::string broken;
  EXPECT_FALSE(r->read(0, 3, px.data(), &broken));
  EXPECT_NE(broken.find("libjpeg: "), std::string::npos) << broken;
  const std::string m = bad_input_message([&] { io::read_color(dir / "damaged.jpg"); });
  EXPECT_NE(m.find("damaged.jpg: cannot read colour pixels: libjpeg: "), std::string::npos) << m;
  EXPECT_EQ(m.find('\n'), std::string::npos) << m;
}

// A file that cannot be created is a one-line bad-input error naming the display path.
TEST(Jpeg, WriteErrorNamesTheFile) {
  ScratchDir dir;
  const std::vector<float> v(12, 0.5f);
  const std::string m =
      bad_input_message([&] { io::jpeg::write(dir / "no/such/dir/x.jpg", "shown.jpg", 2, 2, 3, v.data(), 95); });
  EXPECT_NE(m.find("shown.jpg"), std::string::npos) << m;
}
