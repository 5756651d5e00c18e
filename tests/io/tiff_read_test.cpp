// The direct TIFF reader (io/tiff_direct.hpp, tiff_read.cpp), checked against OpenImageIO's
// TIFF reader: files made here with libtiff in every layout the reader takes (grey, grey +
// alpha, RGB, RGBA with associated or straight alpha; 8 / 16-bit unsigned and 32-bit float;
// uncompressed, LZW, deflate, PackBits, zstd and LZMA with and without predictors; strips of
// several heights and tiles; both byte orders) must give the channel names, alpha, alpha
// association and float samples OpenImageIO gives, bit for bit; files in other layouts must be
// left to OpenImageIO; read_color / read_depth must give the same images either way; and a
// file libtiff cannot decode must be refused with libtiff's reason on one line, nothing on
// stderr (OpenImageIO 2.4 reads such a strip as zeros without an error).
#include <gtest/gtest.h>
#include <tiffio.h>

#include <cstdint>
#include <cstring>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "dofkit/error.hpp"
#include "io/image_io.hpp"
#include "io/io_test_util.hpp"
#include "io/oiio_module.hpp"
#include "io/tiff_direct.hpp"

using namespace dofkit;
using namespace dofkit::test;

namespace {

struct Make {
  int w = 37, h = 29, spp = 3, bits = 8;
  std::uint16_t fmt = SAMPLEFORMAT_UINT;
  std::uint16_t photometric = PHOTOMETRIC_RGB;
  int extra = -1;  // the ExtraSamples value of the last sample; −1: no ExtraSamples tag
  std::uint16_t compression = COMPRESSION_NONE;
  std::uint16_t predictor = PREDICTOR_NONE;
  int tile_w = 0, tile_h = 0;  // 0: strips
  int rps = 8;
  bool big_endian = false, separate = false;
  std::function<void(TIFF*)> more;  // further tags
};

std::size_t row_bytes(const Make& m, int samples_per_pixel) {
  return (static_cast<std::size_t>(m.w) * samples_per_pixel * m.bits + 7) / 8;
}

/// Samples (native byte order, rows of row_bytes(m, spp)): every code of the scale often, the
/// ends of the range, and for float HDR values, negatives, −0, ±∞, a NaN and a subnormal.
std::vector<unsigned char> samples(const Make& m, int seed) {
  std::mt19937 rng(seed);
  const std::size_t n = row_bytes(m, m.spp) * m.h;
  std::vector<unsigned char> v(n);
  if (m.bits == 32 && m.fmt == SAMPLEFORMAT_IEEEFP) {
    std::uniform_real_distribution<float> u(-0.5f, 4.0f);
    const float special[] = {0.0f,
                             -0.0f,
                             1.0f,
                             1e30f,
                             -1e-3f,
                             std::numeric_limits<float>::infinity(),
                             -std::numeric_limits<float>::infinity(),
                             std::numeric_limits<float>::quiet_NaN(),
                             std::numeric_limits<float>::denorm_min()};
    for (std::size_t i = 0; i < n / 4; ++i) {
      const float f = i % 17 < 9 ? special[i % 17] : u(rng);
      std::memcpy(&v[4 * i], &f, 4);
    }
  } else if (m.bits == 16) {
    for (std::size_t i = 0; i < n / 2; ++i) {
      const std::uint16_t q = i % 11 == 0 ? 65535 : i % 13 == 0 ? 0 : static_cast<std::uint16_t>(rng());
      std::memcpy(&v[2 * i], &q, 2);
    }
  } else {
    for (std::size_t i = 0; i < n; ++i) v[i] = static_cast<unsigned char>(i % 7 == 0 ? i : rng());
  }
  return v;
}

/// Writes `data` (pixel-interleaved rows) as the TIFF `m` describes.
void make_tiff(const std::string& path, const Make& m, const std::vector<unsigned char>& data) {
  TIFF* t = TIFFOpen(path.c_str(), m.big_endian ? "wb" : "wl");
  ASSERT_TRUE(t) << path;
  TIFFSetField(t, TIFFTAG_IMAGEWIDTH, static_cast<std::uint32_t>(m.w));
  TIFFSetField(t, TIFFTAG_IMAGELENGTH, static_cast<std::uint32_t>(m.h));
  TIFFSetField(t, TIFFTAG_SAMPLESPERPIXEL, static_cast<std::uint16_t>(m.spp));
  TIFFSetField(t, TIFFTAG_BITSPERSAMPLE, static_cast<std::uint16_t>(m.bits));
  TIFFSetField(t, TIFFTAG_SAMPLEFORMAT, m.fmt);
  TIFFSetField(t, TIFFTAG_PHOTOMETRIC, m.photometric);
  TIFFSetField(t, TIFFTAG_PLANARCONFIG, m.separate ? PLANARCONFIG_SEPARATE : PLANARCONFIG_CONTIG);
  TIFFSetField(t, TIFFTAG_COMPRESSION, m.compression);
  if (m.predictor != PREDICTOR_NONE) TIFFSetField(t, TIFFTAG_PREDICTOR, m.predictor);
  if (m.extra >= 0) {
    const std::uint16_t e = static_cast<std::uint16_t>(m.extra);
    TIFFSetField(t, TIFFTAG_EXTRASAMPLES, 1, &e);
  }
  if (m.tile_w) {
    TIFFSetField(t, TIFFTAG_TILEWIDTH, static_cast<std::uint32_t>(m.tile_w));
    TIFFSetField(t, TIFFTAG_TILELENGTH, static_cast<std::uint32_t>(m.tile_h));
  } else {
    TIFFSetField(t, TIFFTAG_ROWSPERSTRIP, static_cast<std::uint32_t>(m.rps));
  }
  if (m.more) m.more(t);
  const int planes = m.separate ? m.spp : 1, per = m.separate ? 1 : m.spp;
  const std::size_t src_row = row_bytes(m, m.spp), bps = static_cast<std::size_t>(m.bits) / 8;
  // The bytes of pixels [x0, x0 + nx) of row y of plane p (the whole pixel when contiguous).
  auto pixels = [&](int p, int y, int x0, int nx, unsigned char* dst) {
    const unsigned char* row = data.data() + static_cast<std::size_t>(y) * src_row;
    if (!m.separate) {
      const std::size_t b = static_cast<std::size_t>(x0) * m.spp * m.bits / 8;
      std::memcpy(dst, row + b, (static_cast<std::size_t>(nx) * m.spp * m.bits + 7) / 8);
      return;
    }
    for (int x = 0; x < nx; ++x)
      std::memcpy(dst + x * bps, row + (static_cast<std::size_t>(x0 + x) * m.spp + p) * bps, bps);
  };
  if (m.tile_w) {
    const int across = (m.w + m.tile_w - 1) / m.tile_w, down = (m.h + m.tile_h - 1) / m.tile_h;
    const std::size_t tile_row = static_cast<std::size_t>(m.tile_w) * per * bps;
    std::vector<unsigned char> buf(tile_row * m.tile_h);
    for (int p = 0; p < planes; ++p)
      for (int ty = 0; ty < down; ++ty)
        for (int tx = 0; tx < across; ++tx) {
          std::fill(buf.begin(), buf.end(), 0);
          const int x0 = tx * m.tile_w, nx = std::min(m.tile_w, m.w - x0);
          for (int y = 0; y < m.tile_h && ty * m.tile_h + y < m.h; ++y)
            pixels(p, ty * m.tile_h + y, x0, nx, &buf[y * tile_row]);
          const std::uint32_t index = TIFFComputeTile(t, x0, ty * m.tile_h, 0, static_cast<std::uint16_t>(p));
          ASSERT_GE(TIFFWriteEncodedTile(t, index, buf.data(), static_cast<tmsize_t>(buf.size())), 0) << path;
        }
  } else {
    const std::size_t strip_row = m.separate ? static_cast<std::size_t>(m.w) * bps : src_row;
    const int strips = (m.h + m.rps - 1) / m.rps;
    std::vector<unsigned char> buf(strip_row * m.rps);
    for (int p = 0; p < planes; ++p)
      for (int s = 0; s < strips; ++s) {
        const int ny = std::min(m.rps, m.h - s * m.rps);
        for (int y = 0; y < ny; ++y) pixels(p, s * m.rps + y, 0, m.w, &buf[y * strip_row]);
        ASSERT_GE(TIFFWriteEncodedStrip(t, static_cast<std::uint32_t>(p * strips + s), buf.data(),
                                        static_cast<tmsize_t>(strip_row * ny)),
                  0)
            << path;
      }
  }
  TIFFClose(t);
}

std::unique_ptr<io::oiio::Input> open_oiio(const std::string& path) {
  std::string error;
  auto in = io::oiio::module().open(path, /*straight_alpha=*/true, error);
  EXPECT_TRUE(in) << path << ": " << error;
  return in;
}

struct Kind {
  const char* name;
  int spp;
  std::uint16_t photometric;
  int extra;
};
const Kind kKinds[] = {{"Y", 1, PHOTOMETRIC_MINISBLACK, -1},          {"YA_assoc", 2, PHOTOMETRIC_MINISBLACK, 1},
                       {"YA_straight", 2, PHOTOMETRIC_MINISBLACK, 2}, {"RGB", 3, PHOTOMETRIC_RGB, -1},
                       {"RGBA_assoc", 4, PHOTOMETRIC_RGB, 1},         {"RGBA_straight", 4, PHOTOMETRIC_RGB, 2}};

struct Storage {
  const char* name;
  std::uint16_t compression;
  bool predictor;
  int tile_w, tile_h, rps;
  bool big_endian;
};
const Storage kStorages[] = {
    {"none_rps8", COMPRESSION_NONE, false, 0, 0, 8, false},
    {"lzw_pred_rps5", COMPRESSION_LZW, true, 0, 0, 5, false},
    {"lzw_rps1_be", COMPRESSION_LZW, false, 0, 0, 1, true},
    {"deflate_pred_tiles16", COMPRESSION_ADOBE_DEFLATE, true, 16, 16, 0, false},
    {"deflate_rps32", COMPRESSION_ADOBE_DEFLATE, false, 0, 0, 32, false},
    {"packbits_rps3", COMPRESSION_PACKBITS, false, 0, 0, 3, false},
    {"zstd_pred_one_strip_be", COMPRESSION_ZSTD, true, 0, 0, 29, true},
    {"lzma_tiles32x16", COMPRESSION_LZMA, false, 32, 16, 0, false},
    {"none_tiles16_be", COMPRESSION_NONE, false, 16, 16, 0, true},
};

Make make_of(const Kind& k, int bits, const Storage& s) {
  Make m;
  m.spp = k.spp;
  m.photometric = k.photometric;
  m.extra = k.extra;
  m.bits = bits;
  m.fmt = bits == 32 ? SAMPLEFORMAT_IEEEFP : SAMPLEFORMAT_UINT;
  m.compression = s.compression;
  if (s.predictor) m.predictor = bits == 32 ? PREDICTOR_FLOATINGPOINT : PREDICTOR_HORIZONTAL;
  m.tile_w = s.tile_w;
  m.tile_h = s.tile_h;
  m.rps = s.rps;
  m.big_endian = s.big_endian;
  return m;
}

}  // namespace

