// PNG writer (see png_direct.hpp).
//
// A PNG is a signature and a list of chunks (length, type, data, CRC-32 of type + data). The
// pixels are one zlib stream, split over IDAT chunks at any byte, of the image's rows, each
// preceded by a filter-type byte: the row as bytes, or its difference from the bytes to its
// left (Sub), above (Up), their mean (Average) or the Paeth predictor of the three.
//
// Here: (1) every row is quantised to big-endian samples, (2) every row gets the filter whose
// output has the smallest sum of |signed byte| (libpng's default heuristic), (3) the filtered
// rows are cut into blocks of ~256 KiB that are deflated in parallel — each block a raw
// deflate stream primed with the 32 KiB before it (the deflate window, so matches may reach
// back across the cut) and ended with a sync flush (an empty stored block that leaves the
// stream byte-aligned and open), the last one finished — and (4) the blocks are written one
// IDAT chunk each, the first behind the zlib header, the last followed by the Adler-32 of all
// rows (combined from the blocks').
#include "io/png_direct.hpp"

#include <libdeflate.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <zlib.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "dofkit/error.hpp"
#include "io/out_file.hpp"
#include "io/quantise.hpp"

namespace dofkit::io::png {

namespace {

constexpr std::size_t kBlockBytes = 256 * 1024;  // filtered bytes per deflate task
constexpr std::size_t kWindow = 32 * 1024;       // deflate's window: the dictionary of a block
constexpr std::uint8_t kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};

void put32(std::uint8_t* p, std::uint32_t v) {
  p[0] = static_cast<std::uint8_t>(v >> 24);
  p[1] = static_cast<std::uint8_t>(v >> 16);
  p[2] = static_cast<std::uint8_t>(v >> 8);
  p[3] = static_cast<std::uint8_t>(v);
}

inline std::uint8_t paeth(int a, int b, int c) {
  const int p = a + b - c;
  const int pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
  if (pa <= pb && pa <= pc) return static_cast<std::uint8_t>(a);
  return static_cast<std::uint8_t>(pb <= pc ? b : c);
}

// Σ |byte as signed| of a filtered row (libpng's measure for choosing the filter).
inline std::uint64_t cost(const std::uint8_t* f, std::size_t n) {
  std::uint64_t s = 0;
  for (std::size_t i = 0; i < n; ++i) s += f[i] < 128 ? f[i] : 256u - f[i];
  return s;
}

// Filters row `cur` (the one above: `prev`, nullptr for the first) into out[0] (type) and
// out[1 … n]; `bpp` bytes per pixel. With `adaptive` false: filter None.
void filter_row(const std::uint8_t* cur, const std::uint8_t* prev, std::size_t n, std::size_t bpp, bool adaptive,
                std::uint8_t* out, std::array<std::vector<std::uint8_t>, 4>& scratch) {
  if (!adaptive) {
    out[0] = 0;
    std::memcpy(out + 1, cur, n);
    return;
  }
  for (auto& s : scratch) s.resize(n);
  std::uint8_t* sub = scratch[0].data();
  std::uint8_t* up = scratch[1].data();
  std::uint8_t* avg = scratch[2].data();
  std::uint8_t* pae = scratch[3].data();
  const std::size_t head = std::min(bpp, n);
  for (std::size_t i = 0; i < head; ++i) {  // no pixel to the left: a = c = 0
    const int b = prev ? prev[i] : 0;
    sub[i] = cur[i];
    up[i] = static_cast<std::uint8_t>(cur[i] - b);
    avg[i] = static_cast<std::uint8_t>(cur[i] - (b >> 1));
    pae[i] = static_cast<std::uint8_t>(cur[i] - b);  // Paeth(0, b, 0) = b
  }
  if (prev) {
    for (std::size_t i = head; i < n; ++i) {
      sub[i] = static_cast<std::uint8_t>(cur[i] - cur[i - bpp]);
      up[i] = static_cast<std::uint8_t>(cur[i] - prev[i]);
      avg[i] = static_cast<std::uint8_t>(cur[i] - ((cur[i - bpp] + prev[i]) >> 1));
      pae[i] = static_cast<std::uint8_t>(cur[i] - paeth(cur[i - bpp], prev[i], prev[i - bpp]));
    }
  } else {  // first row: b = c = 0, so Up = None, Average = a/2, Paeth = a = Sub
    for (std::size_t i = head; i < n; ++i) {
      sub[i] = static_cast<std::uint8_t>(cur[i] - cur[i - bpp]);
      up[i] = cur[i];
      avg[i] = static_cast<std::uint8_t>(cur[i] - (cur[i - bpp] >> 1));
      pae[i] = sub[i];
    }
  }
  const std::uint8_t* rows[5] = {cur, sub, up, avg, pae};
  int best = 0;
  std::uint64_t best_cost = cost(cur, n);
  for (int t = 1; t < 5; ++t) {
    const std::uint64_t c = cost(rows[t], n);
    if (c < best_cost) best = t, best_cost = c;
  }
  out[0] = static_cast<std::uint8_t>(best);
  std::memcpy(out + 1, rows[best], n);
}

}  // namespace

