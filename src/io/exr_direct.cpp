// Scanline EXR writer and reader (see exr_direct.hpp).
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
#include <atomic>
#include <cctype>
#include <cstdint>
#include <cstring>
#include <memory>
#include <string_view>

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

// Inverse of reorder_and_delta: undo the deltas in place in `coded`, then interleave the
// halves into `out`.
void undelta_and_interleave(std::uint8_t* coded, std::size_t n, std::uint8_t* out) {
  for (std::size_t k = 1; k < n; ++k) coded[k] = static_cast<std::uint8_t>(coded[k - 1] + coded[k] - 128);
  const std::uint8_t* lo = coded;
  const std::uint8_t* hi = coded + (n + 1) / 2;
  std::size_t i = 0;
  for (; i + 1 < n; i += 2) {
    out[i] = *lo++;
    out[i + 1] = *hi++;
  }
  if (i < n) out[i] = *lo;
}

struct DecompressorDeleter {
  void operator()(libdeflate_decompressor* d) const { libdeflate_free_decompressor(d); }
};

bool iequals(std::string_view a, std::string_view b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
           return std::tolower(static_cast<unsigned char>(x)) == std::tolower(static_cast<unsigned char>(y));
         });
}

// OpenImageIO's presentation order of EXR channels: by layer (the name up to its last '.'),
// then the well-known suffixes in this order, then the others by name.
struct PresentedName {
  std::string_view layer, suffix;
  int special = 10000;
  int file_index = 0;
  explicit PresentedName(std::string_view full, int index) : file_index(index) {
    const std::size_t dot = full.find_last_of('.');
    if (dot == std::string_view::npos) {
      suffix = full;
    } else {
      layer = full.substr(0, dot + 1);
      suffix = full.substr(dot + 1);
    }
    static constexpr const char* kSpecial[] = {"R",    "Red",  "G",  "Green", "B",     "Blue", "Y",
                                               "real", "imag", "A",  "Alpha", "AR",    "RA",   "AG",
                                               "GA",   "AB",   "BA", "Z",     "Depth", "Zback"};
    for (int i = 0; i < static_cast<int>(std::size(kSpecial)); ++i)
      if (iequals(suffix, kSpecial[i])) {
        special = i;
        break;
      }
  }
  bool operator<(const PresentedName& o) const {
    if (layer != o.layer) return layer < o.layer;
    if (special != o.special) return special < o.special;
    return suffix < o.suffix;
  }
};

}  // namespace

bool writes_compression(const std::string& compression) {
  return compression.empty() || compression == "none" || compression == "zip" || compression == "zips";
}

void write_scanline(const std::string& file, const std::string& display_path, int width, int height,
                    const std::vector<OutChannel>& channels_in, bool half, const std::string& compression) {
  if (!writes_compression(compression))
    throw_internal(display_path + ": EXR compression " + compression + " not handled here");
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
  // (An exception in a task reaches this caller: TBB rethrows it from parallel_for.)
  std::vector<std::vector<std::uint8_t>> chunks(nchunks);
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
      if (!s.compressor) throw_internal(display_path + ": cannot allocate a deflate compressor");
      out.resize(libdeflate_zlib_compress_bound(s.compressor.get(), bytes));
      const std::size_t packed =
          libdeflate_zlib_compress(s.compressor.get(), s.coded.data(), bytes, out.data(), out.size());
      if (packed == 0 || packed >= bytes) {
        out.assign(s.raw.begin(), s.raw.end());  // incompressible: stored raw
      } else {
        out.resize(packed);
      }
    }
  });

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

// --- reading ------------------------------------------------------------------------------

struct ScanlineReader::Impl {
  exr_context_t ctxt = nullptr;
  struct Channel {
    bool half = false;
    std::size_t offset = 0;  // byte offset of this channel's samples within a stored row
  };
  std::vector<Channel> file_channels;  // in file (sorted) order
  std::vector<int> presented_to_file;  // presentation index → file index
  std::size_t row_bytes = 0;
  int min_y = 0, lines = 1, chunks = 0;
  exr_compression_t compression = EXR_COMPRESSION_NONE;
  ~Impl() {
    if (ctxt) exr_finish(&ctxt);
  }
};

