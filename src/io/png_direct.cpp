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
  bool header = false, ended = false, idat_done = false, have_palette = false;
  std::vector<std::uint8_t> data;
  std::string trns;  // the tRNS chunk's data, checked once the header and palette are known
  bool have_trns = false;
  while (!ended) {
    std::uint8_t head[8];
    if (!f.read(reinterpret_cast<char*>(head), 8)) return refuse("it ends before its IEND chunk (truncated)");
    const std::uint32_t n = get32(head);
    if (n > 0x7fffffffu) return refuse("a chunk declares " + std::to_string(n) + " bytes (more than 2^31 - 1)");
    char type[5] = {static_cast<char>(head[4]), static_cast<char>(head[5]), static_cast<char>(head[6]),
                    static_cast<char>(head[7]), 0};
    for (int i = 0; i < 4; ++i)
      if (!std::isalpha(static_cast<unsigned char>(type[i]))) return refuse("a chunk type is not four letters");
    const std::string t(type);
    const bool critical = std::isupper(static_cast<unsigned char>(type[0])) != 0;
    // IHDR first (libpng refuses any other chunk there, before it looks at the CRC).
    if (!header && t != "IHDR") return refuse("the first chunk is '" + t + "', not IHDR");
    // Chunk data: IDAT straight into the stream, the others into `data`. A large ancillary
    // chunk (text, a profile) is skipped unread: it cannot change the pixels.
    std::uint8_t* dst;
    if (t == "IDAT") {
      if (idat_done) return refuse("its IDAT chunks are not consecutive");
      const std::size_t at = r->stream_.size();
      r->stream_.resize(at + n);
      dst = r->stream_.data() + at;
    } else {
      if (!r->stream_.empty()) idat_done = true;
      if (!critical && n > (1u << 20)) {
        f.seekg(static_cast<std::streamoff>(n) + 4, std::ios::cur);
        if (!f) return refuse("it ends before its IEND chunk (truncated)");
        continue;
      }
      data.resize(n);
      dst = data.data();
    }
    std::uint8_t crc_bytes[4];
    if ((n && !f.read(reinterpret_cast<char*>(dst), n)) || !f.read(reinterpret_cast<char*>(crc_bytes), 4))
      return refuse("it ends inside chunk '" + t + "' (truncated)");
    const uLong crc = crc32(crc32(0, head + 4, 4), dst, n);
    if (static_cast<std::uint32_t>(crc) != get32(crc_bytes)) {
      // libpng's default: an error for a critical chunk, a warning (the chunk is dropped) for
      // an ancillary one, which cannot change the pixels.
      if (!critical) continue;
      return refuse("chunk '" + t + "' fails its CRC check");
    }
    if (!header) {
      // IHDR within the PNG rules (libpng refuses the file otherwise).
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
      r->width_ = static_cast<int>(w);
      r->height_ = static_cast<int>(h);
      r->depth_ = depth;
      r->ctype_ = ctype;
      r->interlaced_ = dst[12] == 1;
      header = true;
    } else if (t == "IEND") {
      ended = true;
    } else if (t == "IHDR") {
      return refuse("it has a second IHDR chunk");
    } else if (t == "PLTE") {
      if (have_palette) return refuse("it has a second PLTE chunk");
      if (!r->stream_.empty()) return refuse("its PLTE chunk follows the image data");
      if (r->ctype_ == 0 || r->ctype_ == 4) return refuse("a grey image with a PLTE chunk");
      if (n == 0 || n % 3 != 0 || n > 768) return refuse("its PLTE chunk is " + std::to_string(n) + " bytes long");
      have_palette = true;
      // Only a palette image uses it (for RGB it is a suggestion); libpng keeps at most
      // 2^depth entries.
      if (r->ctype_ == 3) {
        r->palette_.assign(data.begin(), data.end());
        r->palette_.resize(std::min<std::size_t>(r->palette_.size(), std::size_t{3} << r->depth_));
      }
    } else if (t == "tRNS") {
      if (have_trns) return refuse("it has a second tRNS chunk");
      if (!r->stream_.empty()) return refuse("its tRNS chunk follows the image data");
      have_trns = true;
      trns.assign(data.begin(), data.end());
      if (r->ctype_ == 3 && !have_palette) return refuse("its tRNS chunk comes before its palette");
    } else if (critical && t != "IDAT") {
      return refuse("unknown critical chunk '" + t + "'");
    }
  }
  if (r->stream_.empty()) return refuse("it has no image data (no IDAT chunk)");
  if (r->ctype_ == 3 && r->palette_.empty()) return refuse("a palette image without a PLTE chunk");
  if (have_trns) {
    // Transparency: per palette entry, or one key colour that becomes alpha 0 (libpng
    // expands it into an alpha channel, as OpenImageIO asks it to).
    const std::size_t len = trns.size();
    if (r->ctype_ == 3) {
      if (len == 0 || len > r->palette_.size() / 3)
        return refuse("its tRNS chunk has " + std::to_string(len) + " entries for a palette of " +
                      std::to_string(r->palette_.size() / 3));
      r->palette_alpha_.assign(trns.begin(), trns.end());
    } else if (r->ctype_ == 0 || r->ctype_ == 2) {
      const std::size_t want = r->ctype_ == 0 ? 2 : 6;
      if (len != want)
        return refuse("its tRNS chunk is " + std::to_string(len) + " bytes long, not " + std::to_string(want));
      for (std::size_t i = 0; i < want / 2; ++i)
        r->key_[i] = static_cast<std::uint16_t>((static_cast<unsigned char>(trns[2 * i]) << 8) |
                                                static_cast<unsigned char>(trns[2 * i + 1]));
    } else {
      return refuse("a tRNS chunk in an image that has an alpha channel");
    }
    r->key_alpha_ = true;
  }
  // What the file expands to (OpenImageIO has libpng expand palette, low bit depths and tRNS).
  const bool alpha = r->ctype_ == 4 || r->ctype_ == 6 || have_trns;
  const bool colour = r->ctype_ == 2 || r->ctype_ == 3 || r->ctype_ == 6;
  r->channels_ = (colour ? 3 : 1) + (alpha ? 1 : 0);
  r->bits_ = r->depth_ == 16 ? 16 : 8;
  r->names_ = colour ? std::vector<std::string>{"R", "G", "B"} : std::vector<std::string>{"Y"};
  if (alpha) r->names_.push_back("A");
  return r;
}