void write(const std::string& file, const std::string& display_path, const Layout& lay, const float* pixels, int level,
           bool srgb) {
  const int C = lay.channels;
  if (lay.width <= 0 || lay.height <= 0 || C < 1 || C > 4 || (lay.bits != 8 && lay.bits != 16) || !pixels ||
      level < 0 || level > 9 || lay.width > 0x7fffffff || lay.height > 0x7fffffff)
    throw_internal(display_path + ": PNG layout not written here");
  const std::size_t W = static_cast<std::size_t>(lay.width), H = static_cast<std::size_t>(lay.height);
  const std::size_t bytes_per_sample = lay.bits / 8;
  const std::size_t bpp = C * bytes_per_sample;
  const std::size_t row_bytes = W * bpp;
  const std::size_t stride = row_bytes + 1;  // filtered row: type byte + row
  // A block (at least one row) must fit zlib's 32-bit counts and a PNG chunk's 31-bit length.
  if (stride > (std::size_t{1} << 30))
    throw_bad_input(display_path + ": cannot write: a PNG row of " + std::to_string(stride) +
                    " bytes is more than this writer takes (1 GiB; write .exr)");
  const float max = lay.bits == 8 ? 255.0f : 65535.0f;

  // (1) quantise
  std::vector<std::uint8_t> raw(H * row_bytes);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, H), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t y = r.begin(); y < r.end(); ++y) {
      const float* s = pixels + y * W * C;
      std::uint8_t* d = raw.data() + y * row_bytes;
      const std::size_t n = W * C;
      if (bytes_per_sample == 1) {
        for (std::size_t i = 0; i < n; ++i) d[i] = static_cast<std::uint8_t>(quantise(s[i], max));
      } else {
        for (std::size_t i = 0; i < n; ++i) {
          const std::uint32_t q = quantise(s[i], max);
          d[2 * i] = static_cast<std::uint8_t>(q >> 8);
          d[2 * i + 1] = static_cast<std::uint8_t>(q);
        }
      }
    }
  });

  // (2) filter (level 0 stores the data: filtering would only cost time)
  std::vector<std::uint8_t> filtered(H * stride);
  const bool adaptive = level > 0;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, H, 16), [&](const tbb::blocked_range<std::size_t>& r) {
    std::array<std::vector<std::uint8_t>, 4> scratch;
    for (std::size_t y = r.begin(); y < r.end(); ++y)
      filter_row(raw.data() + y * row_bytes, y ? raw.data() + (y - 1) * row_bytes : nullptr, row_bytes, bpp, adaptive,
                 filtered.data() + y * stride, scratch);
  });
  std::vector<std::uint8_t>().swap(raw);

  // (3) deflate blocks of whole rows
  const std::size_t rows_per_block = std::max<std::size_t>(1, kBlockBytes / stride);
  const std::size_t nblocks = (H + rows_per_block - 1) / rows_per_block;
  const auto block_begin = [&](std::size_t k) { return std::min(H, k * rows_per_block) * stride; };  // bytes
  std::vector<std::vector<std::uint8_t>> packed(nblocks);
  std::vector<uLong> adler(nblocks);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nblocks, 1), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t k = r.begin(); k < r.end(); ++k) {
      const std::size_t begin = block_begin(k), n = block_begin(k + 1) - begin;
      z_stream z{};
      // Raw deflate (no zlib header: the stream's one header is written below), zlib's
      // default window and memory; Z_FILTERED as libpng uses for filtered rows.
      if (deflateInit2(&z, level, Z_DEFLATED, -15, 8, adaptive ? Z_FILTERED : Z_DEFAULT_STRATEGY) != Z_OK)
        throw_internal(display_path + ": cannot start a deflate stream");
      std::unique_ptr<z_stream, int (*)(z_stream*)> guard(&z, deflateEnd);
      if (k > 0) {
        const std::size_t dict = std::min(kWindow, begin);
        if (deflateSetDictionary(&z, filtered.data() + begin - dict, static_cast<uInt>(dict)) != Z_OK)
          throw_internal(display_path + ": cannot prime a deflate stream");
      }
      std::vector<std::uint8_t>& out = packed[k];
      out.resize(deflateBound(&z, n) + 16);  // + the sync flush's empty stored block
      z.next_in = filtered.data() + begin;
      z.avail_in = static_cast<uInt>(n);
      z.next_out = out.data();
      z.avail_out = static_cast<uInt>(out.size());
      const bool last = k + 1 == nblocks;
      const int rc = deflate(&z, last ? Z_FINISH : Z_SYNC_FLUSH);
      if (rc != (last ? Z_STREAM_END : Z_OK) || z.avail_in != 0)
        throw_internal(display_path + ": deflate failed (" + std::to_string(rc) + ")");
      out.resize(out.size() - z.avail_out);
      adler[k] = adler32(1, filtered.data() + begin, static_cast<uInt>(n));
    }
  });
  uLong sum = adler[0];
  for (std::size_t k = 1; k < nblocks; ++k)
    sum = adler32_combine(sum, adler[k], static_cast<z_off_t>(block_begin(k + 1) - block_begin(k)));

  // (4) the file
  OutFile f(file, display_path);
  // Writes one chunk whose data is the concatenation of the given pieces.
  const auto chunk = [&](const char* type, std::initializer_list<std::pair<const std::uint8_t*, std::size_t>> parts) {
    std::size_t n = 0;
    for (const auto& p : parts) n += p.second;
    if (n > 0x7fffffffu) throw_internal(display_path + ": PNG chunk too large");
    std::uint8_t head[8];
    put32(head, static_cast<std::uint32_t>(n));
    std::memcpy(head + 4, type, 4);
    uLong crc = crc32(0, head + 4, 4);
    f.write(head, 8, type);
    for (const auto& p : parts) {
      if (!p.second) continue;
      crc = crc32(crc, p.first, static_cast<uInt>(p.second));
      f.write(p.first, p.second, type);
    }
    std::uint8_t tail[4];
    put32(tail, static_cast<std::uint32_t>(crc));
    f.write(tail, 4, type);
  };
  f.write(kSignature, 8, "header");
  std::uint8_t ihdr[13];
  put32(ihdr, static_cast<std::uint32_t>(W));
  put32(ihdr + 4, static_cast<std::uint32_t>(H));
  ihdr[8] = static_cast<std::uint8_t>(lay.bits);
  ihdr[9] = C == 1 ? 0 : C == 2 ? 4 : C == 3 ? 2 : 6;  // grey, grey + alpha, RGB, RGBA
  ihdr[10] = ihdr[11] = ihdr[12] = 0;                  // deflate, adaptive filtering, no interlace
  chunk("IHDR", {{ihdr, 13}});
  if (srgb) {
    // The chunks OpenImageIO's writer gives an sRGB file: gamma 1/2.2, sRGB (absolute
    // colorimetric), the sRGB primaries and white point (× 100000).
    std::uint8_t gama[4], srgb_chunk[1] = {3}, chrm[32];
    put32(gama, 45455);
    const std::uint32_t c[8] = {31270, 32900, 64000, 33000, 30000, 60000, 15000, 6000};
    for (int i = 0; i < 8; ++i) put32(chrm + 4 * i, c[i]);
    chunk("gAMA", {{gama, 4}});
    chunk("sRGB", {{srgb_chunk, 1}});
    chunk("cHRM", {{chrm, 32}});
  } else {
    std::uint8_t gama[4];
    put32(gama, 100000);  // linear
    chunk("gAMA", {{gama, 4}});
  }
  // zlib header: deflate with a 32 KiB window, the level class zlib itself would write, and
  // the check bits that make the 16-bit header a multiple of 31.
  const int flevel = level < 2 ? 0 : level < 6 ? 1 : level == 6 ? 2 : 3;
  std::uint8_t zhead[2] = {0x78, static_cast<std::uint8_t>(flevel << 6)};
  zhead[1] = static_cast<std::uint8_t>(zhead[1] + (31 - (zhead[0] * 256 + zhead[1]) % 31) % 31);
  std::uint8_t ztail[4];
  put32(ztail, static_cast<std::uint32_t>(sum));
  for (std::size_t k = 0; k < nblocks; ++k) {
    const bool first = k == 0, last = k + 1 == nblocks;
    chunk("IDAT", {{zhead, first ? 2u : 0u}, {packed[k].data(), packed[k].size()}, {ztail, last ? 4u : 0u}});
    std::vector<std::uint8_t>().swap(packed[k]);
  }
  chunk("IEND", {});
  f.close();
}

