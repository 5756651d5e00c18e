// PNG written without OpenImageIO: rows quantised, filtered and deflated here, in parallel.
//
// Why: a 1080p PNG-out `dofkit render` call took ~1.05 s on 2 cores, and the render ~0.07 s of
// it. The rest was OpenImageIO's PNG writer — libpng with zlib on one core (45 % of the call's
// samples) — and loading OpenImageIO itself (~0.15 s, the module of oiio_module.hpp). Here
// the image is cut into blocks of rows that are deflated on all cores with zlib, each
// primed with the last 32 KiB of the rows before it (as pigz does), so the one zlib stream
// a PNG holds compresses as well as a serial one; the zlib level is the caller's, so
// `--png-level` keeps its meaning and the files their size.
//
// The samples are the ones OpenImageIO's writer stores for the same float values (tested
// against it, boundaries included): q = round(v·(2^bits − 1)) in float, halves away from
// zero, clamped to the range; NaN stores 0.
//
// Reading: every PNG is read here, OpenImageIO never sees one: the one zlib stream inflated by
// libdeflate (~3× zlib's speed), the rows unfiltered, and the samples expanded as libpng
// expands them for OpenImageIO (palette → RGB, 1/2/4-bit grey → 8 bits, tRNS → alpha,
// interlaced passes into place) and converted to float as OpenImageIO converts them. So a
// damaged PNG is refused here with the reason, on dofkit's one line, and libpng never prints
// its own "libpng error" line.
#pragma once
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace dofkit::io::png {

/// What write() needs: `pixels` holds width·height·channels floats, pixel-interleaved,
/// already in the file's encoding (sRGB-encoded colour, straight alpha).
struct Layout {
  int width = 0, height = 0;
  int channels = 0;  ///< 1 (grey), 2 (grey + alpha), 3 (RGB) or 4 (RGBA)
  int bits = 8;      ///< 8 or 16
};

/// Writes a non-interlaced PNG straight into `file` (no temporary: the caller's AtomicFile /
/// OutputSet provides it). `level` is the zlib level 0–9. `srgb` marks the file as sRGB
/// (sRGB, gAMA and cHRM chunks), else as linear (gAMA 1.0), as OpenImageIO's writer does.
/// Throws Error(bad_input) naming `display_path` on a write error, Error(internal) on a
/// layout it does not take.
void write(const std::string& file, const std::string& display_path, const Layout& layout, const float* pixels,
           int level, bool srgb);

/// A PNG, opened: the header parsed, every critical chunk's CRC checked.
///
/// A file that breaks the PNG rules is refused, with the reason: a critical chunk whose CRC
/// does not match, an IHDR, PLTE or tRNS that breaks the rules, a missing IEND (truncated),
/// unknown critical chunks, and (by read()) a stream that does not inflate to exactly the
/// rows, fails its Adler-32 check, holds an unknown row filter or a palette index beyond the
/// palette. Ancillary chunks with a bad CRC are skipped, as libpng skips them (they cannot
/// change the pixels); so are bytes after IEND.
class Reader {
 public:
  /// nullptr if `path` is not a PNG (no PNG signature) or cannot be opened; a PNG that is
  /// damaged gives nullptr with `broken` (when given) saying why. Never throws for a bad file.
  static std::unique_ptr<Reader> open(const std::string& path, std::string* broken = nullptr);

  int width() const { return width_; }
  int height() const { return height_; }
  /// OpenImageIO's channel names: Y | Y A | R G B | R G B A.
  const std::vector<std::string>& names() const { return names_; }
  int alpha_channel() const { return channels_ == 2 || channels_ == 4 ? channels_ - 1 : -1; }

  /// Reads channels [cb, ce) as float (code / (2^bits − 1) after the expansion above, as
  /// OpenImageIO gives them; alpha straight, as stored), pixel-interleaved: W·H·(ce − cb)
  /// values. False, with `broken` (when given) saying why, if the data is damaged (above).
  bool read(int cb, int ce, float* out, std::string* broken = nullptr) const;

 private:
  Reader() = default;
  int width_ = 0, height_ = 0, channels_ = 0, bits_ = 8;  // what the file expands to
  int depth_ = 8, ctype_ = 0;                             // the file's own bit depth, colour type
  bool interlaced_ = false;
  std::vector<std::uint8_t> palette_;        // RGB per entry (palette images)
  std::vector<std::uint8_t> palette_alpha_;  // tRNS alpha per entry (palette images)
  std::uint16_t key_[3] = {0, 0, 0};         // tRNS key colour (grey / RGB images)
  bool key_alpha_ = false;                   // tRNS present: the file expands to an alpha channel
  std::vector<std::string> names_;
  std::vector<std::uint8_t> stream_;  // the IDAT chunks' data, concatenated (one zlib stream)
};

}  // namespace dofkit::io::png