ScanlineReader::~ScanlineReader() = default;

std::unique_ptr<ScanlineReader> ScanlineReader::open(const std::string& path) {
  exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
  init.error_handler_fn = &capture_error;
  init.flags |= EXR_CONTEXT_FLAG_SILENT_HEADER_PARSE;
  auto impl = std::make_unique<Impl>();
  if (exr_start_read(&impl->ctxt, path.c_str(), &init) != EXR_ERR_SUCCESS) {
    impl->ctxt = nullptr;
    return nullptr;
  }
  exr_context_t c = impl->ctxt;
  int parts = 0;
  exr_storage_t storage{};
  const exr_attr_chlist_t* chlist = nullptr;
  exr_attr_box2i_t dw{};
  int32_t lines = 0, chunks = 0;
  if (exr_get_count(c, &parts) != EXR_ERR_SUCCESS || parts != 1) return nullptr;
  if (exr_get_storage(c, 0, &storage) != EXR_ERR_SUCCESS || storage != EXR_STORAGE_SCANLINE) return nullptr;
  if (exr_get_compression(c, 0, &impl->compression) != EXR_ERR_SUCCESS) return nullptr;
  if (impl->compression != EXR_COMPRESSION_NONE && impl->compression != EXR_COMPRESSION_ZIPS &&
      impl->compression != EXR_COMPRESSION_ZIP)
    return nullptr;
  if (exr_get_channels(c, 0, &chlist) != EXR_ERR_SUCCESS || !chlist || chlist->num_channels <= 0) return nullptr;
  if (exr_get_data_window(c, 0, &dw) != EXR_ERR_SUCCESS) return nullptr;
  if (exr_get_scanlines_per_chunk(c, 0, &lines) != EXR_ERR_SUCCESS || lines <= 0) return nullptr;
  if (exr_get_chunk_count(c, 0, &chunks) != EXR_ERR_SUCCESS || chunks <= 0) return nullptr;
  const long long w = static_cast<long long>(dw.max.x) - dw.min.x + 1;
  const long long h = static_cast<long long>(dw.max.y) - dw.min.y + 1;
  if (w <= 0 || h <= 0 || w > (1LL << 30) || h > (1LL << 30)) return nullptr;
  if (static_cast<long long>(chunks) != (h + lines - 1) / lines) return nullptr;

  std::unique_ptr<ScanlineReader> r(new ScanlineReader());
  r->width_ = static_cast<int>(w);
  r->height_ = static_cast<int>(h);
  impl->min_y = dw.min.y;
  impl->lines = lines;
  impl->chunks = chunks;
  std::vector<PresentedName> order;
  std::vector<std::string> file_names;
  for (int i = 0; i < chlist->num_channels; ++i) {
    const exr_attr_chlist_entry_t& e = chlist->entries[i];
    if (e.x_sampling != 1 || e.y_sampling != 1) return nullptr;
    if (e.pixel_type != EXR_PIXEL_HALF && e.pixel_type != EXR_PIXEL_FLOAT) return nullptr;
    if (!e.name.str || e.name.length <= 0) return nullptr;
    file_names.emplace_back(e.name.str, static_cast<std::size_t>(e.name.length));
    const bool half = e.pixel_type == EXR_PIXEL_HALF;
    impl->file_channels.push_back({half, impl->row_bytes});
    impl->row_bytes += static_cast<std::size_t>(w) * (half ? 2 : 4);
  }
  for (int i = 0; i < chlist->num_channels; ++i) order.emplace_back(file_names[i], i);
  std::sort(order.begin(), order.end());
  for (const PresentedName& p : order) {
    const int k = static_cast<int>(r->names_.size());
    r->names_.push_back(file_names[p.file_index]);
    impl->presented_to_file.push_back(p.file_index);
    if (r->alpha_ < 0 && (iequals(p.suffix, "A") || iequals(p.suffix, "Alpha"))) r->alpha_ = k;
    if (r->z_ < 0 && (iequals(p.suffix, "Z") || iequals(p.suffix, "Depth"))) r->z_ = k;
  }
  r->impl_ = std::move(impl);
  return r;
}

