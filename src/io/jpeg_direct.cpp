// JPEG reader and writer on libjpeg (see jpeg_direct.hpp).
//
// libjpeg reports a fatal error by calling error_exit, which must not return: here it
// longjmps back to the function that set the jump (the libjpeg convention; everything with a
// destructor is created before setjmp, and nothing the error path uses is changed after it).
// Warnings (corrupt data that libjpeg decodes anyway) are counted, not printed; the first
// message (error or warning) is kept for the caller's one-line error.
#include "io/jpeg_direct.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cerrno>
#include <csetjmp>
#include <cstdio>
#include <cstring>

extern "C" {
#include <jpeglib.h>
}

#include "dofkit/error.hpp"
#include "io/quantise.hpp"

namespace dofkit::io::jpeg {

namespace {

struct ErrorManager {
  jpeg_error_mgr pub;
  std::jmp_buf jump;
  char message[JMSG_LENGTH_MAX];
};

extern "C" void on_error(j_common_ptr cinfo) {
  auto* e = reinterpret_cast<ErrorManager*>(cinfo->err);
  (*cinfo->err->format_message)(cinfo, e->message);
  std::longjmp(e->jump, 1);
}

// Warnings: counted in num_warnings by libjpeg; the first one's text kept (nothing printed).
extern "C" void on_output_message(j_common_ptr cinfo) {
  auto* e = reinterpret_cast<ErrorManager*>(cinfo->err);
  if (e->message[0] == 0) (*cinfo->err->format_message)(cinfo, e->message);
}

void install(ErrorManager& e) {
  jpeg_std_error(&e.pub);
  e.pub.error_exit = on_error;
  e.pub.output_message = on_output_message;
  e.message[0] = 0;
}

// What open() accepts: 8-bit samples, one grey or three YCbCr / RGB components.
bool supported(const jpeg_decompress_struct& c) {
  if (c.data_precision != 8) return false;
  if (c.num_components == 1) return c.jpeg_color_space == JCS_GRAYSCALE;
  return c.num_components == 3 && (c.jpeg_color_space == JCS_YCbCr || c.jpeg_color_space == JCS_RGB);
}

struct Header {
  int width = 0, height = 0, components = 0;
  bool operator==(const Header&) const = default;
};

// The one place that sets libjpeg's jump. Reads the header of `path` into `got`; with
// `samples`, also decodes every sample into it (W·H·C, RGB or grey) provided the header is
// still `expect`. False on a file this reader does not take and on any libjpeg error or
// warning (corrupt data that libjpeg would decode anyway); `damage` then receives libjpeg's
// first message, if there was one (empty: a file of another kind).
bool decode(const std::string& path, Header& got, std::string& damage, JSAMPLE* samples = nullptr,
            const Header* expect = nullptr) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) return false;
  jpeg_decompress_struct cinfo;
  ErrorManager err;
  install(err);
  cinfo.err = &err.pub;
  if (setjmp(err.jump)) {
    damage = err.message;
    jpeg_destroy_decompress(&cinfo);
    std::fclose(f);
    return false;
  }
  jpeg_create_decompress(&cinfo);
  jpeg_stdio_src(&cinfo, f);
  bool ok = jpeg_read_header(&cinfo, TRUE) == JPEG_HEADER_OK && supported(cinfo) && cinfo.image_width > 0 &&
            cinfo.image_height > 0;
  got = {static_cast<int>(cinfo.image_width), static_cast<int>(cinfo.image_height), cinfo.num_components};
  if (ok && samples) {
    ok = expect && got == *expect;
    if (ok) {
      cinfo.out_color_space = got.components == 1 ? JCS_GRAYSCALE : JCS_RGB;  // libjpeg's defaults otherwise
      jpeg_start_decompress(&cinfo);
      ok = static_cast<int>(cinfo.output_width) == got.width && static_cast<int>(cinfo.output_height) == got.height &&
           cinfo.output_components == got.components;
      const std::size_t row_samples = static_cast<std::size_t>(got.width) * got.components;
      while (ok && cinfo.output_scanline < cinfo.output_height) {
        JSAMPROW row = samples + static_cast<std::size_t>(cinfo.output_scanline) * row_samples;
        if (jpeg_read_scanlines(&cinfo, &row, 1) != 1) ok = false;
      }
      if (ok) jpeg_finish_decompress(&cinfo);
    }
  }
  if (err.pub.num_warnings != 0) {
    ok = false;
    damage = err.message[0] ? err.message : "libjpeg warned about corrupt data";
  }
  jpeg_destroy_decompress(&cinfo);
  std::fclose(f);
  return ok;
}

}  // namespace

