// TIFF written without OpenImageIO: the file OpenImageIO's writer (libtiff) makes, strips
// deflated on all cores.
//
// Why: a 1080p TIFF-out `dofkit render` call took ~0.9 s on 2 cores, the render ~0.07 s of
// it. The rest was libtiff deflating the strips on one thread (45 % of the call's samples) and
// loading OpenImageIO with its dependencies (the dynamic loader alone 15 %). TIFF strips are
// independent zlib streams, so here they are compressed in parallel, each exactly as libtiff
// compresses it.
//
// What OpenImageIO 2.4 writes, and so what is written here (tested against it tag for tag and
// strip for strip, tests/io/tiff_write_test.cpp): little-endian classic TIFF, one image, 32
// rows per strip, deflate (compression 8) at zlib's default level with libtiff's predictor —
// horizontal differencing (2) for 8 / 16-bit samples, the floating-point predictor (3) for
// 32-bit float —, contiguous samples, orientation 1, the current DateTime, SampleFormat
// uint / IEEE float, ExtraSamples for the alpha of RGBA (unassociated for integer files,
// associated for float), and for sRGB integer files an EXIF directory with ColorSpace = sRGB
// (that is how OpenImageIO records "oiio:ColorSpace" = sRGB in a TIFF). Integer samples are
// quantised with OpenImageIO's rule (quantise.hpp).
#pragma once
#include <string>

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

}  // namespace dofkit::io::tiff