bool ScanlineReader::read(int cb, int ce, float* out) const {
  if (cb < 0 || ce > static_cast<int>(names_.size()) || cb >= ce) return false;
  std::vector<int> channels;
  std::vector<float*> bases;
  for (int c = cb; c < ce; ++c) {
    channels.push_back(c);
    bases.push_back(out + (c - cb));
  }
  return read_strided(channels, bases, static_cast<std::size_t>(ce - cb));
}

bool ScanlineReader::read_planes(const std::vector<int>& channels, const std::vector<float*>& planes) const {
  if (channels.size() != planes.size() || channels.empty()) return false;
  for (int c : channels)
    if (c < 0 || c >= static_cast<int>(names_.size())) return false;
  return read_strided(channels, planes, 1);
}

bool ScanlineReader::read_strided(const std::vector<int>& channels, const std::vector<float*>& bases,
                                  std::size_t stride) const {
  const Impl& m = *impl_;
  const std::size_t W = static_cast<std::size_t>(width_);
  std::atomic<bool> ok{true};
  struct Buffers {
    std::vector<std::uint8_t> packed, coded, raw;
    std::unique_ptr<libdeflate_decompressor, DecompressorDeleter> inflater;
  };
  tbb::enumerable_thread_specific<Buffers> buffers;
  tbb::parallel_for(tbb::blocked_range<int>(0, m.chunks), [&](const tbb::blocked_range<int>& range) {
    Buffers& b = buffers.local();
    for (int k = range.begin(); k < range.end() && ok.load(std::memory_order_relaxed); ++k) {
      const int row0 = k * m.lines;  // first row of the chunk, counted from the data window's top
      const int n = std::min(m.lines, height_ - row0);
      const std::size_t expected = m.row_bytes * static_cast<std::size_t>(n);
      exr_chunk_info_t ci{};
      if (exr_read_scanline_chunk_info(m.ctxt, 0, m.min_y + row0, &ci) != EXR_ERR_SUCCESS ||
          ci.start_y != m.min_y + row0 || ci.height != n || ci.packed_size == 0 || ci.packed_size > expected) {
        ok = false;
        return;
      }
      b.packed.resize(ci.packed_size);
      if (exr_read_chunk(m.ctxt, 0, &ci, b.packed.data()) != EXR_ERR_SUCCESS) {
        ok = false;
        return;
      }
      const std::uint8_t* raw = b.packed.data();
      if (ci.packed_size != expected) {
        if (m.compression == EXR_COMPRESSION_NONE) {
          ok = false;
          return;
        }
        if (!b.inflater) b.inflater.reset(libdeflate_alloc_decompressor());
        b.coded.resize(expected);
        b.raw.resize(expected);
        std::size_t got = 0;
        if (!b.inflater ||
            libdeflate_zlib_decompress(b.inflater.get(), b.packed.data(), ci.packed_size, b.coded.data(), expected,
                                       &got) != LIBDEFLATE_SUCCESS ||
            got != expected) {
          ok = false;
          return;
        }
        undelta_and_interleave(b.coded.data(), expected, b.raw.data());
        raw = b.raw.data();
      }
      for (int j = 0; j < n; ++j) {
        const std::uint8_t* row = raw + m.row_bytes * j;
        const std::size_t first = static_cast<std::size_t>(row0 + j) * W * stride;
        for (std::size_t k = 0; k < channels.size(); ++k) {
          const Impl::Channel& ch = m.file_channels[m.presented_to_file[channels[k]]];
          const std::uint8_t* src = row + ch.offset;
          float* o = bases[k] + first;
          if (ch.half) {
            for (std::size_t x = 0; x < W; ++x) {
              std::uint16_t bits;
              std::memcpy(&bits, src + 2 * x, 2);
              Imath::half hv;
              hv.setBits(bits);
              o[x * stride] = static_cast<float>(hv);
            }
          } else if (stride == 1) {
            std::memcpy(o, src, 4 * W);
          } else {
            for (std::size_t x = 0; x < W; ++x) std::memcpy(o + x * stride, src + 4 * x, 4);
          }
        }
      }
    }
  });
  return ok.load();
}

}  // namespace dofkit::io::exr
