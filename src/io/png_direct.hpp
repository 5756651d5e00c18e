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
#pragma once
#include <string>

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
void write(const std::string& file, const std::string& display_path, const Layout& layout, const float* pixels, int level,
           bool srgb);

}  // namespace dofkit::io::png
