// Checks that run on a file *before* any decoder opens it.
//
// Only regular files are opened: a device (/dev/zero, /dev/urandom), a fifo, a socket or a
// folder is refused at once (a decoder would block on a fifo, or read /dev/zero for ever),
// and a path that cannot be opened is named with the system's reason (permission denied, a
// symlink loop, a name too long) rather than a decoder's guess.
//
// Then the header walk. Decoders trust sizes written in the header and allocate them before
// they notice that the file is shorter: OpenEXR allocates an attribute's declared size (up to
// 2 GiB; a 300-byte file made the loader allocate and zero 1.7 GB), libpng a text chunk's
// declared length, libjpeg / libtiff / OpenEXR the pixels of the declared size. So the
// structure of every format dofkit reads is walked here on the raw bytes — EXR attributes and
// the chunk table (every part, deep chunks' sample sizes), PNG chunks up to IEND, TIFF and
// BigTIFF directories and their strips / tiles, JPEG segments and scans up to EOI — and a
// file is refused when a record claims more bytes than the file holds, when its declared
// size is beyond the pixel budget (--max-pixels), or when its pixels need more bytes than the
// stored data can expand to at its codec's largest ratio (docs/robustness.md lists the
// ratios). A TIFF codec without such a bound (CCITT fax, JBIG, WebP, …) and an arithmetic-
// coded JPEG are refused; a JPEG without its end-of-image marker is truncated and refused.
#pragma once
#include <cstdint>
#include <string>

namespace dofkit::io {

/// Refuses (Error(bad_input), one line naming `path` and `role`) anything but a regular file
/// this process can open for reading: a missing path, a folder, a device, a fifo, a socket,
/// an unreadable file, a symlink loop, an over-long name. Never blocks (a fifo is recognised
/// before it is opened, and opened, if at all, without waiting). Returns the size in bytes.
std::uint64_t check_input_file(const std::string& path, const char* role);

/// What the header walk learned about a file (0 = not known / not applicable).
struct HeaderFacts {
  /// The size of the image dofkit reads from the file (EXR: the first part's data window, or
  /// its display window if it is deep; TIFF: the first image) and its channels; 0 if the
  /// format is not one the walk reads.
  long long width = 0, height = 0;
  int channels = 0;
  /// Deep EXR: the display window (the frame the layers reader fills) and the bytes of deep
  /// sample data once inflated (what a decoder allocates for the samples).
  long long display_width = 0, display_height = 0;
  std::uint64_t deep_sample_bytes = 0;
  bool deep = false;
};

/// check_input_file, then the header walk above: throws Error(bad_input) naming `path` if
/// the file is structurally impossible, beyond the pixel budget, compressed with a codec
/// dofkit does not bound, or none of EXR, PNG, TIFF / BigTIFF and JPEG (OpenImageIO would
/// decode BMP, GIF, HDR, … without these checks). `facts`, when given, receives what the walk
/// learned.
void check_file_header(const std::string& path, const char* role, HeaderFacts* facts = nullptr);

}  // namespace dofkit::io
