// Over 800 lines: one byte-level walker per format (EXR, PNG, TIFF) behind one entry point and its shared checks.
// The checks of header_check.hpp, format by format, on the raw bytes.
//
// EXR (OpenEXR file format, "Technical Introduction"): magic 76 2f 31 01; int32 version +
// flags (0x200 single-part tiled, 0x400 long names, 0x800 deep, 0x1000 multi-part); then one
// header (several for multi-part, the list ended by an empty header) of attributes
// `name\0 type\0 int32 size, value[size]`, each header ended by a 0 byte; then the chunk offset
// table (uint64 per chunk), then the chunks.
#include "io/header_check.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include "dofkit/error.hpp"
#include "io/image_io.hpp"
#include "io/phone_depth.hpp"

namespace dofkit::io {

namespace {

constexpr std::size_t kMaxHeaderBytes = 16u << 20;  // attributes beyond this are not a real header

// Deflate expands at most 1032:1 (a 258-byte match coded in two bits), so n deflated bytes
// decode to at most 1032·n. A payload shorter than the declared pixels need at that ratio is
// a truncated or corrupt file, refused before any decoder allocates the pixels (the fuzzer
// found a 380-byte PNG declaring 2,000,000 × 60 px: 1.3 GB allocated, then the inflate failed).
constexpr std::uint64_t kMaxDeflateRatio = 1032;

using u128 = unsigned __int128;

std::string errno_reason(int err) {
  switch (err) {
    case EACCES:
    case EPERM:
      return "permission denied";
    case ELOOP:
      return "too many levels of symbolic links (a symlink loop?)";
    case ENAMETOOLONG:
      return "the path or a name in it is too long";
    default: {
      std::string s = std::strerror(err);
      if (!s.empty()) s[0] = static_cast<char>(std::tolower(static_cast<unsigned char>(s[0])));
      return s;
    }
  }
}

// A folder, device, fifo or socket: what it is, for the message; nullptr for a regular file.
const char* not_regular(mode_t mode) {
  if (S_ISREG(mode)) return nullptr;
  if (S_ISDIR(mode)) return "a folder";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISFIFO(mode)) return "a named pipe (fifo)";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a regular file";
}

[[noreturn]] void refuse_open(const std::string& path, const char* role, int err) {
  if (err == ENOENT) throw_bad_input(path + ": " + role + " file does not exist");
  if (err == ENOTDIR) throw_bad_input(path + ": " + role + " file does not exist (a part of its path is not a folder)");
  throw_bad_input(path + ": cannot open " + role + " file: " + errno_reason(err));
}

void refuse_kind(const struct stat& st, const std::string& path, const char* role) {
  if (const char* what = not_regular(st.st_mode)) {
    if (S_ISDIR(st.st_mode)) throw_bad_input(path + ": " + role + " path is a folder, not an image");
    throw_bad_input(path + ": " + role + " path is " + what + ", not a regular file");
  }
}

// The pixel budget (image_io.hpp), checked on the header's size (the open checks it again on
// the size the reader reports).
void check_budget(long long w, long long h, const std::string& path, const char* role) {
  const long long budget = pixel_budget();
  if (w > budget || h > budget || w * h > budget)
    throw_bad_input(path + ": " + role + " image declares " + std::to_string(w) + "x" + std::to_string(h) +
                    " pixels, more than the limit of " + std::to_string(budget) + " (--max-pixels)");
}

[[noreturn]] void too_short(const std::string& path, const char* role, long long w, long long h, std::uint64_t have) {
  throw_bad_input(path + ": cannot read " + role + " image: its " + std::to_string(w) + "x" + std::to_string(h) +
                  " pixels need more bytes than its " + std::to_string(have) +
                  " bytes of image data can hold (truncated or corrupt)");
}

// Random access to the file's bytes (positions and lengths checked against its size).
class Bytes {
 public:
  Bytes(std::ifstream& f, std::uint64_t size) : f_(f), size_(size) {}
  std::uint64_t size() const { return size_; }
  bool read(std::uint64_t pos, std::size_t n, void* out) {
    if (pos > size_ || n > size_ - pos) return false;
    f_.clear();
    f_.seekg(static_cast<std::streamoff>(pos));
    return static_cast<bool>(f_.read(static_cast<char*>(out), static_cast<std::streamsize>(n)));
  }

 private:
  std::ifstream& f_;
  std::uint64_t size_;
};

std::int32_t le32(const unsigned char* p) {
  return static_cast<std::int32_t>(static_cast<std::uint32_t>(p[0]) | static_cast<std::uint32_t>(p[1]) << 8 |
                                   static_cast<std::uint32_t>(p[2]) << 16 | static_cast<std::uint32_t>(p[3]) << 24);
}
std::uint64_t le64(const unsigned char* p) {
  std::uint64_t v = 0;
  for (int i = 7; i >= 0; --i) v = v << 8 | p[i];
  return v;
}

// --- EXR ---------------------------------------------------------------------------------

// The most an EXR compression can expand the bytes it stores (each chunk may also be stored
// raw, ratio 1); 0 = an unknown code (OpenEXR refuses it).
//   RLE: a 2-byte run codes at most 128 bytes. ZIP(S): deflate. PIZ: Huffman codes of at least
//   one bit, a repeated value sent as value + run code + 8-bit count for up to 256 16-bit words:
//   10 bits for 4096 → 410. PXR24: 32-bit floats kept as 3 deflated bytes. B44(A): a 4×4 block
//   of halfs (32 bytes) in 14 bytes, or 3 when flat (B44A). DWAA/DWAB: run-length coding (at
//   most 64:1: a block's AC coefficients in one 2-byte end-of-block code) then deflate.
std::uint64_t exr_max_ratio(int compression) {
  switch (compression) {
    case 0:
      return 1;  // NONE
    case 1:
      return 64;  // RLE
    case 2:
    case 3:
      return kMaxDeflateRatio;  // ZIPS, ZIP
    case 4:
      return 410;  // PIZ
    case 5:
      return kMaxDeflateRatio * 4 / 3 + 1;  // PXR24
    case 6:
    case 7:
      return 11;  // B44, B44A
    case 8:
    case 9:
      return 64 * kMaxDeflateRatio;  // DWAA, DWAB
    default:
      return 0;
  }
}

// Scanlines per chunk for each compression code (NONE, RLE, ZIPS, ZIP, PIZ, PXR24, B44,
// B44A, DWAA, DWAB); unknown codes count as 1 (the decoder rejects them).
int lines_per_chunk(int compression) {
  static const int table[] = {1, 1, 1, 16, 32, 16, 32, 32, 32, 256};
  return compression >= 0 && compression < 10 ? table[compression] : 1;
}

struct Part {
  bool has_window = false;
  long long w = 0, h = 0;
  bool has_display = false;
  long long display_w = 0, display_h = 0;
  int compression = 0;
  bool tiled = false;
  long long tile_w = 0, tile_h = 0;
  long long chunk_count = -1;
  bool deep = false;
  struct Channel {
    int bytes, xs, ys;  // sample size, x / y sampling
  };
  std::vector<Channel> channels;  // empty if the list was missing or did not parse
  long long chunks = 0;           // chunks in the offset table
};

class Walker {
 public:
  // Reads the header lazily from `f`: 64 KiB first (a real header is a few KiB), more only
  // when an attribute runs past what was read, up to kMaxHeaderBytes.
  Walker(std::ifstream& f, std::size_t file_size, const std::string& path, const char* role)
      : f_(f), cap_(std::min(file_size, kMaxHeaderBytes)), file_size_(file_size), path_(path), role_(role) {}

