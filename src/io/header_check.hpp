// Header sanity checks that run on the raw bytes of a file *before* OpenImageIO opens it.
//
// Why: some decoders trust sizes written in the header and allocate them before noticing
// that the file is shorter. OpenEXR, for one, allocates an attribute's declared size (up to
// 2 GiB) before reading it, so a 300-byte file can make the loader allocate and zero 1.7 GB
// (found by the fuzzer). We walk the EXR header ourselves — it is a simple list of
// (name, type, size, value) records — and refuse a file whose records claim more bytes than
// the file holds, or whose data window is beyond the pixel budget, before any decoder runs.
// PNG likewise: libpng allocates a text chunk's declared length (the fuzzer made a 313-byte
// file claim a 754 MB tEXt chunk), so every chunk must fit in the file. TIFF: OIIO reads a
// strip that lies past the end of the file as zeros without an error, so every strip and
// tile must lie inside the file. In every format the declared pixels must also fit what the
// stored pixel data can expand to (PNG, scanline EXR, and the first image of a TIFF with no,
// LZW, deflate or PackBits compression): a 134-byte deflate TIFF declaring 16000×16000 px
// made a whole call take 9 s and 6 GB reading zeros.
#pragma once
#include <string>

namespace dofkit::io {

/// Throws Error(bad_input) naming `path` if its header is structurally impossible (see
/// above). Files that are not EXR, PNG or classic TIFF are left to their decoders; an unreadable path is not an
/// error here (the caller reports it).
void check_file_header(const std::string& path, const char* role);

}  // namespace dofkit::io