// --- reading ------------------------------------------------------------------------------

namespace {

std::uint32_t get32(const std::uint8_t* p) {
  return (static_cast<std::uint32_t>(p[0]) << 24) | (static_cast<std::uint32_t>(p[1]) << 16) |
         (static_cast<std::uint32_t>(p[2]) << 8) | p[3];
}

}  // namespace

std::unique_ptr<Reader> Reader::open(const std::string& path, std::string* broken) {
  const auto refuse = [&](std::string why) -> std::unique_ptr<Reader> {
    if (broken) *broken = std::move(why);
    return nullptr;
  };
  std::ifstream f(path, std::ios::binary);
  if (!f) return nullptr;
  std::uint8_t sig[8];
  if (!f.read(reinterpret_cast<char*>(sig), 8) || std::memcmp(sig, kSignature, 8) != 0) return nullptr;
  std::unique_ptr<Reader> r(new Reader());
  bool header = false, ended = false, idat_done = false, other = false;
  std::vector<std::uint8_t> data;
  while (!ended) {
    std::uint8_t head[8];
    if (!f.read(reinterpret_cast<char*>(head), 8)) return nullptr;  // no IEND
    const std::uint32_t n = get32(head);
    if (n > 0x7fffffffu) return nullptr;
    char type[5] = {static_cast<char>(head[4]), static_cast<char>(head[5]), static_cast<char>(head[6]),
                    static_cast<char>(head[7]), 0};
    for (int i = 0; i < 4; ++i)
      if (!std::isalpha(static_cast<unsigned char>(type[i]))) return nullptr;
    const std::string t(type);
    const bool critical = std::isupper(static_cast<unsigned char>(type[0])) != 0;
    // IHDR first (libpng refuses any other chunk there, before it looks at the CRC).
    if (!header && t != "IHDR") return refuse("the first chunk is '" + t + "', not IHDR");
    // Chunk data: IDAT straight into the stream, the others into `data` (small ones only;
    // a large ancillary chunk is left to OpenImageIO, which skips or reads it).
    std::uint8_t* dst;
    if (t == "IDAT") {
      if (!header || idat_done) return nullptr;  // IDAT chunks must be consecutive
      const std::size_t at = r->stream_.size();
      r->stream_.resize(at + n);
      dst = r->stream_.data() + at;
    } else {
      if (!r->stream_.empty()) idat_done = true;
      if (n > (1u << 20)) return nullptr;
      data.resize(n);
      dst = data.data();
    }
    std::uint8_t crc_bytes[4];
    if ((n && !f.read(reinterpret_cast<char*>(dst), n)) || !f.read(reinterpret_cast<char*>(crc_bytes), 4))
      return nullptr;
    const uLong crc = crc32(crc32(0, head + 4, 4), dst, n);
    if (static_cast<std::uint32_t>(crc) != get32(crc_bytes)) {
      // libpng's default: an error for a critical chunk, a warning (the chunk is dropped) for
      // an ancillary one. OpenImageIO may never reach IEND, so that one is left to it.
      if (!critical) continue;
      if (t == "IEND") return nullptr;
      return refuse("chunk '" + t + "' fails its CRC check");
    }
    if (!header) {
      // IHDR within the PNG rules (libpng refuses the file otherwise); this reader takes
      // 8 / 16-bit grey, grey + alpha, RGB and RGBA without interlacing.
      if (n != 13) return refuse("its IHDR chunk is " + std::to_string(n) + " bytes long, not 13");
      const std::uint32_t w = get32(dst), h = get32(dst + 4);
      const int depth = dst[8], ctype = dst[9];
      if (w == 0 || h == 0) return refuse("its IHDR declares a zero width or height");
      if (w > 0x7fffffffu || h > 0x7fffffffu) return refuse("its IHDR declares a width or height above 2^31 - 1");
      if (dst[10] != 0)
        return refuse("its IHDR declares compression method " + std::to_string(dst[10]) + " (only 0 exists)");
      if (dst[11] != 0)
        return refuse("its IHDR declares filter method " + std::to_string(dst[11]) + " (only 0 exists)");
      if (dst[12] > 1)
        return refuse("its IHDR declares interlace method " + std::to_string(dst[12]) + " (only 0 and 1 exist)");
      const bool valid = (ctype == 0 && (depth == 1 || depth == 2 || depth == 4 || depth == 8 || depth == 16)) ||
                         (ctype == 3 && (depth == 1 || depth == 2 || depth == 4 || depth == 8)) ||
                         ((ctype == 2 || ctype == 4 || ctype == 6) && (depth == 8 || depth == 16));
      if (!valid)
        return refuse("its IHDR declares colour type " + std::to_string(ctype) + " with bit depth " +
                      std::to_string(depth) + ", which PNG does not allow");
      if ((depth != 8 && depth != 16) || ctype == 3 || dst[12] != 0) return nullptr;  // OpenImageIO's
      switch (ctype) {
        case 0:
          r->names_ = {"Y"};
          break;
        case 4:
          r->names_ = {"Y", "A"};
          break;
        case 2:
          r->names_ = {"R", "G", "B"};
          break;
        default:
          r->names_ = {"R", "G", "B", "A"};
          break;
      }
      r->width_ = static_cast<int>(w);
      r->height_ = static_cast<int>(h);
      r->bits_ = depth;
      r->channels_ = static_cast<int>(r->names_.size());
      header = true;
    } else if (t == "IEND") {
      ended = true;
    } else if (t != "IDAT" && (t == "tRNS" || t == "sBIT" || critical)) {
      // transparency (libpng expands it into alpha), significant bits, a palette, a second
      // header or an unknown critical chunk: OpenImageIO's business (checked to the end, so
      // a broken critical chunk after it is still reported here)
      other = true;
    }
  }
  if (other || !header || r->stream_.empty()) return nullptr;
  char extra;
  if (f.read(&extra, 1)) return nullptr;  // bytes after IEND
  return r;
}