TEST(TiffRead, EqualsOpenImageIOBitForBit) {
  ScratchDir dir;
  int files = 0;
  for (const Kind& k : kKinds)
    for (int bits : {8, 16, 32})
      for (const Storage& s : kStorages) {
        if (!TIFFIsCODECConfigured(s.compression)) continue;
        const std::string name = std::string(k.name) + "_" + std::to_string(bits) + "_" + s.name;
        SCOPED_TRACE(name);
        const Make m = make_of(k, bits, s);
        const std::string path = dir / (name + ".tif");
        make_tiff(path, m, samples(m, files));
        ++files;
        const auto direct = io::tiff::Reader::open(path);
        ASSERT_TRUE(direct);
        const auto oiio = open_oiio(path);
        ASSERT_TRUE(oiio);
        const io::oiio::Spec& spec = oiio->spec();
        EXPECT_EQ(direct->width(), spec.width);
        EXPECT_EQ(direct->height(), spec.height);
        EXPECT_EQ(direct->names(), spec.channelnames);
        EXPECT_EQ(direct->alpha_channel(), spec.alpha_channel);
        EXPECT_EQ(direct->integer(), spec.integer);
        EXPECT_EQ(direct->unassociated(), spec.unassociated);
        const int n = k.spp;
        for (const auto& [cb, ce] : std::vector<std::pair<int, int>>{{0, n}, {n - 1, n}, {n > 1 ? 1 : 0, n}}) {
          const std::size_t count = static_cast<std::size_t>(m.w) * m.h * (ce - cb);
          std::vector<float> a(count, -7.0f), b(count, -9.0f);
          ASSERT_TRUE(direct->read(cb, ce, a.data()));
          ASSERT_TRUE(oiio->read(cb, ce, b.data())) << oiio->error();
          EXPECT_EQ(bit_differences(a, b), 0u) << "channels " << cb << "-" << ce;
        }
      }
  EXPECT_GE(files, 6 * 3 * 7);
}

