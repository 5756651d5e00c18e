// JPEG read and written without OpenImageIO, through libjpeg (libjpeg-turbo) directly.
//
// Why: with the common EXRs and PNGs direct, a photograph's call (a JPEG in, often a JPEG
// out) was the one that still loaded OpenImageIO: ~0.2 s of dynamic linking of its ~260
// libraries before the first pixel. libjpeg is what OpenImageIO decodes and encodes with, and
// it is called here with the same settings — decoding: libjpeg's defaults (accurate integer
// DCT, smooth chroma upsampling) into RGB or grey; encoding: libjpeg's defaults, the quality
// with baseline tables, 4:2:0 chroma, the float samples quantised with OpenImageIO's rule — so
// the pixels are the ones OpenImageIO gave (tested against it).
//
// Files libjpeg cannot read as 8-bit grey / YCbCr / RGB (CMYK, YCCK, 12-bit) go to
// OpenImageIO. A file this reader takes whose decoding raises a libjpeg error *or warning*
// (corrupt or truncated data, which libjpeg would decode anyway: grey rows for the missing
// part of a truncated file) is refused with libjpeg's message; it is not handed on.
#pragma once
#include <memory>
#include <string>
#include <vector>

namespace dofkit::io::jpeg {

/// Writes a baseline JPEG straight into `file` (no temporary: the caller's AtomicFile /
/// OutputSet provides it). `pixels`: width·height·channels floats, pixel-interleaved, in the
/// file's encoding (sRGB); channels 1 (grey) or 3 (RGB); quality 1–100. Throws
/// Error(bad_input) naming `display_path` on a write error.
void write(const std::string& file, const std::string& display_path, int width, int height, int channels,
           const float* pixels, int quality);

/// A JPEG this reader takes (see above), its header read.
class Reader {
 public:
  /// nullptr if `path` is not such a file (the caller then uses OpenImageIO); then `broken`
  /// (when given) holds libjpeg's message if its header is damaged. Never throws for a bad
  /// file.
  static std::unique_ptr<Reader> open(const std::string& path, std::string* broken = nullptr);

  int width() const { return width_; }
  int height() const { return height_; }
  /// OpenImageIO's channel names: Y | R G B.
  const std::vector<std::string>& names() const { return names_; }

  /// Reads channels [cb, ce) as float (code · (1 / 255), as OpenImageIO gives them),
  /// pixel-interleaved: W·H·(ce − cb) values. False on any libjpeg error or warning; then
  /// `broken` (when given) holds libjpeg's first message.
  bool read(int cb, int ce, float* out, std::string* broken = nullptr) const;

 private:
  Reader() = default;
  std::string path_;
  int width_ = 0, height_ = 0;
  std::vector<std::string> names_;
};

}  // namespace dofkit::io::jpeg