bool Reader::read(int cb, int ce, float* out, std::string* broken) const {
  if (cb < 0 || ce > channels_ || cb >= ce) return false;
  const std::size_t W = static_cast<std::size_t>(width_), H = static_cast<std::size_t>(height_);
  const std::size_t bps = bits_ / 8, bpp = channels_ * bps, row_bytes = W * bpp, stride = row_bytes + 1;
  std::vector<std::uint8_t> rows(H * stride);
  {
    std::unique_ptr<libdeflate_decompressor, void (*)(libdeflate_decompressor*)> d(libdeflate_alloc_decompressor(),
                                                                                   libdeflate_free_decompressor);
    if (!d) return false;
    // Exactly the declared rows, Adler-32 checked. A stream that ends early is an error for
    // libpng too ("Not enough image data"); a bad Adler-32 or data past the rows only a warning.
    std::size_t got = 0;
    if (libdeflate_zlib_decompress(d.get(), stream_.data(), stream_.size(), rows.data(), rows.size(), &got) !=
        LIBDEFLATE_SUCCESS)
      return false;
    if (got != rows.size()) {
      if (broken)
        *broken = "its image data inflates to " + std::to_string(got) + " of the " + std::to_string(rows.size()) +
                  " bytes its rows need (truncated or corrupt)";
      return false;
    }
  }
  // Unfilter in place (each row depends on the one above, already unfiltered).
  for (std::size_t y = 0; y < H; ++y) {
    std::uint8_t* cur = rows.data() + y * stride + 1;
    const std::uint8_t* up = y ? rows.data() + (y - 1) * stride + 1 : nullptr;
    const std::size_t head = std::min(bpp, row_bytes);
    switch (cur[-1]) {
      case 0:
        break;
      case 1:
        for (std::size_t i = head; i < row_bytes; ++i) cur[i] = static_cast<std::uint8_t>(cur[i] + cur[i - bpp]);
        break;
      case 2:
        if (up)
          for (std::size_t i = 0; i < row_bytes; ++i) cur[i] = static_cast<std::uint8_t>(cur[i] + up[i]);
        break;
      case 3:
        for (std::size_t i = 0; i < head; ++i) cur[i] = static_cast<std::uint8_t>(cur[i] + (up ? up[i] >> 1 : 0));
        for (std::size_t i = head; i < row_bytes; ++i)
          cur[i] = static_cast<std::uint8_t>(cur[i] + ((cur[i - bpp] + (up ? up[i] : 0)) >> 1));
        break;
      case 4:
        for (std::size_t i = 0; i < head; ++i) cur[i] = static_cast<std::uint8_t>(cur[i] + (up ? up[i] : 0));
        for (std::size_t i = head; i < row_bytes; ++i)
          cur[i] = static_cast<std::uint8_t>(cur[i] + (up ? paeth(cur[i - bpp], up[i], up[i - bpp]) : cur[i - bpp]));
        break;
      default:
        if (broken)
          *broken = "row " + std::to_string(y) + " has filter type " + std::to_string(cur[-1]) + " (only 0-4 exist)";
        return false;
    }
  }
  // Samples → float as OpenImageIO gives them: code · (1 / max).
  const int n = ce - cb;
  const float scale = 1.0f / (bits_ == 8 ? 255.0f : 65535.0f);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, H), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t y = r.begin(); y < r.end(); ++y) {
      const std::uint8_t* s = rows.data() + y * stride + 1;
      float* o = out + y * W * n;
      for (std::size_t x = 0; x < W; ++x)
        for (int c = 0; c < n; ++c) {
          const std::uint8_t* p = s + x * bpp + (cb + c) * bps;
          const unsigned code = bps == 1 ? p[0] : (static_cast<unsigned>(p[0]) << 8) | p[1];
          o[x * n + c] = static_cast<float>(code) * scale;
        }
    }
  });
  return true;
}

}  // namespace dofkit::io::png