namespace {

// Undoes the filters of `rows` rows of `row_bytes` bytes (each after its filter-type byte),
// `bpp` bytes per complete pixel (at least 1); false (and `why`) on an unknown filter type.
bool unfilter(std::uint8_t* data, std::size_t rows, std::size_t row_bytes, std::size_t bpp, std::size_t first_row,
              std::string* why) {
  const std::size_t stride = row_bytes + 1;
  for (std::size_t y = 0; y < rows; ++y) {
    std::uint8_t* cur = data + y * stride + 1;
    const std::uint8_t* up = y ? data + (y - 1) * stride + 1 : nullptr;
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
        if (why)
          *why = "row " + std::to_string(first_row + y) + " has filter type " + std::to_string(cur[-1]) +
                 " (only 0-4 exist)";
        return false;
    }
  }
  return true;
}

// Adam7: the seven passes' first pixel and spacing (x0, y0, dx, dy).
constexpr int kAdam7[7][4] = {{0, 0, 8, 8}, {4, 0, 8, 8}, {0, 4, 4, 8}, {2, 0, 4, 4},
                              {0, 2, 2, 4}, {1, 0, 2, 2}, {0, 1, 1, 2}};

}  // namespace

bool Reader::read(int cb, int ce, float* out, std::string* broken) const {
  if (cb < 0 || ce > channels_ || cb >= ce) return false;
  const std::size_t W = static_cast<std::size_t>(width_), H = static_cast<std::size_t>(height_);
  // The file's own samples per pixel and bits per pixel.
  const int file_channels = ctype_ == 0 || ctype_ == 3 ? 1 : ctype_ == 4 ? 2 : ctype_ == 2 ? 3 : 4;
  const std::size_t pixel_bits = static_cast<std::size_t>(file_channels) * depth_;
  const std::size_t bpp = std::max<std::size_t>(1, pixel_bits / 8);
  // The passes (one without interlacing): size and where their rows start in the stream.
  struct Pass {
    std::size_t x0, y0, dx, dy, w, h, row_bytes, at;
  };
  std::vector<Pass> passes;
  std::size_t total = 0;
  for (int p = 0; p < (interlaced_ ? 7 : 1); ++p) {
    Pass s{0, 0, 1, 1, W, H, 0, 0};
    if (interlaced_) {
      s.x0 = kAdam7[p][0], s.y0 = kAdam7[p][1], s.dx = kAdam7[p][2], s.dy = kAdam7[p][3];
      s.w = W > s.x0 ? (W - s.x0 + s.dx - 1) / s.dx : 0;
      s.h = H > s.y0 ? (H - s.y0 + s.dy - 1) / s.dy : 0;
    }
    if (s.w == 0 || s.h == 0) continue;  // an empty pass has no rows, not even filter bytes
    s.row_bytes = (s.w * pixel_bits + 7) / 8;
    s.at = total;
    total += s.h * (s.row_bytes + 1);
    passes.push_back(s);
  }
  std::vector<std::uint8_t> rows(total);
  {
    std::unique_ptr<libdeflate_decompressor, void (*)(libdeflate_decompressor*)> d(libdeflate_alloc_decompressor(),
                                                                                   libdeflate_free_decompressor);
    if (!d) return false;
    // Exactly the declared rows, Adler-32 checked: a stream that ends early, does not inflate,
    // fails its checksum or holds more than the rows is a damaged file (libpng would err or
    // warn and decode what it could).
    std::size_t got = 0;
    const libdeflate_result res =
        libdeflate_zlib_decompress(d.get(), stream_.data(), stream_.size(), rows.data(), rows.size(), &got);
    if (res == LIBDEFLATE_SUCCESS && got != rows.size()) {
      if (broken)
        *broken = "its image data inflates to " + std::to_string(got) + " of the " + std::to_string(rows.size()) +
                  " bytes its rows need (truncated or corrupt)";
      return false;
    }
    if (res != LIBDEFLATE_SUCCESS) {
      if (broken)
        *broken = res == LIBDEFLATE_INSUFFICIENT_SPACE
                      ? "its image data inflates to more bytes than its rows (corrupt)"
                      : "its image data does not inflate (a corrupt zlib stream or checksum)";
      return false;
    }
  }
  // Unfilter in place, pass by pass (each row depends on the one above, already unfiltered).
  for (const Pass& s : passes)
    if (!unfilter(rows.data() + s.at, s.h, s.row_bytes, bpp, 0, broken)) return false;

  const int n = ce - cb;
  const float scale = 1.0f / (bits_ == 8 ? 255.0f : 65535.0f);
  if (!interlaced_ && (depth_ == 8 || depth_ == 16) && ctype_ != 3 && !key_alpha_) {
    // The common case: samples as stored → float as OpenImageIO gives them: code · (1 / max).
    const std::size_t bps = bits_ / 8, stride = passes[0].row_bytes + 1;
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
  // Everything else, as libpng expands it for OpenImageIO: grey of 1, 2 or 4 bits scaled to 8
  // (v · 255 / (2^depth − 1)), palette indices to their RGB entry (and tRNS alpha, 255 past
  // its entries), a tRNS key colour to alpha 0 (else the maximum); pixels of interlaced
  // passes to their place.
  const unsigned max_code = bits_ == 8 ? 255u : 65535u;
  const unsigned low_mask = (1u << std::min(depth_, 8)) - 1;
  const unsigned low_scale = depth_ < 8 ? 255u / low_mask : 1u;
  const std::size_t palette_entries = palette_.size() / 3;
  for (const Pass& s : passes) {
    const std::size_t stride = s.row_bytes + 1;
    for (std::size_t py = 0; py < s.h; ++py) {
      const std::uint8_t* row = rows.data() + s.at + py * stride + 1;
      const std::size_t y = s.y0 + py * s.dy;
      for (std::size_t px = 0; px < s.w; ++px) {
        // The file's samples of this pixel (raw codes).
        unsigned raw[4] = {0, 0, 0, 0};
        for (int k = 0; k < file_channels; ++k) {
          const std::size_t bit = (px * file_channels + k) * depth_;
          if (depth_ == 16) {
            raw[k] = static_cast<unsigned>(row[bit / 8]) << 8 | row[bit / 8 + 1];
          } else if (depth_ == 8) {
            raw[k] = row[bit / 8];
          } else {
            raw[k] = (row[bit / 8] >> (8 - depth_ - bit % 8)) & low_mask;
          }
        }
        unsigned v[4] = {0, 0, 0, max_code};  // the expanded pixel: colour (or Y) then alpha
        int count = 0;
        switch (ctype_) {
          case 3: {
            const unsigned i = raw[0];
            if (i >= palette_entries) {
              if (broken)
                *broken = "pixel (" + std::to_string(s.x0 + px * s.dx) + ", " + std::to_string(y) +
                          ") has palette index " + std::to_string(i) + ", beyond its " +
                          std::to_string(palette_entries) + " entries (corrupt)";
              return false;
            }
            v[0] = palette_[3 * i], v[1] = palette_[3 * i + 1], v[2] = palette_[3 * i + 2];
            v[3] = i < palette_alpha_.size() ? palette_alpha_[i] : 255u;
            count = 3;
            break;
          }
          case 0:
            v[0] = depth_ < 8 ? raw[0] * low_scale : raw[0];
            if (key_alpha_) v[3] = raw[0] == (key_[0] & (depth_ == 16 ? 0xffffu : low_mask)) ? 0 : max_code;
            count = 1;
            break;
          case 2:
            v[0] = raw[0], v[1] = raw[1], v[2] = raw[2];
            if (key_alpha_) {
              const unsigned m = depth_ == 16 ? 0xffffu : 0xffu;
              v[3] = raw[0] == (key_[0] & m) && raw[1] == (key_[1] & m) && raw[2] == (key_[2] & m) ? 0 : max_code;
            }
            count = 3;
            break;
          case 4:
            v[0] = raw[0], v[3] = raw[1];
            count = 1;
            break;
          default:
            v[0] = raw[0], v[1] = raw[1], v[2] = raw[2], v[3] = raw[3];
            count = 3;
            break;
        }
        // This reader's channels (count colour channels, then alpha if it has one).
        float* o = out + ((y * W) + s.x0 + px * s.dx) * n;
        for (int c = cb; c < ce; ++c) o[c - cb] = static_cast<float>(c < count ? v[c] : v[3]) * scale;
      }
    }
  }
  return true;
}

}  // namespace dofkit::io::png
