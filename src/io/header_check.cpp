// EXR header walk, see header_check.hpp. Layout (OpenEXR file format, "Technical
// Introduction"): magic 76 2f 31 01; int32 version + flags (0x200 single-part tiled, 0x400
// long names, 0x800 deep, 0x1000 multi-part); then one header (several for multi-part, the
// list ended by an empty header) of attributes `name\0 type\0 int32 size, value[size]`,
// each header ended by a 0 byte; then the chunk offset table (uint64 per chunk).
#include "io/header_check.hpp"

#include <algorithm>
#include <cstdint>
#include <cctype>
#include <cstring>
#include <fstream>
#include <set>
#include <string>
#include <vector>

#include "dofkit/error.hpp"
#include "io/image_io.hpp"

namespace dofkit::io {

namespace {

constexpr std::size_t kMaxHeaderBytes = 16u << 20;  // attributes beyond this are not a real header

// Deflate expands at most 1032:1 (a 258-byte match coded in two bits), so n deflated bytes
// decode to at most 1032·n. A payload shorter than the declared pixels need at that ratio is
// a truncated or corrupt file, refused before any decoder allocates the pixels (the fuzzer
// found a 380-byte PNG declaring 2,000,000 × 60 px: 1.3 GB allocated, then the inflate failed).
constexpr std::uint64_t kMaxDeflateRatio = 1032;

// The pixel budget (image_io.hpp), checked on the header's size (the open checks it again on
// the size the reader reports).
void check_budget(long long w, long long h, const std::string& path, const char* role) {
  const long long budget = pixel_budget();
  if (w > budget || h > budget || w * h > budget)
    throw_bad_input(path + ": " + role + " image declares " + std::to_string(w) + "x" + std::to_string(h) +
                    " pixels, more than the limit of " + std::to_string(budget) + " (--max-pixels)");
}

// The most an EXR compression can expand the bytes it stores, for the codes this check
// covers; 0 = not bounded here (PIZ's Huffman run codes, B44's flat blocks, DWA).
std::uint64_t exr_max_ratio(int compression) {
  switch (compression) {
    case 0:
      return 1;  // NONE
    case 1:
      return 64;  // RLE: a 2-byte run codes at most 128 bytes
    case 2:
    case 3:
      return kMaxDeflateRatio;  // ZIPS, ZIP
    case 5:
      return kMaxDeflateRatio * 4 / 3 + 1;  // PXR24: float samples stored as 3 deflated bytes
    default:
      return 0;
  }
}

std::int32_t le32(const unsigned char* p) {
  return static_cast<std::int32_t>(static_cast<std::uint32_t>(p[0]) | static_cast<std::uint32_t>(p[1]) << 8 |
                                   static_cast<std::uint32_t>(p[2]) << 16 | static_cast<std::uint32_t>(p[3]) << 24);
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
  int compression = 0;
  bool tiled = false;
  long long tile_w = 0, tile_h = 0;
  long long chunk_count = -1;
  bool deep = false;
  struct Channel {
    int bytes, xs, ys;  // sample size, x / y sampling
  };
  std::vector<Channel> channels;  // empty if the list was missing or did not parse
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

  void run() {
    const std::int32_t version = le32(b_.data() + 4);
    const bool single_tiled = version & 0x200, long_names = version & 0x400, multipart = version & 0x1000;
    const std::size_t max_name = long_names ? 256 : 32;
    pos_ = 8;
    std::vector<Part> parts;
    for (;;) {
      Part part;
      part.tiled = single_tiled && !multipart;
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
    for (const Part& p : parts) {
      if (!p.has_window) fail("a header has no dataWindow");
      if (p.w <= 0 || p.h <= 0) fail("empty or inverted dataWindow");
      check_budget(p.w, p.h, path_, role_);
      if (p.chunk_count >= 0) {
        chunks += p.chunk_count;
      } else if (p.tiled) {
        if (p.tile_w <= 0 || p.tile_h <= 0) fail("tiled image without a valid tile size");
        chunks += ((p.w + p.tile_w - 1) / p.tile_w) * ((p.h + p.tile_h - 1) / p.tile_h);
      } else {
        const long long lpc = lines_per_chunk(p.compression);
        chunks += (p.h + lpc - 1) / lpc;
      }
    }
    const long long table_bytes = chunks * 8;
    const long long after_header = static_cast<long long>(file_size_ - std::min(file_size_, pos_));
    if (table_bytes > after_header)
      fail("file is truncated (its chunk table needs " + std::to_string(table_bytes) + " bytes, " +
           std::to_string(after_header) + " remain)");
    // A single-part scanline image: its pixels must fit the bytes after the table at the
    // compression's largest ratio.
    if (parts.size() == 1 && !parts[0].tiled && !parts[0].deep && !parts[0].channels.empty()) {
      const Part& p = parts[0];
      const std::uint64_t ratio = exr_max_ratio(p.compression);
      unsigned __int128 need = 0;  // a channel sampled every (xs, ys) px stores ≥ ⌊W/xs⌋·⌊H/ys⌋ samples
      for (const Part::Channel& c : p.channels)
        need += static_cast<unsigned __int128>(c.bytes) * static_cast<std::uint64_t>(p.w / c.xs) *
                static_cast<std::uint64_t>(p.h / c.ys);
      const std::uint64_t have = static_cast<std::uint64_t>(after_header - table_bytes);
      if (ratio > 0 && need > static_cast<unsigned __int128>(have) * ratio)
        throw_bad_input(path_ + ": cannot read " + role_ + " image: its " + std::to_string(p.w) + "x" +
                        std::to_string(p.h) + " pixels need more bytes than its " + std::to_string(have) +
                        " bytes of pixel data can hold (truncated or corrupt)");
    }
  }

 private:
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
      if (name == "dataWindow" && type == "box2i" && size == 16) {
        const long long x0 = le32(v), y0 = le32(v + 4), x1 = le32(v + 8), y1 = le32(v + 12);
        part.has_window = true;
        part.w = x1 - x0 + 1;
        part.h = y1 - y0 + 1;
      } else if (name == "compression" && size == 1) {
        part.compression = v[0];
      } else if (name == "tiles" && type == "tiledesc" && size >= 8) {
        part.tile_w = static_cast<std::uint32_t>(le32(v));
        part.tile_h = static_cast<std::uint32_t>(le32(v + 4));
      } else if (name == "type" && type == "string") {
        const std::string t(reinterpret_cast<const char*>(v), static_cast<std::size_t>(size));
        part.tiled = t == "tiledimage" || t == "deeptile";
        part.deep = t == "deepscanline" || t == "deeptile";
      } else if (name == "channels" && type == "chlist") {
        part.channels = channel_list(v, static_cast<std::size_t>(size));
      } else if (name == "chunkCount" && size == 4) {
        part.chunk_count = le32(v);
        if (part.chunk_count < 0) fail("negative chunkCount");
      }
      pos_ += static_cast<std::size_t>(size);
    }
  }