std::unique_ptr<Reader> Reader::open(const std::string& path, std::string* broken) {
  unsigned char magic[3] = {0, 0, 0};
  if (std::FILE* f = std::fopen(path.c_str(), "rb")) {
    const std::size_t got = std::fread(magic, 1, 3, f);
    std::fclose(f);
    if (got != 3) return nullptr;
  }
  if (magic[0] != 0xff || magic[1] != 0xd8 || magic[2] != 0xff) return nullptr;  // no JPEG start of image
  Header h;
  std::string damage;
  if (!decode(path, h, damage)) {
    if (broken && !damage.empty()) *broken = "libjpeg: " + damage;
    return nullptr;
  }
  std::unique_ptr<Reader> r(new Reader());
  r->path_ = path;
  r->width_ = h.width;
  r->height_ = h.height;
  r->names_ = h.components == 1 ? std::vector<std::string>{"Y"} : std::vector<std::string>{"R", "G", "B"};
  return r;
}

bool Reader::read(int cb, int ce, float* out, std::string* broken) const {
  const int C = static_cast<int>(names_.size());
  if (cb < 0 || ce > C || cb >= ce) return false;
  const std::size_t W = static_cast<std::size_t>(width_), H = static_cast<std::size_t>(height_);
  std::vector<JSAMPLE> samples(W * H * C);
  const Header expect{width_, height_, C};
  Header got;
  std::string damage;
  if (!decode(path_, got, damage, samples.data(), &expect)) {
    if (broken) *broken = damage.empty() ? std::string("the file changed while it was read") : "libjpeg: " + damage;
    return false;
  }
  const int n = ce - cb;
  const float scale = 1.0f / 255.0f;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, H), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t y = r.begin(); y < r.end(); ++y) {
      const JSAMPLE* s = samples.data() + y * W * C + cb;
      float* o = out + y * W * n;
      for (std::size_t x = 0; x < W; ++x)
        for (int c = 0; c < n; ++c) o[x * n + c] = static_cast<float>(s[x * C + c]) * scale;
    }
  });
  return true;
}

void write(const std::string& file, const std::string& display_path, int width, int height, int channels,
           const float* pixels, int quality) {
  if (width <= 0 || height <= 0 || (channels != 1 && channels != 3) || !pixels || quality < 1 || quality > 100 ||
      width > JPEG_MAX_DIMENSION || height > JPEG_MAX_DIMENSION)
    throw_internal(display_path + ": JPEG layout not written here");
  const std::size_t W = static_cast<std::size_t>(width), H = static_cast<std::size_t>(height);
  std::vector<JSAMPLE> samples(W * H * channels);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, H), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t i = r.begin() * W * channels; i < r.end() * W * channels; ++i)
      samples[i] = static_cast<JSAMPLE>(quantise(pixels[i], 255.0f));
  });

  errno = 0;
  std::FILE* f = std::fopen(file.c_str(), "wb");
  if (!f)
    throw_bad_input(display_path + ": cannot write: cannot create the file" +
                    (errno ? std::string(": ") + std::strerror(errno) : ""));
  jpeg_compress_struct cinfo;
  ErrorManager err;
  install(err);
  cinfo.err = &err.pub;
  if (setjmp(err.jump)) {
    jpeg_destroy_compress(&cinfo);
    std::fclose(f);
    throw_bad_input(display_path + ": cannot write: " + err.message);
  }
  jpeg_create_compress(&cinfo);
  jpeg_stdio_dest(&cinfo, f);
  cinfo.image_width = static_cast<JDIMENSION>(width);
  cinfo.image_height = static_cast<JDIMENSION>(height);
  cinfo.input_components = channels;
  cinfo.in_color_space = channels == 1 ? JCS_GRAYSCALE : JCS_RGB;
  jpeg_set_defaults(&cinfo);                // JFIF, 4:2:0 chroma, accurate integer DCT, Huffman tables
  jpeg_set_quality(&cinfo, quality, TRUE);  // baseline-limited quantisation tables
  jpeg_start_compress(&cinfo, TRUE);
  while (cinfo.next_scanline < cinfo.image_height) {
    JSAMPROW row = samples.data() + static_cast<std::size_t>(cinfo.next_scanline) * W * channels;
    jpeg_write_scanlines(&cinfo, &row, 1);
  }
  jpeg_finish_compress(&cinfo);  // flushes through jpeg_stdio_dest (a short write is an error)
  jpeg_destroy_compress(&cinfo);
  const bool flushed = std::fflush(f) == 0 && !std::ferror(f);
  const bool closed = std::fclose(f) == 0;
  if (!flushed || !closed)
    throw_bad_input(display_path + ": cannot write: " + (errno ? std::strerror(errno) : "close failed"));
}

}  // namespace dofkit::io::jpeg