TEST(TiffRead, LeavesOtherLayoutsToOpenImageIO) {
  ScratchDir dir;
  std::vector<std::pair<std::string, Make>> cases;
  auto add = [&](const std::string& name, const std::function<void(Make&)>& edit) {
    Make m;
    edit(m);
    cases.emplace_back(name, m);
  };
  add("separate_planes", [](Make& m) { m.separate = true; });
  add("min_is_white", [](Make& m) { m.spp = 1, m.photometric = PHOTOMETRIC_MINISWHITE; });
  add("half_float", [](Make& m) { m.bits = 16, m.fmt = SAMPLEFORMAT_IEEEFP; });
  add("uint32", [](Make& m) { m.bits = 32; });
  add("int16", [](Make& m) { m.bits = 16, m.fmt = SAMPLEFORMAT_INT; });
  add("four_bit", [](Make& m) { m.spp = 1, m.bits = 4, m.photometric = PHOTOMETRIC_MINISBLACK; });
  add("cmyk", [](Make& m) { m.spp = 4, m.photometric = PHOTOMETRIC_SEPARATED; });
  add("rgba_unspecified_extra", [](Make& m) { m.spp = 4, m.extra = EXTRASAMPLE_UNSPECIFIED; });
  add("rgb_plus_two", [](Make& m) { m.spp = 5, m.extra = 2; });
  add("jpeg", [](Make& m) { m.compression = COMPRESSION_JPEG, m.rps = 16; });
  add("x_position", [](Make& m) {
    m.more = [](TIFF* t) {
      TIFFSetField(t, TIFFTAG_XRESOLUTION, 1.0f);
      TIFFSetField(t, TIFFTAG_YRESOLUTION, 1.0f);
      TIFFSetField(t, TIFFTAG_XPOSITION, 3.0f);
    };
  });
  add("tile_far_larger_than_the_image", [](Make& m) {  // one 4096×4112 tile (16.1 MiB) for 5×4 px
    m.w = 5, m.h = 4, m.spp = 1, m.photometric = PHOTOMETRIC_MINISBLACK, m.tile_w = 4096, m.tile_h = 4112;
    m.compression = COMPRESSION_ADOBE_DEFLATE;
  });
  add("palette", [](Make& m) {
    m.spp = 1, m.photometric = PHOTOMETRIC_PALETTE;
    m.more = [](TIFF* t) {
      static std::vector<std::uint16_t> map(256);
      for (int i = 0; i < 256; ++i) map[i] = static_cast<std::uint16_t>(i * 257);
      TIFFSetField(t, TIFFTAG_COLORMAP, map.data(), map.data(), map.data());
    };
  });
  for (const auto& [name, m] : cases) {
    SCOPED_TRACE(name);
    const std::string path = dir / (name + ".tif");
    make_tiff(path, m, samples(m, 5));
    EXPECT_FALSE(io::tiff::Reader::open(path));
  }
  // Not TIFFs at all.
  write_bytes(dir / "text.tif", "this is not a TIFF file");
  EXPECT_FALSE(io::tiff::Reader::open(dir / "text.tif"));
  EXPECT_FALSE(io::tiff::Reader::open(dir / "missing.tif"));
}