  /// Reads the first block; false if the file cannot be read (left to the decoder to report).
  bool start() { return more(); }

  [[noreturn]] void fail(const std::string& why) const {
    throw_bad_input(path_ + ": cannot read " + role_ + " image: not a valid EXR: " + why);
  }

  void run(HeaderFacts* facts) {
    const std::int32_t version = le32(b_.data() + 4);
    const bool single_tiled = version & 0x200, long_names = version & 0x400, multipart = version & 0x1000;
    const std::size_t max_name = long_names ? 256 : 32;
    pos_ = 8;
    std::vector<Part> parts;
    for (;;) {
      Part part;
      part.tiled = single_tiled && !multipart;
      part.deep = (version & 0x800) && !multipart;
      const bool empty = read_header(part, max_name);
      if (empty && (multipart ? !parts.empty() : true)) {
        if (!multipart) parts.push_back(part);
        break;
      }
      parts.push_back(part);
      if (!multipart) break;
      if (parts.size() > 4096) fail("more than 4096 parts");
    }
    // The chunk offset table follows the headers and must be in the file.
    long long chunks = 0;
    for (Part& p : parts) {
      if (!p.has_window) fail("a header has no dataWindow");
      // Required too: without it OpenEXR's C++ reader assumes a 64x64 display window, which
      // the layers reader fills (a fuzzed deep file of 5x4 px was probed 5x4 and read 64x64).
      if (!p.has_display) fail("a header has no displayWindow");
      if (p.w <= 0 || p.h <= 0) fail("empty or inverted dataWindow");
      check_budget(p.w, p.h, path_, role_);
      if (p.deep) {
        // The layers reader fills a frame of the display window: that is the image's size.
        if (p.display_w <= 0 || p.display_h <= 0) fail("empty or inverted displayWindow");
        check_budget(p.display_w, p.display_h, path_, role_);
      }
      if (p.chunk_count >= 0) {
        p.chunks = p.chunk_count;
      } else if (p.tiled) {
        if (p.tile_w <= 0 || p.tile_h <= 0) fail("tiled image without a valid tile size");
        p.chunks = ((p.w + p.tile_w - 1) / p.tile_w) * ((p.h + p.tile_h - 1) / p.tile_h);
      } else {
        const long long lpc = lines_per_chunk(p.compression);
        p.chunks = (p.h + lpc - 1) / lpc;
      }
      chunks += p.chunks;
      if (chunks > static_cast<long long>(file_size_)) break;  // the check below fails
    }
    const long long table_bytes = chunks * 8;
    const long long after_header = static_cast<long long>(file_size_ - std::min(file_size_, pos_));
    if (table_bytes > after_header)
      fail("file is truncated (its chunk table needs " + std::to_string(table_bytes) + " bytes, " +
           std::to_string(after_header) + " remain)");
    const std::uint64_t have = static_cast<std::uint64_t>(after_header - table_bytes);
    // The flat parts' pixels must fit the bytes after the table at the largest ratio of their
    // compressions (every part's data lies there; a channel sampled every (xs, ys) px stores
    // at least ⌊W/xs⌋·⌊H/ys⌋ samples).
    u128 need = 0;
    std::uint64_t ratio = 0;
    bool bounded = true;
    long long big_w = 0, big_h = 0;
    for (const Part& p : parts) {
      if (p.deep || p.channels.empty()) continue;
      const std::uint64_t r = exr_max_ratio(p.compression);
      if (r == 0) bounded = false;
      ratio = std::max(ratio, r);
      for (const Part::Channel& c : p.channels)
        need += static_cast<u128>(c.bytes) * static_cast<std::uint64_t>(p.w / c.xs) *
                static_cast<std::uint64_t>(p.h / c.ys);
      if (p.w * p.h > big_w * big_h) big_w = p.w, big_h = p.h;
    }
    if (bounded && ratio > 0 && need > static_cast<u128>(have) * ratio) too_short(path_, role_, big_w, big_h, have);
    // Deep parts: every chunk's sample data must be in the file and inflate to no more than
    // its compression allows; the total is what a decoder allocates for the samples.
    std::uint64_t first_chunk = 0;
    for (const Part& p : parts) {
      if (p.deep) deep_chunks(p, parts.size() > 1, pos_ + 8 * first_chunk, facts);
      first_chunk += static_cast<std::uint64_t>(p.chunks);
    }
    if (facts && !parts.empty()) {
      const Part& p = parts[0];
      facts->width = p.w;
      facts->height = p.h;
      facts->channels = static_cast<int>(p.channels.size());
      if (p.deep) {
        facts->deep = true;
        facts->width = facts->display_width = p.display_w;
        facts->height = facts->display_height = p.display_h;
      }
    }
  }

