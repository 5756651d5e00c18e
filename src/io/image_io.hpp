// Image IO through OpenImageIO (library target dofkit_io; the core library has no IO).
//
// Colour from 8/16-bit files (PNG, JPEG, TIFF) is sRGB-decoded to linear; EXR (and float
// TIFF) is taken as linear. Colour is returned RGBA premultiplied (alpha 1 if the file has
// none). Writes go to a temporary file in the target folder that is renamed into place, so
// a failed write never leaves a partial or clobbered file.
#pragma once
#include <string>
#include <vector>

#include "dofkit/frame.hpp"
#include "dofkit/image.hpp"

namespace dofkit::io {

/// How a depth file encodes depth (`--depth-kind`).
enum class DepthKind {
  z,             ///< planar z along the optical axis (default)
  distance,      ///< radial distance from the camera centre (needs fov_deg)
  disparity,     ///< z = disparity_scale / d; 8/16-bit normalised maps: bright = near
  ndc,           ///< hardware depth d in [0,1]: z = n f / (f − d (f − n)); f may be inf
  ndc_reversed,  ///< reversed-Z: z = n f / (n + d (f − n)); f may be inf
};

struct DepthOptions {
  DepthKind kind = DepthKind::z;
  double fov_deg = 0;              ///< horizontal field of view, degrees (distance kind)
  double disparity_scale = 1;      ///< z = scale / d (disparity kind)
  double clip_near = 0.1;          ///< near clip, scene units (ndc kinds)
  double clip_far = 1000;          ///< far clip, scene units; +inf allowed (ndc kinds)
  bool invalid_as_far = false;     ///< NaN / negative / zero depth → +inf instead of an error
};

/// Reads a colour image → RGBA premultiplied linear, 4 planes. Throws Error(bad_input)
/// naming the file on any failure.
Image read_color(const std::string& path);

/// Reads a depth map: a single-channel file whatever its channel name, or the Z / depth.Z
/// channel of a multi-channel EXR; converts it to planar z per `opt`.
Image read_depth(const std::string& path, const DepthOptions& opt);

/// True if the file is an EXR with a Z (or depth.Z) channel.
bool has_depth_channel(const std::string& path);

enum class Encoding { automatic, linear, srgb };

/// Writes an image. Format from the extension (.exr float/half, .png 8/16-bit, .jpg, .tif).
/// 1-plane images are written as one channel (EXR channel name `channel_name`, default "Y"),
/// 4-plane RGBA premultiplied colour is un-premultiplied and sRGB-encoded for 8/16-bit
/// formats (automatic), kept linear and premultiplied for EXR.
struct WriteOptions {
  Encoding encoding = Encoding::automatic;
  int bits = 0;                         ///< 0 = format default (PNG 8, EXR half → use 32 for float)
  std::string channel_name = "Y";       ///< for single-channel EXR
  bool keep_alpha = true;               ///< write A (else RGB only)
};
void write_image(const std::string& path, const Image& img, const WriteOptions& opt = {});

/// Loads a frame from colour + optional depth file (depth from the colour EXR's Z channel
/// when depth_path is empty) and validates it (sizes, invalid depth per opt).
Frame load_frame(const std::string& color_path, const std::string& depth_path, const DepthOptions& opt);

}  // namespace dofkit::io