TEST(TiffRead, ReadColorAndDepthEqualTheOpenImageIOPath) {
  // The same samples stored with contiguous samples (read here) and in separate planes
  // (read by OpenImageIO): read_color and read_depth give the same floats.
  ScratchDir dir;
  for (const Kind& k : kKinds)
    for (int bits : {8, 16, 32}) {
      SCOPED_TRACE(std::string(k.name) + " " + std::to_string(bits));
      Make m = make_of(k, bits, kStorages[1]);
      const std::vector<unsigned char> data = samples(m, bits + k.spp);
      const std::string direct = dir / "direct.tif", via = dir / "via_oiio.tif";
      make_tiff(direct, m, data);
      m.separate = true;
      make_tiff(via, m, data);
      ASSERT_TRUE(io::tiff::Reader::open(direct));
      ASSERT_FALSE(io::tiff::Reader::open(via));
      EXPECT_EQ(bit_differences(io::read_color(direct), io::read_color(via)), 0u) << "read_color";
      if (k.spp == 1) {
        io::DepthOptions o;
        o.kind = bits == 32 ? io::DepthKind::z : io::DepthKind::disparity;
        o.disparity_scale = 1.0;
        o.invalid_as_far = true;
        EXPECT_EQ(bit_differences(io::read_depth(direct, o), io::read_depth(via, o)), 0u) << "read_depth";
      }
    }
}