 private:
  // The chunks of one deep part, from its entries of the offset table at `table`. A deep
  // scanline chunk is [int32 part] int32 y, uint64 packed count-table size, uint64 packed
  // sample size, uint64 unpacked sample size; a deep tile has four int32 (tile x, y, level
  // x, y) instead of y.
  void deep_chunks(const Part& p, bool multipart, std::uint64_t table, HeaderFacts* facts) {
    const std::uint64_t ratio = exr_max_ratio(p.compression);
    if (ratio == 0 || p.compression > 3) fail("deep data with compression " + std::to_string(p.compression));
    const std::size_t head = (multipart ? 4 : 0) + (p.tiled ? 16 : 4) + 24;
    const long long lpc = lines_per_chunk(p.compression);
    std::uint64_t total = 0;
    std::vector<unsigned char> offsets;
    for (long long i = 0; i < p.chunks; ++i) {
      unsigned char b[8];
      if (!read_at(table + 8 * static_cast<std::uint64_t>(i), 8, b)) fail("cannot read its chunk table");
      const std::uint64_t at = le64(b);
      unsigned char h[44];
      if (at < pos_ || !read_at(at, head, h))
        fail("deep chunk " + std::to_string(i) + " lies past the end of the " + std::to_string(file_size_) +
             "-byte file");
      const unsigned char* s = h + head - 24;
      const std::uint64_t packed_table = le64(s), packed = le64(s + 8), unpacked = le64(s + 16);
      const std::uint64_t room = file_size_ - at - head;
      if (packed_table > room || packed > room - packed_table)
        fail("deep chunk " + std::to_string(i) + " declares " + std::to_string(packed_table + packed) +
             " bytes but only " + std::to_string(room) + " remain in the file");
      if (static_cast<u128>(unpacked) > static_cast<u128>(packed) * ratio)
        fail("deep chunk " + std::to_string(i) + " declares " + std::to_string(unpacked) +
             " bytes of samples, more than its " + std::to_string(packed) + " stored bytes can hold");
      // The sample-count table: one int32 per pixel of the chunk's lines / tile.
      const u128 counts = static_cast<u128>(p.tiled ? p.tile_w * p.tile_h : p.w * std::min(lpc, p.h)) * 4;
      if (packed_table == 0 || counts > static_cast<u128>(packed_table) * ratio)
        fail("deep chunk " + std::to_string(i) + " has a sample-count table of " + std::to_string(packed_table) +
             " bytes, too short for its pixels");
      total += unpacked;
      if (total > (std::uint64_t{1} << 62)) fail("deep sample data beyond 2^62 bytes");
    }
    if (facts) facts->deep_sample_bytes += total;
  }

  bool read_at(std::uint64_t pos, std::size_t n, unsigned char* out) {
    if (pos > file_size_ || n > file_size_ - pos) return false;
    f_.clear();
    f_.seekg(static_cast<std::streamoff>(pos));
    return static_cast<bool>(f_.read(reinterpret_cast<char*>(out), static_cast<std::streamsize>(n)));
  }

  // Reads one header; returns true if it was empty (a lone 0 byte).
  bool read_header(Part& part, std::size_t max_name) {
    std::set<std::string> names;
    for (int n = 0;; ++n) {
      const std::string name = read_string(max_name, "attribute name");
      if (name.empty()) return n == 0;
      // Names are unique within a header. OpenEXR's core library (the direct reader) keeps
      // the first of two, its C++ library (OpenImageIO) the last, and this walk the last: the
      // fuzzer found two dataWindows of 6778373×20 and 5×4 px, so the readers disagreed on the
      // size (a buffer overflow, then a 2 GB allocation past the checks above).
      if (!names.insert(name).second) fail("attribute '" + name + "' appears twice in one header");
      const std::string type = read_string(max_name, "attribute type");
      need(4, "attribute size");
      const std::int32_t size = le32(b_.data() + pos_);
      pos_ += 4;
      if (size < 0) fail("attribute '" + name + "' has a negative size");
      if (static_cast<std::size_t>(size) > file_size_ - pos_)
        fail("attribute '" + name + "' declares " + std::to_string(size) + " bytes but only " +
             std::to_string(file_size_ - pos_) + " remain in the file");
      need(static_cast<std::size_t>(size), "attribute value");
      const unsigned char* v = b_.data() + pos_;
      // OpenEXR's C++ library (OpenImageIO's reader) reads a value of a known type by the type,
      // not by the declared size: a size that disagrees makes it read the rest of the header
      // from another offset than this walk (and the core library) — a fuzzed 363-byte file
      // then declared a 1.9 GB opaque attribute to it and none to us.
      if (const int fixed = fixed_size(type); fixed >= 0 && size != fixed)
        fail("attribute '" + name + "' of type " + type + " declares " + std::to_string(size) + " bytes (a " + type +
             " has " + std::to_string(fixed) + ")");
      if (type == "chlist") {
        std::vector<Part::Channel> list;
        const bool ok = channel_list(v, static_cast<std::size_t>(size), list);
        if (name == "channels") {
          // OpenImageIO 2.4 aborts (an assertion) on a pixel type other than 0–2, and
          // OpenEXR reports a malformed list in several lines: refused here (found by
          // fuzz_layers).
          if (!ok)
            fail(
                "malformed channel list (a pixel type other than uint / half / float, a sampling below 1, or "
                "a list that does not end where its attribute does)");
          part.channels = std::move(list);
        } else if (!ok) {
          fail("attribute '" + name + "': malformed channel list (it does not end where its attribute does)");
        }
      }
      if ((name == "dataWindow" || name == "displayWindow") && type == "box2i") {  // 16 bytes: fixed_size above
        const long long x0 = le32(v), y0 = le32(v + 4), x1 = le32(v + 8), y1 = le32(v + 12);
        if (name == "dataWindow") {
          part.has_window = true;
          part.w = x1 - x0 + 1;
          part.h = y1 - y0 + 1;
        } else {
          part.has_display = true;
          part.display_w = x1 - x0 + 1;
          part.display_h = y1 - y0 + 1;
        }
      } else if (name == "compression" && size == 1) {
        part.compression = v[0];
      } else if (name == "tiles" && type == "tiledesc") {  // 9 bytes: fixed_size above
        part.tile_w = static_cast<std::uint32_t>(le32(v));
        part.tile_h = static_cast<std::uint32_t>(le32(v + 4));
      } else if (name == "type" && type == "string") {
        const std::string t(reinterpret_cast<const char*>(v), static_cast<std::size_t>(size));
        part.tiled = t == "tiledimage" || t == "deeptile";
        part.deep = t == "deepscanline" || t == "deeptile";
      } else if (name == "chunkCount" && size == 4) {
        part.chunk_count = le32(v);
        if (part.chunk_count < 0) fail("negative chunkCount");
      }
      pos_ += static_cast<std::size_t>(size);
    }
  }

