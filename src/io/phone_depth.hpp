// Depth maps embedded in phone photos: Google Camera JPEGs (GDepth XMP: a base64 depth image
// with its near/far/format, in the standard or the extended XMP) and HEIC/HEIF files with an
// auxiliary depth image (libheif, when dofkit is built with it: DOFKIT_HAVE_HEIF).
//
// Hostile input: every length is checked against the bytes actually present before anything
// is allocated (an XMP packet is at most one JPEG segment, 65533 bytes; the extended XMP's
// declared length must equal the chunks present); the XML parser refuses DTDs (no entity
// expansion), nests at most kMaxXmlDepth deep and is linear in its input; the decoded depth
// image goes through the same header checks and pixel budget as a depth file.
#pragma once
#include <string>
#include <string_view>
#include <vector>

#include "dofkit/image.hpp"
#include "io/image_io.hpp"

namespace dofkit::io {

/// One XMP property: namespace URI, local name, value (entities decoded). From an attribute
/// of any element, or from an element that holds only text.
struct XmpProperty {
  std::string ns, name, value;
};

inline constexpr int kMaxXmlDepth = 256;

/// Parses an XMP packet (XML 1.0 without a DTD). False with `why` (one line) if it is not
/// well-formed: unclosed or mismatched tags, an undeclared prefix, an unknown entity, a DTD.
bool parse_xmp(std::string_view xml, std::vector<XmpProperty>& out, std::string& why);

/// Base64 (RFC 4648; whitespace skipped, '=' padding only at the end). False with `why`.
bool decode_base64(std::string_view text, std::string& out, std::string& why);
/// Base64 with '=' padding (tests and fuzz seeds write GDepth data with it).
std::string encode_base64(std::string_view bytes);

/// The XMP packets of a JPEG: the standard packet and the extended one (reassembled from its
/// chunks, those whose GUID the standard packet names in xmpNote:HasExtendedXMP).
struct JpegXmp {
  std::string standard, extended;
};
/// Reads the segments of the JPEG `bytes` before its image data. False with `why` if the
/// segments are malformed (truncated, extended-XMP chunks that do not tile their declared
/// length). A JPEG without XMP gives true and empty packets.
bool jpeg_xmp(std::string_view bytes, JpegXmp& out, std::string& why);

/// Whether `path` starts like a JPEG (FF D8 FF) / an ISO-BMFF HEIF file (ftyp with a HEIF
/// brand).
bool looks_like_jpeg(const std::string& path);
bool looks_like_heif(const std::string& path);

/// Whether load_frame takes the depth from the photo `color_path` itself (a JPEG or HEIF given
/// without a depth file and without --depth-channel).
bool reads_embedded_depth(const std::string& color_path, const std::string& depth_path,
                          const std::string& depth_channel);

/// A HEIF photo's primary image as its header declares it (libheif; nothing decoded): size
/// and channels (3, or 4 with an alpha image). Throws Error(bad_input) naming the file if
/// libheif cannot read it or it is beyond the pixel budget, and "built without HEIC support"
/// without libheif. The header walk (header_check.hpp) calls it for HEIF files.
struct HeifInfo {
  int width = 0, height = 0, channels = 3;
};
HeifInfo probe_heif(const std::string& path, const char* role);

/// A HEIF photo's primary image (libheif, its transformations applied) as read_color returns
/// colour: RGBA, linear (the 8–16-bit samples sRGB-decoded), premultiplied (alpha 1 without
/// an alpha image). Throws Error(bad_input) naming the file.
Image read_heif_color(const std::string& path);

/// The depth map embedded in the photo `path`, converted to planar z in metres per its own
/// metadata, at the map's own resolution (load_frame resamples it), with `facts->embedded`
/// saying where it came from. An empty Image, with `missing` saying what was looked for, if
/// the photo carries none. Throws Error(bad_input) naming the file for malformed metadata or
/// a damaged depth image; Error(bad_input) "built without HEIC support" for a HEIF file when
/// dofkit was built without libheif. `width` × `height`: the photo's size (a depth map larger
/// than it is refused before it is decoded). Only opt.invalid_as_far is used from `opt`.
Image read_embedded_depth(const std::string& path, int width, int height, const DepthOptions& opt, DepthFacts* facts,
                          std::string& missing);

}  // namespace dofkit::io
