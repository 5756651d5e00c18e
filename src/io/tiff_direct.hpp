// TIFF written without OpenImageIO: the file OpenImageIO's writer (libtiff) makes, strips
// deflated on all cores.
//
// Why: a 1080p TIFF-out `dofkit render` call took ~0.9 s on 2 cores, the render ~0.07 s of
// it. The rest was libtiff deflating the strips on one thread (45 % of the call's samples) and
// loading OpenImageIO with its dependencies (the dynamic loader alone 15 %). TIFF strips are
// independent zlib streams, so here they are compressed in parallel.
//
// What OpenImageIO 2.4 writes, and so what is written here (tested against it tag for tag,
// tests/io/tiff_write_test.cpp): little-endian classic TIFF, one image, 32 rows per strip,
// deflate (compression 8) with libtiff's predictor — horizontal differencing (2) for 8 /
// 16-bit samples, the floating-point predictor (3) for 32-bit float —, contiguous samples,
// orientation 1, the current DateTime, SampleFormat uint / IEEE float, ExtraSamples for the
// alpha of RGBA (unassociated for integer files, associated for float), and for sRGB integer
// files an EXIF directory with ColorSpace = sRGB (that is how OpenImageIO records
// "oiio:ColorSpace" = sRGB in a TIFF). Integer samples are quantised with OpenImageIO's rule
// (quantise.hpp). Each strip holds the same predicted samples as OpenImageIO's, deflated as
// libtiff deflates a strip written in one call (libdeflate, level 7; tested against libtiff
// strip for strip) — OpenImageIO writes row by row, which libtiff deflates with zlib's level 6
// instead: a stream of nearly the same size, 2-3x slower to make.
//
// Reading (tiff_read.cpp): the common TIFFs — the first image of the file, grey / grey + alpha /
// RGB / RGBA, 8 or 16-bit unsigned or 32-bit float samples, contiguous, in strips or tiles,
// any compression libtiff decodes except JPEG — are decoded here with libtiff itself, the
// library OpenImageIO reads them with, strips / tiles on all cores, and given the channel
// names, alpha and sample values OpenImageIO gives (tested against it). The rest go to
// OpenImageIO. Why: a TIFF-in call spent ~0.2 s loading OpenImageIO, 40 % of the call.
#pragma once
#include <memory>
#include <string>
#include <vector>

namespace dofkit::io::tiff {

/// What write() needs: `pixels` holds width·height·channels floats, pixel-interleaved,
/// already in the file's encoding (sRGB-encoded colour, straight alpha for integer files).
struct Layout {
  int width = 0, height = 0;
  int channels = 0;   ///< 1 (grey), 3 (RGB) or 4 (RGBA)
  int bits = 8;       ///< 8 or 16 (unsigned integer) or 32 (float)
  bool srgb = false;  ///< integer files: mark as sRGB (EXIF ColorSpace); else linear
};

/// True for the layouts write() takes (the rest go to OpenImageIO).
bool writes(int channels, int bits);

/// Writes the TIFF straight into `file` (no temporary: the caller's AtomicFile / OutputSet
/// provides it). Throws Error(bad_input) naming `display_path` on a write error or a file
/// that would pass classic TIFF's 4 GiB, Error(internal) on a layout it does not take.
void write(const std::string& file, const std::string& display_path, const Layout& layout, const float* pixels);

/// A TIFF this reader takes (see above), opened. libtiff's messages are kept, not printed.
class Reader {
 public:
  /// nullptr if `path` is not such a file (the caller then uses OpenImageIO). Never throws
  /// for a bad file.
  static std::unique_ptr<Reader> open(const std::string& path);
  ~Reader();

  int width() const { return width_; }
  int height() const { return height_; }
  /// OpenImageIO's channel names: Y | Y A | R G B | R G B A.
  const std::vector<std::string>& names() const { return names_; }
  int alpha_channel() const { return alpha_ ? channels_ - 1 : -1; }
  bool unassociated() const { return unassociated_; }  ///< ExtraSamples says straight alpha
  bool integer() const { return bits_ != 32; }

  /// Reads channels [cb, ce) as float (integer codes as code · (1 / (2^bits − 1)), as
  /// OpenImageIO converts them; alpha as stored), pixel-interleaved: W·H·(ce − cb) values.
  /// False if libtiff cannot decode every strip / tile in full: then `broken` (when given)
  /// names the first such strip / tile and libtiff's reason. OpenImageIO 2.4 reads such a
  /// file without an error (the strip as zeros), so the caller refuses it instead of handing
  /// it on. False with `broken` empty: the file could not be opened again as it was.
  bool read(int cb, int ce, float* out, std::string* broken = nullptr) const;

 private:
  Reader() = default;
  std::string path_;
  int width_ = 0, height_ = 0, channels_ = 0, bits_ = 8;
  bool alpha_ = false, unassociated_ = false, tiled_ = false;
  int block_w_ = 0, block_h_ = 0;  ///< tile size, or width × rows per strip
  std::vector<std::string> names_;
};

}  // namespace dofkit::io::tiff