  // The channel list: `name\0 int32 type, uint8 pLinear, 3 reserved, int32 xSampling, int32
  // ySampling` per channel, ended by a 0 byte. Empty if malformed (OpenEXR reports that).
  static std::vector<Part::Channel> channel_list(const unsigned char* v, std::size_t size) {
    std::vector<Part::Channel> out;
    std::size_t i = 0;
    for (;;) {
      if (i >= size) return {};
      if (v[i] == 0) return out;
      while (i < size && v[i] != 0) ++i;
      if (i + 1 + 16 > size) return {};
      const unsigned char* e = v + i + 1;
      const std::int32_t type = le32(e), xs = le32(e + 8), ys = le32(e + 12);
      if (type < 0 || type > 2 || xs < 1 || ys < 1) return {};
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

// PNG: 8-byte signature, then chunks `uint32 length (big-endian), type[4], data, crc`. Decoders
// allocate a chunk's declared length before reading it (libpng: text and unknown chunks), so
// every chunk up to IEND must fit in the file. Only the chunk heads and IHDR's data are read.
// The IDAT chunks must also be able to inflate to the pixels IHDR declares (kMaxDeflateRatio).
void check_png(std::ifstream& f, std::size_t file_size, const std::string& path, const char* role) {
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
    const unsigned __int128 need =
        static_cast<unsigned __int128>((static_cast<std::uint64_t>(w) * pixel_bits + 7) / 8) * h;
    if (need > static_cast<unsigned __int128>(idat_bytes) * kMaxDeflateRatio)
      throw_bad_input(path + ": cannot read " + role + " image: its " + std::to_string(w) + "x" + std::to_string(h) +
                      " pixels need more bytes than its " + std::to_string(idat_bytes) +
                      " bytes of image data can hold (truncated or corrupt)");
  }
}

// The most a TIFF compression can expand the bytes it stores; 0 = not bounded here (JPEG,
// zstd, LZMA, …). LZW: a code of at least 9 bits stands for a string of at most 4096 bytes.
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
      return 64;  // PackBits: a 2-byte run codes 128 bytes
    default:
      return 0;
  }
}

// TIFF (classic, not BigTIFF): "II*\0" / "MM\0*", uint32 offset of the first IFD; an IFD is a
// uint16 entry count, 12-byte entries (tag, type, count, value-or-offset) and the uint32 offset
// of the next IFD. OIIO 2.4 reads a strip or tile that lies (partly) past the end of the file as
// zeros and reports success, so a truncated TIFF would load as a silently black image: every
// strip/tile (offset, byte count) pair of every IFD must lie inside the file.
void check_tiff(std::ifstream& f, std::size_t file_size, bool big_endian, const std::string& path, const char* role) {
  auto fail = [&](const std::string& why) {
    throw_bad_input(path + ": cannot read " + role + " image: not a valid TIFF: " + why);
  };
  auto read_at = [&](std::size_t pos, std::size_t n, unsigned char* out) {
    if (pos > file_size || n > file_size - pos) return false;
    f.clear();
    f.seekg(static_cast<std::streamoff>(pos));
    return static_cast<bool>(f.read(reinterpret_cast<char*>(out), static_cast<std::streamsize>(n)));
  };
  auto u16 = [&](const unsigned char* p) -> std::uint32_t {
    return big_endian ? (std::uint32_t(p[0]) << 8 | p[1]) : (std::uint32_t(p[1]) << 8 | p[0]);
  };
  auto u32 = [&](const unsigned char* p) -> std::uint32_t {
    return big_endian ? (std::uint32_t(p[0]) << 24 | std::uint32_t(p[1]) << 16 | std::uint32_t(p[2]) << 8 | p[3])
                      : (std::uint32_t(p[3]) << 24 | std::uint32_t(p[2]) << 16 | std::uint32_t(p[1]) << 8 | p[0]);
  };
  // Values of a SHORT/LONG array entry (inline when they fit in 4 bytes). Arrays longer than
  // the file could hold are themselves a defect.
  auto values = [&](const unsigned char* e, std::vector<std::uint64_t>& out) {
    const std::uint32_t type = u16(e + 2), count = u32(e + 4);
    const std::size_t size = type == 3 ? 2 : type == 4 ? 4 : 0;
    if (size == 0) fail("strip/tile table of type " + std::to_string(type));
    if (count > file_size / size) fail("strip/tile table longer than the file");
    std::vector<unsigned char> raw(count * size);
    if (count == 0) {
      // an empty table: nothing to check (the decoder refuses an image without strips)
    } else if (count * size <= 4) {
      std::memcpy(raw.data(), e + 8, count * size);
    } else if (!read_at(u32(e + 8), raw.size(), raw.data())) {
      fail("strip/tile table lies past the end of the file");
    }
    out.resize(count);
    for (std::uint32_t i = 0; i < count; ++i) out[i] = size == 2 ? u16(&raw[i * 2]) : u32(&raw[i * 4]);
  };
  unsigned char b4[4];
  if (!read_at(4, 4, b4)) return;
  std::size_t ifd = u32(b4);
  std::vector<std::size_t> seen;
  while (ifd != 0) {
    if (std::find(seen.begin(), seen.end(), ifd) != seen.end()) fail("its directories form a loop");
    if (seen.size() >= 1024) fail("more than 1024 directories");
    seen.push_back(ifd);
    unsigned char b2[2];
    if (!read_at(ifd, 2, b2)) fail("directory offset " + std::to_string(ifd) + " is past the end of the file");
    const std::uint32_t n = u16(b2);
    std::vector<unsigned char> entries(static_cast<std::size_t>(n) * 12 + 4);
    if (!read_at(ifd + 2, entries.size(), entries.data())) fail("directory runs past the end of the file");
    std::vector<std::uint64_t> offsets, counts;
    // The first image's size, samples, bits and compression (what the readers decode).
    std::uint64_t w = 0, h = 0, spp = 1, bits = 0, compression = 1, photometric = 0;
    for (std::uint32_t i = 0; i < n; ++i) {
      const unsigned char* e = &entries[static_cast<std::size_t>(i) * 12];
      const std::uint32_t tag = u16(e), type = u16(e + 2), count = u32(e + 4);
      if (tag == 273 || tag == 324) values(e, offsets);
      if (tag == 279 || tag == 325) values(e, counts);
      if ((type == 3 || type == 4) && count >= 1) {
        const std::uint64_t v = type == 3 ? u16(e + 8) : u32(e + 8);  // the first value, when inline
        const bool inline_value = count * (type == 3 ? 2 : 4) <= 4;
        if (tag == 256 && inline_value) w = v;
        if (tag == 257 && inline_value) h = v;
        if (tag == 277 && inline_value) spp = v;
        if (tag == 259 && inline_value) compression = v;
        if (tag == 262 && inline_value) photometric = v;
        if (tag == 258) {
          unsigned char b2[2];
          if (inline_value)
            bits = v;
          else if (type == 3 && read_at(u32(e + 8), 2, b2))
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
    // Pixels that need more bytes than the strips / tiles can expand to: a truncated or
    // corrupt file, refused before a reader allocates the pixels (as for PNG and EXR).
    // YCbCr (6) may store subsampled chroma: fewer bytes than samples, so it is not bounded.
    if (seen.size() == 1 && w > 0 && h > 0 && bits > 0 && spp > 0 && photometric != 6) {
      check_budget(static_cast<long long>(w), static_cast<long long>(h), path, role);
      const std::uint64_t ratio = tiff_max_ratio(static_cast<std::uint32_t>(compression));
      std::uint64_t stored = 0;
      for (std::uint64_t c : counts) stored += c;
      const unsigned __int128 need = static_cast<unsigned __int128>(w) * spp * bits / 8 * h;
      if (ratio > 0 && need > static_cast<unsigned __int128>(stored) * ratio)
        throw_bad_input(path + ": cannot read " + role + " image: its " + std::to_string(w) + "x" + std::to_string(h) +
                        " pixels need more bytes than its " + std::to_string(stored) +
                        " bytes of image data can hold (truncated or corrupt)");
    }
    ifd = u32(&entries[static_cast<std::size_t>(n) * 12]);
  }
}

}  // namespace

void check_file_header(const std::string& path, const char* role) {
  std::ifstream f(path, std::ios::binary | std::ios::ate);
  if (!f) return;  // the caller reports missing / unreadable files
  const std::streamoff end = f.tellg();
  if (end < 8) return;
  const std::size_t file_size = static_cast<std::size_t>(end);
  unsigned char magic[8];
  f.seekg(0);
  if (!f.read(reinterpret_cast<char*>(magic), 8)) return;
  static const unsigned char png_sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (std::memcmp(magic, png_sig, 8) == 0) return check_png(f, file_size, path, role);
  if (magic[0] == 'I' && magic[1] == 'I' && magic[2] == 42 && magic[3] == 0)
    return check_tiff(f, file_size, false, path, role);
  if (magic[0] == 'M' && magic[1] == 'M' && magic[2] == 0 && magic[3] == 42)
    return check_tiff(f, file_size, true, path, role);
  const bool exr = magic[0] == 0x76 && magic[1] == 0x2f && magic[2] == 0x31 && magic[3] == 0x01;
  if (!exr) return;
  Walker walker(f, file_size, path, role);
  if (walker.start()) walker.run();
}

}  // namespace dofkit::io
