// TIFF read with libtiff directly (tiff_direct.hpp): the common layouts, as OpenImageIO reads
// them. OpenImageIO's TIFF reader is libtiff too, so the decoding is the same code; what this
// file must match is what OpenImageIO makes of the header (channel names, alpha, its
// association) and how it converts the samples to float. Files whose header asks for anything
// more (palette, CMYK, Lab / YCbCr, 1–6 / 10–14-bit, signed or half samples, separate planes,
// an image origin, texture tags) are left to OpenImageIO.
#include <tiffio.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <climits>
#include <cstdarg>
#include <cstdio>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

#include "io/tiff_direct.hpp"

namespace dofkit::io::tiff {

namespace {

// libtiff's warnings for a handle opened here are dropped, its errors kept (the first one, on
// one line) in the std::string its user data points to, if any: nothing reaches stderr.
int quiet(TIFF*, void*, const char*, const char*, va_list) { return 1; }
int keep_first(TIFF*, void* user, const char* module, const char* fmt, va_list ap) {
  auto* kept = static_cast<std::string*>(user);
  if (!kept || !kept->empty()) return 1;
  char text[512];
  std::vsnprintf(text, sizeof text, fmt, ap);
  *kept = std::string(module && *module ? module : "libtiff") + ": " + text;
  for (char& c : *kept)
    if (c == '\n' || c == '\r') c = ' ';
  return 1;
}

struct TiffCloser {
  void operator()(TIFF* t) const { TIFFClose(t); }
};
using TiffPtr = std::unique_ptr<TIFF, TiffCloser>;

TiffPtr open_quiet(const std::string& path, std::string* errors = nullptr) {
  TIFFOpenOptions* opts = TIFFOpenOptionsAlloc();
  if (!opts) return nullptr;
  TIFFOpenOptionsSetErrorHandlerExtR(opts, keep_first, errors);
  TIFFOpenOptionsSetWarningHandlerExtR(opts, quiet, nullptr);
  TiffPtr t(TIFFOpenExt(path.c_str(), "r", opts));  // the options are copied into the handle
  TIFFOpenOptionsFree(opts);
  return t;
}

bool is_tiff_magic(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  unsigned char m[4] = {};
  if (!f.read(reinterpret_cast<char*>(m), 4)) return false;
  const bool le = m[0] == 'I' && m[1] == 'I' && (m[2] == 42 || m[2] == 43) && m[3] == 0;
  const bool be = m[0] == 'M' && m[1] == 'M' && m[2] == 0 && (m[3] == 42 || m[3] == 43);
  return le || be;
}

/// What a handle opened again must show to be the file open() accepted.
struct FileLayout {
  std::uint32_t width = 0, height = 0;
  std::uint16_t spp = 0, bits = 0;
  bool tiled = false;
};

bool same_layout(TIFF* t, const FileLayout& want) {
  std::uint32_t w = 0, h = 0;
  std::uint16_t spp = 0, bits = 0;
  TIFFGetField(t, TIFFTAG_IMAGEWIDTH, &w);
  TIFFGetField(t, TIFFTAG_IMAGELENGTH, &h);
  TIFFGetFieldDefaulted(t, TIFFTAG_SAMPLESPERPIXEL, &spp);
  TIFFGetField(t, TIFFTAG_BITSPERSAMPLE, &bits);
  return w == want.width && h == want.height && spp == want.spp && bits == want.bits &&
         (TIFFIsTiled(t) != 0) == want.tiled;
}

}  // namespace

Reader::~Reader() = default;

std::unique_ptr<Reader> Reader::open(const std::string& path) {
  if (!is_tiff_magic(path)) return nullptr;
  TiffPtr t = open_quiet(path);
  if (!t) return nullptr;
  TIFF* tif = t.get();
  std::uint32_t w = 0, h = 0, depth = 1;
  std::uint16_t spp = 1, bits = 0, fmt = SAMPLEFORMAT_UINT, photometric = 0, planar = PLANARCONFIG_CONTIG;
  std::uint16_t compression = COMPRESSION_NONE;
  if (!TIFFGetField(tif, TIFFTAG_IMAGEWIDTH, &w) || !TIFFGetField(tif, TIFFTAG_IMAGELENGTH, &h)) return nullptr;
  if (w == 0 || h == 0 || w > INT_MAX || h > INT_MAX) return nullptr;
  TIFFGetFieldDefaulted(tif, TIFFTAG_IMAGEDEPTH, &depth);
  if (depth > 1) return nullptr;  // a volume: OpenImageIO reports it
  TIFFGetFieldDefaulted(tif, TIFFTAG_SAMPLESPERPIXEL, &spp);
  // OpenImageIO takes a missing BitsPerSample as 8, libtiff as 1: leave such a file to it.
  if (!TIFFGetField(tif, TIFFTAG_BITSPERSAMPLE, &bits)) return nullptr;
  TIFFGetFieldDefaulted(tif, TIFFTAG_SAMPLEFORMAT, &fmt);
  if (!((bits == 8 || bits == 16) && fmt == SAMPLEFORMAT_UINT) && !(bits == 32 && fmt == SAMPLEFORMAT_IEEEFP))
    return nullptr;
  if (!TIFFGetField(tif, TIFFTAG_PHOTOMETRIC, &photometric)) return nullptr;
  TIFFGetFieldDefaulted(tif, TIFFTAG_PLANARCONFIG, &planar);
  if (planar != PLANARCONFIG_CONTIG) return nullptr;
  TIFFGetFieldDefaulted(tif, TIFFTAG_COMPRESSION, &compression);
  // JPEG-in-TIFF goes through OpenImageIO's RGBA path for some layouts: not taken here.
  if (compression == COMPRESSION_JPEG || compression == COMPRESSION_OJPEG || !TIFFIsCODECConfigured(compression))
    return nullptr;
  // Tags that change what OpenImageIO reports (an image origin, a display window, texture
  // and shadow-map naming): left to it.
  {
    float pos = 0;
    std::uint32_t full = 0;
    char* text = nullptr;
    if (TIFFGetField(tif, TIFFTAG_XPOSITION, &pos) || TIFFGetField(tif, TIFFTAG_YPOSITION, &pos) ||
        TIFFGetField(tif, TIFFTAG_PIXAR_IMAGEFULLWIDTH, &full) ||
        TIFFGetField(tif, TIFFTAG_PIXAR_IMAGEFULLLENGTH, &full) ||
        TIFFGetField(tif, TIFFTAG_PIXAR_TEXTUREFORMAT, &text))
      return nullptr;
  }
  std::uint16_t nextra = 0;
  std::uint16_t* extra = nullptr;
  TIFFGetFieldDefaulted(tif, TIFFTAG_EXTRASAMPLES, &nextra, &extra);
  int colour = 0;
  if (photometric == PHOTOMETRIC_MINISBLACK)
    colour = 1;
  else if (photometric == PHOTOMETRIC_RGB)
    colour = 3;
  else
    return nullptr;
  if (spp != colour && spp != colour + 1) return nullptr;
  const bool alpha = spp == colour + 1;
  // Exactly the extra samples the channel count implies, and an alpha that says what it is
  // (OpenImageIO renames an "unspecified" extra channel, and guesses for a missing tag).
  if (nextra != (alpha ? 1 : 0)) return nullptr;
  if (alpha && (!extra || (extra[0] != EXTRASAMPLE_ASSOCALPHA && extra[0] != EXTRASAMPLE_UNASSALPHA))) return nullptr;

  std::unique_ptr<Reader> r(new Reader());
  r->path_ = path;
  r->width_ = static_cast<int>(w);
  r->height_ = static_cast<int>(h);
  r->channels_ = spp;
  r->bits_ = bits;
  r->alpha_ = alpha;
  r->unassociated_ = alpha && extra[0] == EXTRASAMPLE_UNASSALPHA;
  r->tiled_ = TIFFIsTiled(tif) != 0;
  if (r->tiled_) {
    std::uint32_t tw = 0, th = 0;
    if (!TIFFGetField(tif, TIFFTAG_TILEWIDTH, &tw) || !TIFFGetField(tif, TIFFTAG_TILELENGTH, &th)) return nullptr;
    if (tw == 0 || th == 0 || tw > INT_MAX || th > INT_MAX) return nullptr;
    // One tile is decoded into a buffer of its own size: a tile far larger than the image
    // (legal, but a file of a few bytes could declare 2^20 × 2^20) is left to OpenImageIO.
    const std::uint64_t px_bytes = static_cast<std::uint64_t>(spp) * bits / 8;
    const std::uint64_t tile_bytes = static_cast<std::uint64_t>(tw) * th * px_bytes;
    if (tile_bytes > std::max<std::uint64_t>(std::uint64_t{16} << 20, 4 * static_cast<std::uint64_t>(w) * h * px_bytes))
      return nullptr;
    r->block_w_ = static_cast<int>(tw);
    r->block_h_ = static_cast<int>(th);
  } else {
    std::uint32_t rps = 0;
    TIFFGetFieldDefaulted(tif, TIFFTAG_ROWSPERSTRIP, &rps);
    if (rps == 0) return nullptr;
    r->block_w_ = static_cast<int>(w);
    r->block_h_ = static_cast<int>(std::min(rps, h));
  }
  if (colour == 1)
    r->names_ = alpha ? std::vector<std::string>{"Y", "A"} : std::vector<std::string>{"Y"};
  else
    r->names_ = alpha ? std::vector<std::string>{"R", "G", "B", "A"} : std::vector<std::string>{"R", "G", "B"};
  return r;
}

namespace {

// Samples cb … cb + nc − 1 of nx pixels of `channels` samples of type T (native byte order,
// as libtiff returns them) to float: integer codes times `scale`, floats as they are.
template <typename T>
void convert_row(const unsigned char* src, float* dst, int nx, std::size_t nc, int channels, int cb, float scale) {
  for (int x = 0; x < nx; ++x)
    for (std::size_t c = 0; c < nc; ++c) {
      T q;
      std::memcpy(&q, src + (static_cast<std::size_t>(x) * channels + cb + c) * sizeof(T), sizeof(T));
      dst[static_cast<std::size_t>(x) * nc + c] = std::is_same_v<T, float> ? q : static_cast<float>(q) * scale;
    }
}

}  // namespace

bool Reader::read(int cb, int ce, float* out, std::string* broken) const {
  if (cb < 0 || ce > channels_ || cb >= ce) return false;
  const FileLayout want{static_cast<std::uint32_t>(width_), static_cast<std::uint32_t>(height_),
                        static_cast<std::uint16_t>(channels_), static_cast<std::uint16_t>(bits_), tiled_};
  const int across = tiled_ ? (width_ + block_w_ - 1) / block_w_ : 1;
  const int down = (height_ + block_h_ - 1) / block_h_;
  const long long nblocks = static_cast<long long>(across) * down;
  const std::size_t bps = static_cast<std::size_t>(bits_ / 8);
  const std::size_t block_row = static_cast<std::size_t>(block_w_) * channels_ * bps;
  const std::size_t nc = static_cast<std::size_t>(ce - cb);
  const float scale = bits_ == 8 ? 1.0f / 255.0f : 1.0f / 65535.0f;  // OpenImageIO's conversion
  // Blocks are decoded in a few fixed chunks, each with its own libtiff handle (a handle is
  // not thread-safe): both cores inflate.
  const int nchunk = static_cast<int>(std::min<long long>(nblocks, 8));
  // Per chunk: the first block libtiff could not decode (nblocks if none) and its error.
  std::vector<long long> failed(static_cast<std::size_t>(nchunk), nblocks);
  std::vector<std::string> errors(static_cast<std::size_t>(nchunk));
  std::atomic<bool> ok{true};
  tbb::parallel_for(0, nchunk, [&](int chunk) {
    std::string& error = errors[static_cast<std::size_t>(chunk)];
    TiffPtr t = open_quiet(path_, &error);
    if (!t || !same_layout(t.get(), want) ||
        (tiled_ ? TIFFNumberOfTiles(t.get()) : TIFFNumberOfStrips(t.get())) < static_cast<std::uint32_t>(nblocks)) {
      ok = false;
      return;
    }
    const tmsize_t block_bytes = tiled_ ? TIFFTileSize(t.get()) : TIFFStripSize(t.get());
    if (block_bytes <= 0 || static_cast<std::size_t>(block_bytes) < block_row * static_cast<std::size_t>(block_h_)) {
      ok = false;
      return;
    }
    std::vector<unsigned char> buf(static_cast<std::size_t>(block_bytes));
    const long long b0 = nblocks * chunk / nchunk, b1 = nblocks * (chunk + 1) / nchunk;
    for (long long b = b0; b < b1; ++b) {
      const int bx = static_cast<int>(b % across), by = static_cast<int>(b / across);
      const int x0 = bx * block_w_, y0 = by * block_h_;
      const int nx = std::min(block_w_, width_ - x0), ny = std::min(block_h_, height_ - y0);
      // A strip holds exactly its rows; a tile is always whole (padded at the edges).
      const std::size_t need = block_row * static_cast<std::size_t>(tiled_ ? block_h_ : ny);
      error.clear();
      const tmsize_t got = tiled_
                               ? TIFFReadEncodedTile(t.get(), static_cast<std::uint32_t>(b), buf.data(), block_bytes)
                               : TIFFReadEncodedStrip(t.get(), static_cast<std::uint32_t>(b), buf.data(), block_bytes);
      if (got < 0 || static_cast<std::size_t>(got) < need) {
        failed[static_cast<std::size_t>(chunk)] = b;
        if (error.empty())
          error =
              "it holds " + std::to_string(got < 0 ? 0 : got) + " of the " + std::to_string(need) + " bytes it needs";
        return;
      }
      for (int y = 0; y < ny; ++y) {
        const unsigned char* src = buf.data() + static_cast<std::size_t>(y) * block_row;
        float* dst = out + ((static_cast<std::size_t>(y0 + y) * width_ + x0) * nc);
        if (bits_ == 8)
          convert_row<std::uint8_t>(src, dst, nx, nc, channels_, cb, scale);
        else if (bits_ == 16)
          convert_row<std::uint16_t>(src, dst, nx, nc, channels_, cb, scale);
        else
          convert_row<float>(src, dst, nx, nc, channels_, cb, 1.0f);
      }
    }
  });
  if (!ok) return false;  // a handle that did not open as the first did: OpenImageIO's turn
  const auto first = std::min_element(failed.begin(), failed.end());
  if (*first == nblocks) return true;
  // libtiff cannot decode a strip / tile. OpenImageIO 2.4 would read it as zeros (or as far as
  // it decodes) without an error: refused here, with libtiff's reason.
  if (broken) {
    std::string why = errors[static_cast<std::size_t>(first - failed.begin())];
    if (why.rfind(path_ + ": ", 0) == 0) why.erase(0, path_.size() + 2);  // some codecs name the file, not themselves
    *broken = std::string(tiled_ ? "tile " : "strip ") + std::to_string(*first) + " does not decode (" + why +
              "): corrupt or truncated";
  }
  return false;
}

}  // namespace dofkit::io::tiff