TEST(TiffRead, UndecodableDataIsRefusedWithLibtiffsReasonOnOneLine) {
  ScratchDir dir;
  // Deflate names its codec; LZW names the file, which the message then leaves out.
  for (const auto& [compression, reason] : std::vector<std::pair<std::uint16_t, std::string>>{
           {COMPRESSION_ADOBE_DEFLATE, "(ZIPDecode: "}, {COMPRESSION_LZW, "(Using code not yet in table)"}}) {
    SCOPED_TRACE(reason);
    Make m;
    m.compression = compression;
    m.rps = 29;  // one strip
    const std::string path = dir / "bad.tif";
    make_tiff(path, m, samples(m, 1));
    // Overwrite the middle of the strip's stream: the strip no longer decodes.
    std::string bytes = slurp(path);
    TIFF* t = TIFFOpen(path.c_str(), "r");
    ASSERT_TRUE(t);
    std::uint64_t* offsets = nullptr;
    std::uint64_t* counts = nullptr;
    ASSERT_TRUE(TIFFGetField(t, TIFFTAG_STRIPOFFSETS, &offsets));
    ASSERT_TRUE(TIFFGetField(t, TIFFTAG_STRIPBYTECOUNTS, &counts));
    const std::size_t at = offsets[0] + 2, n = counts[0] - 8;
    TIFFClose(t);
    for (std::size_t i = 0; i < n; ++i) bytes[at + i] = static_cast<char>(0xff ^ (i * 37));
    write_bytes(path, bytes);
    const auto direct = io::tiff::Reader::open(path);
    ASSERT_TRUE(direct);  // the header is fine
    std::vector<float> buf(static_cast<std::size_t>(m.w) * m.h * m.spp);
    testing::internal::CaptureStderr();
    std::string broken;
    EXPECT_FALSE(direct->read(0, m.spp, buf.data(), &broken));
    EXPECT_NE(broken.find("strip 0 does not decode " + reason), std::string::npos) << broken;
    const std::string message = bad_input_message([&] { io::read_color(path); });
    const std::string err = testing::internal::GetCapturedStderr();
    EXPECT_EQ(err, "");
    EXPECT_EQ(message.rfind(path + ": cannot read colour pixels: strip 0 does not decode " + reason, 0), 0u) << message;
    EXPECT_EQ(message.find(path, 1), std::string::npos) << "the file named twice: " << message;
  }
}

TEST(TiffRead, SubsampledYCbCrPassesTheHeaderWalksPayloadBound) {
  // Uncompressed YCbCr 4:2:0 stores 6 bytes per 2×2 block, half of width × height × 3: the
  // header walk's bound (stored bytes × 1 for no compression) must not refuse it. It is not
  // read here; OpenImageIO decodes it (libtiff's RGBA interface).
  ScratchDir dir;
  const std::string path = dir / "ycbcr.tif";
  TIFF* t = TIFFOpen(path.c_str(), "wl");
  ASSERT_TRUE(t);
  TIFFSetField(t, TIFFTAG_IMAGEWIDTH, 8u);
  TIFFSetField(t, TIFFTAG_IMAGELENGTH, 8u);
  TIFFSetField(t, TIFFTAG_SAMPLESPERPIXEL, static_cast<std::uint16_t>(3));
  TIFFSetField(t, TIFFTAG_BITSPERSAMPLE, static_cast<std::uint16_t>(8));
  TIFFSetField(t, TIFFTAG_PHOTOMETRIC, PHOTOMETRIC_YCBCR);
  TIFFSetField(t, TIFFTAG_PLANARCONFIG, PLANARCONFIG_CONTIG);
  TIFFSetField(t, TIFFTAG_COMPRESSION, COMPRESSION_NONE);
  TIFFSetField(t, TIFFTAG_YCBCRSUBSAMPLING, 2, 2);
  TIFFSetField(t, TIFFTAG_ROWSPERSTRIP, 8u);
  std::vector<unsigned char> blocks(16 * 6);
  for (std::size_t i = 0; i < blocks.size(); ++i)
    blocks[i] = i % 6 < 4 ? static_cast<unsigned char>(40 + 10 * i % 150) : 128;
  ASSERT_EQ(TIFFWriteRawStrip(t, 0, blocks.data(), static_cast<tmsize_t>(blocks.size())),
            static_cast<tmsize_t>(blocks.size()));
  TIFFClose(t);
  EXPECT_FALSE(io::tiff::Reader::open(path));
  Image img;
  ASSERT_NO_THROW(img = io::read_color(path));
  EXPECT_EQ(img.width(), 8);
  EXPECT_EQ(img.height(), 8);
}