  // The size in bytes of a value of a fixed-size attribute type, −1 for the variable ones
  // (string, stringvector, floatvector, chlist, preview, opaque types).
  static int fixed_size(const std::string& type) {
    static const std::pair<const char*, int> kSizes[] = {
        {"box2i", 16},      {"box2f", 16},    {"v2i", 8},      {"v2f", 8},           {"v2d", 16},
        {"v3i", 12},        {"v3f", 12},      {"v3d", 24},     {"m33f", 36},         {"m33d", 72},
        {"m44f", 64},       {"m44d", 128},    {"int", 4},      {"float", 4},         {"double", 8},
        {"compression", 1}, {"lineOrder", 1}, {"envmap", 1},   {"tiledesc", 9},      {"chromaticities", 32},
        {"keycode", 28},    {"timecode", 8},  {"rational", 8}, {"deepImageState", 1}};
    for (const auto& [t, n] : kSizes)
      if (type == t) return n;
    return -1;
  }

  // The channel list: `name\0 int32 type, uint8 pLinear, 3 reserved, int32 xSampling, int32
  // ySampling` per channel, ended by a 0 byte that is the attribute's last. False if malformed.
  static bool channel_list(const unsigned char* v, std::size_t size, std::vector<Part::Channel>& out) {
    out.clear();
    std::size_t i = 0;
    for (;;) {
      if (i >= size) return false;
      if (v[i] == 0) return i + 1 == size;
      while (i < size && v[i] != 0) ++i;
      if (i + 1 + 16 > size) return false;
      const unsigned char* e = v + i + 1;
      const std::int32_t type = le32(e), xs = le32(e + 8), ys = le32(e + 12);
      if (type < 0 || type > 2 || xs < 1 || ys < 1) return false;
      out.push_back({type == 1 ? 2 : 4, xs, ys});
      i += 1 + 16;
    }
  }

  std::string read_string(std::size_t max_len, const char* what) {
    std::size_t end = pos_;
    for (;;) {
      while (end < b_.size() && b_[end] != 0) {
        if (end - pos_ >= max_len) fail(std::string(what) + " is too long");
        ++end;
      }
      if (end < b_.size()) break;
      if (!more()) ran_out(what);
    }
    std::string s(reinterpret_cast<const char*>(b_.data() + pos_), end - pos_);
    pos_ = end + 1;
    return s;
  }

  void need(std::size_t n, const char* what) {
    while (n > b_.size() - std::min(b_.size(), pos_))
      if (!more()) ran_out(what);
  }

  [[noreturn]] void ran_out(const char* what) const {
    if (b_.size() < file_size_) fail(std::string("header larger than ") + std::to_string(kMaxHeaderBytes) + " bytes");
    fail(std::string("header ends inside an ") + what);
  }

  // Extends the buffer (doubling, at least 64 KiB, at most cap_); false once cap_ is read.
  bool more() {
    const std::size_t old = b_.size();
    if (old >= cap_) return false;
    const std::size_t grown = std::min(cap_, std::max<std::size_t>(2 * old, 64u << 10));
    b_.resize(grown);
    f_.clear();
    f_.seekg(static_cast<std::streamoff>(old));
    if (!f_.read(reinterpret_cast<char*>(b_.data() + old), static_cast<std::streamsize>(grown - old))) {
      b_.resize(old);
      return false;
    }
    return true;
  }

