// Scanline EXR writer (see exr_direct.hpp).
//
// A scanline chunk holds `lines` rows (1 for none / zips, 16 for zip); within it, row by row,
// each channel's W samples in the header's channel order, little-endian. ZIP / ZIPS chunks
// are that block with its bytes split into even and odd positions (two halves), then
// delta-coded (d = b[i] − b[i−1] + 128, mod 256), then zlib-compressed; a chunk that does not
// shrink is stored raw, which readers recognise by its size (OpenEXR's rule).
#include "io/exr_direct.hpp"

#include <OpenEXR/openexr.h>
#include <libdeflate.h>
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <Imath/half.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <memory>

#include "dofkit/error.hpp"

namespace dofkit::io::exr {

namespace {

// OpenEXR's default zip level (3.1's exr_get_default_zip_compression_level): libdeflate at 4
// writes files within 0.3 % of zlib's level 6 on float frames, ~2× faster.
constexpr int kZipLevel = 4;

thread_local std::string t_last_error;

void capture_error(exr_const_context_t, exr_result_t code, const char* msg) {
  t_last_error = msg ? msg : exr_get_error_code_as_string(code);
}

struct ContextCloser {
  exr_context_t ctxt = nullptr;
  ~ContextCloser() {
    if (ctxt) exr_finish(&ctxt);
  }
};

struct CompressorDeleter {
  void operator()(libdeflate_compressor* c) const { libdeflate_free_compressor(c); }
};

// Per-thread scratch: the raw block, its reordered/delta-coded copy and a compressor.
struct Scratch {
  std::vector<std::uint8_t> raw, coded;
  std::unique_ptr<libdeflate_compressor, CompressorDeleter> compressor;
};

// Packs rows [y0, y0 + n) into `out`, channels in the given (sorted) order.
void pack_rows(const std::vector<OutChannel>& ch, int width, int y0, int n, bool half, std::uint8_t* out) {
  const std::size_t W = static_cast<std::size_t>(width);
  for (int y = y0; y < y0 + n; ++y) {
    for (const OutChannel& c : ch) {
      const float* src = c.data + static_cast<std::size_t>(y) * W;
      if (half) {
        for (std::size_t x = 0; x < W; ++x) {
          const std::uint16_t bits = Imath::half(src[x]).bits();
          std::memcpy(out + 2 * x, &bits, 2);  // little-endian host (x86-64 / arm64)
        }
        out += 2 * W;
      } else {
        std::memcpy(out, src, 4 * W);
        out += 4 * W;
      }
    }
  }
}

// OpenEXR's ZIP pre-pass: even bytes to the first half, odd to the second, then deltas.
void reorder_and_delta(const std::uint8_t* in, std::size_t n, std::uint8_t* out) {
  std::uint8_t* lo = out;
  std::uint8_t* hi = out + (n + 1) / 2;
  std::size_t i = 0;
  for (; i + 1 < n; i += 2) {
    *lo++ = in[i];
    *hi++ = in[i + 1];
  }
  if (i < n) *lo++ = in[i];
  std::uint8_t prev = out[0];
  for (std::size_t k = 1; k < n; ++k) {
    const std::uint8_t cur = out[k];
    out[k] = static_cast<std::uint8_t>(cur - prev + 128);
    prev = cur;
  }
}

}  // namespace

bool writes_compression(const std::string& compression) {
  return compression.empty() || compression == "none" || compression == "zip" || compression == "zips";
}

void write_scanline(const std::string& file, const std::string& display_path, int width, int height,
                    const std::vector<OutChannel>& channels_in, bool half, const std::string& compression) {
  if (!writes_compression(compression)) throw_internal(display_path + ": EXR compression " + compression + " not handled here");
  if (width <= 0 || height <= 0 || channels_in.empty()) throw_internal(display_path + ": nothing to write");
  const auto fail = [&](const char* what, exr_result_t rc) {
    std::string m = t_last_error.empty() ? exr_get_error_code_as_string(rc) : t_last_error;
    std::replace(m.begin(), m.end(), '\n', ' ');
    throw_bad_input(display_path + ": cannot write: " + what + ": " + m);
  };

  std::vector<OutChannel> ch = channels_in;
  std::sort(ch.begin(), ch.end(), [](const OutChannel& a, const OutChannel& b) { return a.name < b.name; });
  for (std::size_t i = 1; i < ch.size(); ++i)
    if (ch[i].name == ch[i - 1].name) throw_internal(display_path + ": duplicate EXR channel " + ch[i].name);

  const exr_compression_t ctype = compression == "none"   ? EXR_COMPRESSION_NONE
                                  : compression == "zips" ? EXR_COMPRESSION_ZIPS
                                                          : EXR_COMPRESSION_ZIP;
  const int lines = ctype == EXR_COMPRESSION_ZIP ? 16 : 1;
  const int nchunks = (height + lines - 1) / lines;
  const std::size_t row_bytes = static_cast<std::size_t>(width) * ch.size() * (half ? 2 : 4);

  // Pack and compress every chunk (in parallel), then write them in order.
  std::vector<std::vector<std::uint8_t>> chunks(nchunks);
  std::vector<std::uint8_t> failed(nchunks, 0);
  tbb::enumerable_thread_specific<Scratch> scratch;
  tbb::parallel_for(tbb::blocked_range<int>(0, nchunks), [&](const tbb::blocked_range<int>& r) {
    Scratch& s = scratch.local();
    for (int k = r.begin(); k < r.end(); ++k) {
      const int y0 = k * lines;
      const int n = std::min(lines, height - y0);
      const std::size_t bytes = row_bytes * n;
      std::vector<std::uint8_t>& out = chunks[k];
      if (ctype == EXR_COMPRESSION_NONE) {
        out.resize(bytes);
        pack_rows(ch, width, y0, n, half, out.data());
        continue;
      }
      s.raw.resize(bytes);
      s.coded.resize(bytes);
      pack_rows(ch, width, y0, n, half, s.raw.data());
      reorder_and_delta(s.raw.data(), bytes, s.coded.data());
      if (!s.compressor) s.compressor.reset(libdeflate_alloc_compressor(kZipLevel));
      if (!s.compressor) {
        failed[k] = 1;
        continue;
      }
      out.resize(libdeflate_zlib_compress_bound(s.compressor.get(), bytes));
      const std::size_t packed = libdeflate_zlib_compress(s.compressor.get(), s.coded.data(), bytes, out.data(), out.size());
      if (packed == 0 || packed >= bytes) {
        out.assign(s.raw.begin(), s.raw.end());  // incompressible: stored raw
      } else {
        out.resize(packed);
      }
    }
  });
  if (std::find(failed.begin(), failed.end(), 1) != failed.end())
    throw_internal(display_path + ": cannot allocate a deflate compressor");

  t_last_error.clear();
  exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
  init.error_handler_fn = &capture_error;
  ContextCloser ctx;
  exr_result_t rc = exr_start_write(&ctx.ctxt, file.c_str(), EXR_WRITE_FILE_DIRECTLY, &init);
  if (rc != EXR_ERR_SUCCESS) {
    ctx.ctxt = nullptr;
    fail("open", rc);
  }
  int part = 0;
  if ((rc = exr_add_part(ctx.ctxt, "", EXR_STORAGE_SCANLINE, &part)) != EXR_ERR_SUCCESS) fail("header", rc);
  if ((rc = exr_initialize_required_attr_simple(ctx.ctxt, part, width, height, ctype)) != EXR_ERR_SUCCESS)
    fail("header", rc);
  for (const OutChannel& c : ch) {
    rc = exr_add_channel(ctx.ctxt, part, c.name.c_str(), half ? EXR_PIXEL_HALF : EXR_PIXEL_FLOAT,
                         EXR_PERCEPTUALLY_LOGARITHMIC,  // pLinear = 0, OpenEXR's default
                        
                         1, 1);
    if (rc != EXR_ERR_SUCCESS) fail("channel list", rc);
  }
  if ((rc = exr_write_header(ctx.ctxt)) != EXR_ERR_SUCCESS) fail("header", rc);
  for (int k = 0; k < nchunks; ++k) {
    rc = exr_write_scanline_chunk(ctx.ctxt, part, k * lines, chunks[k].data(), chunks[k].size());
    if (rc != EXR_ERR_SUCCESS) fail("pixels", rc);
    std::vector<std::uint8_t>().swap(chunks[k]);
  }
  exr_context_t done = ctx.ctxt;
  ctx.ctxt = nullptr;
  if ((rc = exr_finish(&done)) != EXR_ERR_SUCCESS) fail("close", rc);
}

}  // namespace dofkit::io::exr