  std::ifstream& f_;
  std::size_t cap_;
  std::vector<unsigned char> b_;
  std::size_t file_size_;
  const std::string& path_;
  const char* role_;
  std::size_t pos_ = 0;
};

// --- PNG ---------------------------------------------------------------------------------

// PNG: 8-byte signature, then chunks `uint32 length (big-endian), type[4], data, crc`. Decoders
// allocate a chunk's declared length before reading it (libpng: text and unknown chunks), so
// every chunk up to IEND must fit in the file. Only the chunk heads and IHDR's data are read.
// The IDAT chunks must also be able to inflate to the pixels IHDR declares (kMaxDeflateRatio).
void check_png(std::ifstream& f, std::size_t file_size, const std::string& path, const char* role, HeaderFacts* facts) {
  auto fail = [&](const std::string& why) {
    throw_bad_input(path + ": cannot read " + role + " image: not a valid PNG: " + why);
  };
  const auto be32 = [](const unsigned char* p) {
    return static_cast<std::uint32_t>(p[0]) << 24 | static_cast<std::uint32_t>(p[1]) << 16 |
           static_cast<std::uint32_t>(p[2]) << 8 | p[3];
  };
  std::size_t pos = 8;
  std::uint64_t pixel_bits = 0, idat_bytes = 0;  // pixel_bits: 0 unless IHDR came first and parsed
  std::uint32_t w = 0, h = 0;
  for (bool first = true;; first = false) {
    if (file_size - pos < 12) fail("file is truncated (no IEND chunk)");
    unsigned char head[8];
    f.seekg(static_cast<std::streamoff>(pos));
    if (!f.read(reinterpret_cast<char*>(head), 8)) fail("cannot read a chunk header");
    const std::uint32_t len = be32(head);
    std::string type(reinterpret_cast<const char*>(head + 4), 4);
    for (char& c : type)
      if (!std::isalpha(static_cast<unsigned char>(c))) c = '?';
    if (len > file_size - pos - 12)
      fail("chunk '" + type + "' declares " + std::to_string(len) + " bytes but only " +
           std::to_string(file_size - pos - 12) + " remain in the file");
    if (first && type == "IHDR" && len == 13) {
      unsigned char d[13];
      if (!f.read(reinterpret_cast<char*>(d), 13)) fail("cannot read IHDR");
      w = be32(d);
      h = be32(d + 4);
      static const int samples[7] = {1, 0, 3, 1, 2, 0, 4};  // per colour type; 0 = invalid
      if (d[9] < 7 && samples[d[9]] > 0 && d[8] >= 1 && d[8] <= 16)
        pixel_bits = static_cast<std::uint64_t>(samples[d[9]]) * d[8];
    }
    if (type == "IDAT") idat_bytes += len;
    pos += 12 + static_cast<std::size_t>(len);
    if (type == "IEND") break;
  }
  // Every pixel's bits are in the inflated stream (interlaced or not), so at least ⌈W·bits/8⌉
  // bytes per row.
  if (pixel_bits > 0 && w > 0 && h > 0) {
    check_budget(w, h, path, role);
    if (facts) facts->width = w, facts->height = h;
    const u128 need = static_cast<u128>((static_cast<std::uint64_t>(w) * pixel_bits + 7) / 8) * h;
    if (need > static_cast<u128>(idat_bytes) * kMaxDeflateRatio) too_short(path, role, w, h, idat_bytes);
  }
}

// --- TIFF / BigTIFF ----------------------------------------------------------------------

// The TIFF codecs dofkit reads and the most each can expand the bytes it stores. A codec
// without such a bound is refused (CCITT fax and JBIG code a blank row in a bit or two, so a
// 16 KB G4 file can declare 16000² px; WebP and LERC code a flat image in a few bytes).
//   LZW: a code of at least 9 bits stands for a string of at most 4096 bytes. PackBits: a
//   2-byte run codes 128 bytes. zstd: a block holds at most 128 KiB, and the cheapest, a run
//   of one byte, takes 4 bytes. LZMA: every decision of its range coder costs at least
//   -log2(2017/2048) = 0.022 bit and the longest match (273 bytes) takes 14 decisions, so
//   ≤ 7084:1 (8192 here). JPEG: counted in pixels, not bytes (kJpegPixelsPerByte).
std::uint64_t tiff_max_ratio(std::uint32_t compression) {
  switch (compression) {
    case 1:
      return 1;  // none
    case 5:
      return 4096 * 8 / 9 + 1;  // LZW
    case 8:
    case 32946:
      return kMaxDeflateRatio;  // deflate (Adobe, and the old code)
    case 32773:
      return 64;  // PackBits
    case 50000:
      return 32768;  // zstd
    case 34925:
      return 8192;  // LZMA
    default:
      return 0;
  }
}

// JPEG (any flavour dofkit decodes: Huffman-coded, sequential or progressive) spends at least
// one bit on every 8×8 block of every component (a DC difference code; in progressive files
// the first DC scan), so a stored byte holds at most 8 blocks = 512 pixels of one component.
constexpr std::uint64_t kJpegPixelsPerByte = 512;

const char* tiff_compression_name(std::uint32_t c) {
  switch (c) {
    case 2:
      return "CCITT modified Huffman";
    case 3:
      return "CCITT group 3 fax";
    case 4:
      return "CCITT group 4 fax";
    case 6:
      return "old-style JPEG";
    case 32809:
      return "ThunderScan";
    case 32908:
    case 32909:
      return "Pixar";
    case 34661:
      return "JBIG";
    case 34676:
    case 34677:
      return "SGI LogLuv";
    case 34712:
      return "JPEG 2000";
    case 34887:
      return "LERC";
    case 34925:
      return "LZMA";
    case 50000:
      return "Zstandard";
    case 50001:
      return "WebP";
    default:
      return "unknown";
  }
}

// Classic TIFF: "II*\0" / "MM\0*", uint32 offset of the first IFD; an IFD is a uint16 entry
// count, 12-byte entries (uint16 tag, uint16 type, uint32 count, 4-byte value-or-offset) and
// the uint32 offset of the next IFD. BigTIFF: "II+\0" / "MM\0+", uint16 8 (offset size),
// uint16 0, uint64 offset of the first IFD; an IFD is a uint64 count, 20-byte entries (tag,
// type, uint64 count, 8-byte value-or-offset) and a uint64 next offset.
// OIIO 2.4 reads a strip or tile that lies (partly) past the end of the file as zeros and
// reports success, so a truncated TIFF would load as a silently black image: every
// strip/tile (offset, byte count) pair of every IFD must lie inside the file.
void check_tiff(std::ifstream& f, std::size_t file_size, bool big_endian, bool big, const std::string& path,
                const char* role, HeaderFacts* facts) {
  auto fail = [&](const std::string& why) {
    throw_bad_input(path + ": cannot read " + role + " image: not a valid TIFF: " + why);
  };
  Bytes file(f, file_size);
  auto u16 = [&](const unsigned char* p) -> std::uint32_t {
    return big_endian ? (std::uint32_t(p[0]) << 8 | p[1]) : (std::uint32_t(p[1]) << 8 | p[0]);
  };
  auto u32 = [&](const unsigned char* p) -> std::uint32_t {
    return big_endian ? (std::uint32_t(p[0]) << 24 | std::uint32_t(p[1]) << 16 | std::uint32_t(p[2]) << 8 | p[3])
                      : (std::uint32_t(p[3]) << 24 | std::uint32_t(p[2]) << 16 | std::uint32_t(p[1]) << 8 | p[0]);
  };
  auto u64 = [&](const unsigned char* p) -> std::uint64_t {
    return big_endian ? (std::uint64_t(u32(p)) << 32 | u32(p + 4)) : (std::uint64_t(u32(p + 4)) << 32 | u32(p));
  };
  // Sizes of the layout: offsets, entry counts and value fields.
  const std::size_t off_size = big ? 8 : 4, entry_size = big ? 20 : 12, count_size = big ? 8 : 2;
  auto offset = [&](const unsigned char* p) -> std::uint64_t { return big ? u64(p) : u32(p); };
  auto type_size = [](std::uint32_t type) -> std::size_t {
    return type == 3 ? 2 : type == 4 ? 4 : type == 16 ? 8 : 0;  // SHORT, LONG, LONG8
  };
  auto value_at = [&](std::uint32_t type, const unsigned char* p) -> std::uint64_t {
    return type == 3 ? u16(p) : type == 4 ? u32(p) : u64(p);
  };
  // Values of a SHORT/LONG/LONG8 array entry (inline when they fit the value field). Arrays
  // longer than the file could hold are themselves a defect.
  auto values = [&](const unsigned char* e, std::vector<std::uint64_t>& out) {
    const std::uint32_t type = u16(e + 2);
    const std::uint64_t count = big ? u64(e + 4) : u32(e + 4);
    const std::size_t size = type_size(type);
    const unsigned char* field = e + (big ? 12 : 8);
    if (size == 0) fail("strip/tile table of type " + std::to_string(type));
    if (count > file_size / size) fail("strip/tile table longer than the file");
    std::vector<unsigned char> raw(count * size);
    if (count == 0) {
      // an empty table: nothing to check (the decoder refuses an image without strips)
    } else if (count * size <= off_size) {
      std::memcpy(raw.data(), field, count * size);
    } else if (!file.read(offset(field), raw.size(), raw.data())) {
      fail("strip/tile table lies past the end of the file");
    }
    out.resize(count);
    for (std::uint64_t i = 0; i < count; ++i) out[i] = value_at(type, &raw[i * size]);
  };
  unsigned char head[16];
  if (big) {
    if (!file.read(4, 12, head)) fail("file is truncated (no BigTIFF header)");
    if (u16(head) != 8 || u16(head + 2) != 0) fail("BigTIFF header with offset size " + std::to_string(u16(head)));
  } else if (!file.read(4, 4, head + 4)) {
    return;
  }
  std::uint64_t ifd = big ? u64(head + 4) : u32(head + 4);
  std::vector<std::uint64_t> seen;
  while (ifd != 0) {
    if (std::find(seen.begin(), seen.end(), ifd) != seen.end()) fail("its directories form a loop");
    if (seen.size() >= 1024) fail("more than 1024 directories");
    seen.push_back(ifd);
    unsigned char cb[8];
    if (!file.read(ifd, count_size, cb))
      fail("directory offset " + std::to_string(ifd) + " is past the end of the file");
    const std::uint64_t n = big ? u64(cb) : u16(cb);
    if (n > (file_size - std::min<std::uint64_t>(file_size, ifd)) / entry_size)
      fail("directory runs past the end of the file");
    std::vector<unsigned char> entries(static_cast<std::size_t>(n) * entry_size + off_size);
    if (!file.read(ifd + count_size, entries.size(), entries.data())) fail("directory runs past the end of the file");
    std::vector<std::uint64_t> offsets, counts;
    // The first image's size, samples, bits and compression (what the readers decode).
    std::uint64_t w = 0, h = 0, spp = 1, bits = 0, compression = 1, photometric = 0;
    std::set<std::uint32_t> tags;
    for (std::uint64_t i = 0; i < n; ++i) {
      const unsigned char* e = &entries[static_cast<std::size_t>(i) * entry_size];
      const std::uint32_t tag = u16(e), type = u16(e + 2);
      // A tag is unique within a directory. libtiff keeps the first of two and ignores the
      // other (a warning), this walk would take the last: a fuzzed file with two heights
      // (3, then 32) was probed as 5x32 and read as 5x3.
      if (!tags.insert(tag).second) fail("tag " + std::to_string(tag) + " appears twice in one directory");
      const std::uint64_t count = big ? u64(e + 4) : u32(e + 4);
      const unsigned char* field = e + (big ? 12 : 8);
      if (tag == 273 || tag == 324) values(e, offsets);
      if (tag == 279 || tag == 325) values(e, counts);
      const std::size_t size = type_size(type);
      if (size > 0 && count >= 1) {
        const std::uint64_t v = value_at(type, field);  // the first value, when inline
        const bool inline_value = count * size <= off_size;
        if (tag == 256 && inline_value) w = v;
        if (tag == 257 && inline_value) h = v;
        if (tag == 277 && inline_value) spp = v;
        if (tag == 259 && inline_value) compression = v;
        if (tag == 262 && inline_value) photometric = v;
        if (tag == 258) {
          unsigned char b2[2];
          if (inline_value)
            bits = v;
          else if (type == 3 && file.read(offset(field), 2, b2))
            bits = u16(b2);
        }
      }
    }
    // Every directory in the main chain is an image and needs its data; OIIO reads an image
    // without strips as zeros.
    if (offsets.empty()) fail("directory " + std::to_string(seen.size() - 1) + " has no strips or tiles");
    if (offsets.size() != counts.size())
      fail(std::to_string(offsets.size()) + " strip/tile offsets but " + std::to_string(counts.size()) +
           " byte counts");
    for (std::size_t i = 0; i < offsets.size(); ++i)
      if (offsets[i] > file_size || counts[i] > file_size - offsets[i])
        fail("strip/tile " + std::to_string(i) + " (" + std::to_string(counts[i]) + " bytes at offset " +
             std::to_string(offsets[i]) + ") lies past the end of the " + std::to_string(file_size) + "-byte file");
    if (seen.size() == 1) {
      // The image the readers decode: a codec dofkit bounds, and pixels that fit what its
      // strips / tiles can expand to (else a truncated or corrupt file, refused before a
      // reader allocates the pixels, as for PNG and EXR).
      const std::uint64_t ratio = tiff_max_ratio(static_cast<std::uint32_t>(compression));
      if (ratio == 0 && compression != 7)
        throw_bad_input(path + ": cannot read " + role + " image: TIFF compression " + std::to_string(compression) +
                        " (" + tiff_compression_name(static_cast<std::uint32_t>(compression)) +
                        ") is not supported; dofkit reads uncompressed, LZW, deflate, PackBits, zstd, LZMA and JPEG "
                        "TIFFs");
      if (w > 0 && h > 0) {
        check_budget(static_cast<long long>(w), static_cast<long long>(h), path, role);
        if (facts) {
          facts->width = static_cast<long long>(w);
          facts->height = static_cast<long long>(h);
          facts->channels = static_cast<int>(std::min<std::uint64_t>(spp, 1 << 16));
        }
        std::uint64_t stored = 0;
        for (std::uint64_t c : counts) stored += c;
        // YCbCr (6) may store subsampled chroma: only the luma samples are certain.
        const std::uint64_t samples = photometric == 6 ? 1 : std::max<std::uint64_t>(spp, 1);
        const u128 px = static_cast<u128>(w) * h;
        const bool short_data = compression == 7
                                    ? px > static_cast<u128>(stored) * kJpegPixelsPerByte
                                    : bits > 0 && px * samples * bits / 8 > static_cast<u128>(stored) * ratio;
        if (short_data) too_short(path, role, static_cast<long long>(w), static_cast<long long>(h), stored);
      }
    }
    ifd = offset(&entries[static_cast<std::size_t>(n) * entry_size]);
  }
}

// --- JPEG --------------------------------------------------------------------------------

// JPEG: SOI (FF D8), then segments `FF marker, uint16 length (big-endian, including itself),
// data`; after a start-of-scan (SOS) segment the entropy-coded data runs up to the next marker
// that is not a stuffed FF 00 or a restart marker; the file ends with EOI (FF D9). The walk
// reads the frame header (SOFn: precision, height, width, components with their sampling
// factors) and every scan, and refuses: a file without EOI (truncated: libjpeg would only
// warn and decode grey for the missing rows), no frame or no scan, arithmetic coding (no
// bound on its expansion), a component no scan codes, and a scan whose blocks need more bits
// than its data has. Huffman coding spends at least one bit per 8×8 block on its DC
// difference (progressive: the first DC scan; refinement: one bit), and a sequential scan one
// more on the end-of-block code, so a 649-byte file cannot declare 16000² px.
void check_jpeg(std::ifstream& f, std::size_t file_size, const std::string& path, const char* role,
                HeaderFacts* facts) {
  auto fail = [&](const std::string& why) {
    throw_bad_input(path + ": cannot read " + role + " image: not a valid JPEG: " + why);
  };
  // Buffered forward reading (the entropy data is scanned byte by byte).
  std::vector<unsigned char> buf(1 << 16);
  std::uint64_t buf_pos = 0, buf_len = 0, pos = 2;
  auto byte_at = [&](std::uint64_t p, unsigned char& out) {
    if (p >= file_size) return false;
    if (p < buf_pos || p >= buf_pos + buf_len) {
      buf_pos = p;
      buf_len = std::min<std::uint64_t>(buf.size(), file_size - p);
      f.clear();
      f.seekg(static_cast<std::streamoff>(p));
      if (!f.read(reinterpret_cast<char*>(buf.data()), static_cast<std::streamsize>(buf_len))) {
        buf_len = 0;
        return false;
      }
    }
    out = buf[p - buf_pos];
    return true;
  };
  auto be16_at = [&](std::uint64_t p, std::uint32_t& out) {
    unsigned char a, b;
    if (!byte_at(p, a) || !byte_at(p + 1, b)) return false;
    out = std::uint32_t(a) << 8 | b;
    return true;
  };
  struct Component {
    int id, h, v;
    std::uint64_t blocks = 0;
    bool coded = false;  // in a (first DC) scan
  };
  std::vector<Component> comps;
  bool frame = false, progressive = false, lossless = false;
  long long width = 0, height = 0;
  int scans = 0;
  for (;;) {
    // The next marker: FF, any fill FFs, then the code.
    unsigned char b = 0;
    if (!byte_at(pos, b)) fail("it ends before its end-of-image marker (truncated)");
    if (b != 0xff) fail("no marker at byte " + std::to_string(pos));
    while (byte_at(pos + 1, b) && b == 0xff) ++pos;
    if (!byte_at(pos + 1, b)) fail("it ends before its end-of-image marker (truncated)");
    const unsigned marker = b;
    pos += 2;
    if (marker == 0xd9) break;                                           // EOI
    if (marker == 0x01 || (marker >= 0xd0 && marker <= 0xd7)) continue;  // TEM, stray RSTn
    if (marker == 0xd8 || marker == 0x00) fail("unexpected marker " + std::to_string(marker));
    std::uint32_t len;
    if (!be16_at(pos, len)) fail("it ends before its end-of-image marker (truncated)");
    if (len < 2 || len > file_size - pos) fail("a segment runs past the end of the file (truncated)");
    const std::uint64_t seg = pos + 2, seg_end = pos + len;
    const bool sof = marker >= 0xc0 && marker <= 0xcf && marker != 0xc4 && marker != 0xc8 && marker != 0xcc;
    if (sof) {
      if (frame) fail("two frame headers");
      frame = true;
      if (marker >= 0xc9) fail("arithmetic coding is not supported");
      if (marker == 0xc5 || marker == 0xc6 || marker == 0xc7) fail("hierarchical JPEG is not supported");
      progressive = marker == 0xc2;
      lossless = marker == 0xc3;
      std::uint32_t hh = 0, ww = 0;
      unsigned char nf = 0;
      if (len < 8 || !be16_at(seg + 1, hh) || !be16_at(seg + 3, ww) || !byte_at(seg + 5, nf))
        fail("frame header too short");
      if (hh == 0) fail("height 0 (a DNL marker) is not supported");
      if (ww == 0) fail("width 0");
      if (nf < 1 || nf > 4) fail(std::to_string(nf) + " components (dofkit reads 1, 3 or 4)");
      if (len < 8u + 3u * nf) fail("frame header too short");
      width = ww;
      height = hh;
      int hmax = 1, vmax = 1;
      for (unsigned i = 0; i < nf; ++i) {
        unsigned char id = 0, hv = 0;
        byte_at(seg + 6 + 3 * i, id);
        byte_at(seg + 7 + 3 * i, hv);
        const int h = hv >> 4, v = hv & 15;
        if (h < 1 || h > 4 || v < 1 || v > 4) fail("sampling factors outside 1..4");
        comps.push_back({id, h, v});
        hmax = std::max(hmax, h);
        vmax = std::max(vmax, v);
      }
      check_budget(width, height, path, role);
      for (Component& c : comps) {
        // The component's samples (ceil(W·h/hmax) × ceil(H·v/vmax)) in 8×8 blocks; lossless
        // JPEG codes every sample (a block of one).
        const std::uint64_t cw = (static_cast<std::uint64_t>(width) * c.h + hmax - 1) / hmax;
        const std::uint64_t ch = (static_cast<std::uint64_t>(height) * c.v + vmax - 1) / vmax;
        c.blocks = lossless ? cw * ch : ((cw + 7) / 8) * ((ch + 7) / 8);
      }
    } else if (marker == 0xda) {
      if (!frame) fail("a scan before the frame header");
      unsigned char ns = 0;
      if (!byte_at(seg, ns) || ns < 1 || ns > 4 || len < 6u + 2u * ns) fail("scan header too short");
      unsigned char ss = 0, se = 0, a = 0;
      byte_at(seg + 1 + 2 * ns, ss);
      byte_at(seg + 2 + 2 * ns, se);
      byte_at(seg + 3 + 2 * ns, a);
      const int ah = a >> 4;
      // Bits this scan must spend per block of each of its components.
      const int bits = lossless ? 1 : !progressive ? 2 : ss == 0 ? 1 : 0;
      std::uint64_t need_bits = 0;
      for (unsigned i = 0; i < ns; ++i) {
        unsigned char id = 0;
        byte_at(seg + 1 + 2 * i, id);
        auto c = std::find_if(comps.begin(), comps.end(), [&](const Component& k) { return k.id == id; });
        if (c == comps.end()) fail("a scan codes component " + std::to_string(id) + ", which the frame lacks");
        need_bits += c->blocks * bits;
        if (!progressive || (ss == 0 && ah == 0)) c->coded = true;
      }
      (void)se;
      // The entropy-coded data: up to a marker other than FF 00 (stuffing) and RSTn.
      std::uint64_t p = seg_end, data = 0;
      for (;;) {
        unsigned char x = 0, y = 0;
        if (!byte_at(p, x)) fail("it ends inside its image data (truncated)");
        if (x == 0xff) {
          if (!byte_at(p + 1, y)) fail("it ends inside its image data (truncated)");
          if (y == 0x00 || (y >= 0xd0 && y <= 0xd7)) {
            p += 2;
            data += 2;
            continue;
          }
          if (y == 0xff) {  // fill bytes before a marker
            ++p;
            continue;
          }
          break;
        }
        ++p;
        ++data;
      }
      if (static_cast<u128>(need_bits) > static_cast<u128>(data) * 8) too_short(path, role, width, height, data);
      ++scans;
      pos = p;
      continue;
    }
    pos = seg_end;
  }
  if (!frame) fail("no frame header");
  if (scans == 0) fail("no image data");
  for (const Component& c : comps)
    if (!c.coded) fail("component " + std::to_string(c.id) + " is in no scan (truncated or corrupt)");
  if (facts) facts->width = width, facts->height = height, facts->channels = static_cast<int>(comps.size());
}

// The walk proper, by the file's first bytes.
void walk(const std::string& path, const char* role, std::uint64_t size, HeaderFacts* facts) {
  // Only the four formats dofkit documents are read; any other file (BMP, GIF, HDR, PSD, …,
  // which OpenImageIO would decode without these checks) is refused.
  const auto not_an_image = [&] {
    throw_bad_input(path + ": cannot read " + role + " image: not an EXR, PNG, JPEG or TIFF file" +
                    (size == 0 ? " (it is empty)" : ""));
  };
  std::ifstream f(path, std::ios::binary);
  if (!f) return;  // vanished since it was opened: the decoder reports it
  if (looks_like_heif(path)) {
    // A HEIF/HEIC photo: libheif reads its boxes (phone_depth.hpp).
    const HeifInfo h = probe_heif(path, role);
    if (facts) facts->width = h.width, facts->height = h.height, facts->channels = h.channels;
    return;
  }
  if (size < 3) not_an_image();
  const std::size_t file_size = static_cast<std::size_t>(size);
  unsigned char magic[8] = {};
  if (!f.read(reinterpret_cast<char*>(magic), static_cast<std::streamsize>(std::min<std::uint64_t>(8, size)))) return;
  if (magic[0] == 0xff && magic[1] == 0xd8 && magic[2] == 0xff) return check_jpeg(f, file_size, path, role, facts);
  if (size < 8) not_an_image();
  static const unsigned char png_sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (std::memcmp(magic, png_sig, 8) == 0) return check_png(f, file_size, path, role, facts);
  if (magic[0] == 'I' && magic[1] == 'I' && (magic[2] == 42 || magic[2] == 43) && magic[3] == 0)
    return check_tiff(f, file_size, false, magic[2] == 43, path, role, facts);
  if (magic[0] == 'M' && magic[1] == 'M' && magic[2] == 0 && (magic[3] == 42 || magic[3] == 43))
    return check_tiff(f, file_size, true, magic[3] == 43, path, role, facts);
  const bool exr = magic[0] == 0x76 && magic[1] == 0x2f && magic[2] == 0x31 && magic[3] == 0x01;
  if (!exr) not_an_image();
  Walker walker(f, file_size, path, role);
  if (walker.start()) walker.run(facts);
}

struct stat checked_stat(const std::string& path, const char* role) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) refuse_open(path, role, errno);
  refuse_kind(st, path, role);
  // O_NONBLOCK: a fifo swapped in after the stat opens without waiting for a writer (and is
  // refused below); it has no effect on a regular file.
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_NOCTTY | O_CLOEXEC);
  if (fd < 0) refuse_open(path, role, errno);
  const int ok = ::fstat(fd, &st);
  ::close(fd);
  if (ok != 0) refuse_open(path, role, errno);
  refuse_kind(st, path, role);
  return st;
}

// The last files walked (a command probes its inputs' headers before it reads them, and the
// read walks them again): the same path, inode, size, modification time and pixel budget
// give the same result without reading the file again.
struct Walked {
  std::string path;
  dev_t dev;
  ino_t ino;
  off_t size;
  long long mtime_ns;
  long long budget;
  HeaderFacts facts;
};
std::mutex g_walked_mutex;
std::vector<Walked> g_walked;

long long mtime_ns(const struct stat& st) {
  return static_cast<long long>(st.st_mtim.tv_sec) * 1000000000LL + st.st_mtim.tv_nsec;
}

}  // namespace

std::uint64_t check_input_file(const std::string& path, const char* role) {
  return static_cast<std::uint64_t>(checked_stat(path, role).st_size);
}

void check_file_header(const std::string& path, const char* role, HeaderFacts* facts) {
  const struct stat st = checked_stat(path, role);
  {
    const std::lock_guard<std::mutex> lock(g_walked_mutex);
    for (const Walked& w : g_walked)
      if (w.path == path && w.dev == st.st_dev && w.ino == st.st_ino && w.size == st.st_size &&
          w.mtime_ns == mtime_ns(st) && w.budget == pixel_budget()) {
        if (facts) *facts = w.facts;
        return;
      }
  }
  HeaderFacts found;
  walk(path, role, static_cast<std::uint64_t>(st.st_size), &found);  // throws for a bad file
  if (facts) *facts = found;
  const std::lock_guard<std::mutex> lock(g_walked_mutex);
  if (g_walked.size() >= 16) g_walked.erase(g_walked.begin());
  g_walked.push_back({path, st.st_dev, st.st_ino, st.st_size, mtime_ns(st), pixel_budget(), found});
}

}  // namespace dofkit::io
