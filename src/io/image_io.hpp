// Image IO (library target dofkit_io; the core library has no IO): single-part scanline
// EXRs with none / zips / zip compression directly (exr_direct.hpp), every other file
// through OpenImageIO, loaded on first use (oiio_module.hpp).
//
// Colour from 8/16-bit files (PNG, JPEG, TIFF) is sRGB-decoded to linear; EXR (and float
// TIFF) is taken as linear. Colour is returned RGBA premultiplied (alpha 1 if the file has
// none). Writes go to a temporary file in the target folder that is renamed into place, so
// a failed write never leaves a partial or clobbered file.
#pragma once
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "dofkit/frame.hpp"
#include "dofkit/image.hpp"
#include "io/depth_resample.hpp"

namespace dofkit::io {

/// How a depth file encodes depth (`--depth-kind`).
enum class DepthKind {
  z,             ///< planar z along the optical axis (default)
  distance,      ///< radial distance from the camera centre (needs fov_deg)
  disparity,     ///< z = disparity_scale / d; 8/16-bit normalised maps: bright = near
  ndc,           ///< hardware depth d in [0,1]: z = n f / (f − d (f − n)); f may be inf
  ndc_reversed,  ///< reversed-Z: z = n f / (n + d (f − n)); f may be inf
  linear,        ///< d in [0,1] linear between the clip planes: z = n + d (f − n); f finite
};

struct DepthOptions {
  DepthKind kind = DepthKind::z;
  double fov_deg = 0;           ///< horizontal field of view, degrees (distance kind)
  double disparity_scale = 1;   ///< z = scale / d (disparity kind)
  double clip_near = 0.1;       ///< near clip, scene units (ndc kinds)
  double clip_far = 1000;       ///< far clip, scene units; +inf allowed (ndc kinds)
  bool invalid_as_far = false;  ///< NaN / negative / zero depth → +inf instead of an error
  /// Multiplies every converted depth: file units × scale = metres (`--depth-scale`,
  /// `--depth-units`); finite and > 0. 1 leaves every value bit for bit as read.
  double scale = 1;
  /// The channel to read (`--depth-channel`; exact name, else the one equal ignoring case);
  /// "" = chosen by name (choose_depth_channel).
  std::string channel;
  /// A depth map smaller than the colour image (load_frame): how it is brought to the
  /// colour's size (`--depth-upsample`), and whether another aspect ratio is scaled per axis
  /// (`--depth-fit stretch`) instead of refused.
  DepthUpsample upsample = DepthUpsample::guided;
  bool stretch = false;
  /// A depth map of the colour's size re-snapped to the colour's edges (`--depth-refine`,
  /// refine_depth); a smaller map is brought up by `upsample` instead.
  bool refine = false;
};

/// What read_depth found in the file (for the CLI's sanity warnings).
struct DepthFacts {
  bool integer = false;  ///< 8/16-bit integer samples (normalised to [0, 1] before conversion)
  std::string channel;   ///< the channel read ("R=G=B" for a grey RGB file)
  /// A depth map embedded in a phone photo (phone_depth.hpp): where it came from and how it
  /// was converted, for the note; "" for a depth file or channel.
  std::string embedded;
  /// The focus distance the photo records (GFocus:FocalDistance, in the depth map's metres),
  /// used when the camera flags give none.
  std::optional<double> focus_m;
};

/// The depth channel of a file with these channel names. `wanted` (--depth-channel): that
/// name exactly, else the one channel equal to it ignoring case. Without it: a file of one
/// channel gives that channel; otherwise the first of these tiers (names compared ignoring
/// case) with exactly one hit: `Z`; `depth.Z` or `depth`; `*depth*.Z` (e.g.
/// ViewLayer.Depth.Z); any other `<layer>.Z`. A channel of a normal (N.*, *Normal*.*),
/// position (P.*, *Position*.*) or motion (*Vector*.*, *Motion*.*, *Velocity*.*) pass is never
/// a candidate. index = -1 with `problem` (a sentence listing the channels, naming
/// --depth-channel) when no channel or several qualify.
struct DepthChannelChoice {
  int index = -1;
  std::string problem;
};
DepthChannelChoice choose_depth_channel(const std::vector<std::string>& names, const std::string& wanted);

/// The colour channels of a file with these names. `wanted` (--color-channels, 3 or 4 names):
/// those names. Without it: bare R, G, B [A] (A: else `alpha_channel`); else the one layer
/// that holds <layer>.R/.G/.B [.A] (ignoring the leaf's case); else, of several such layers,
/// the one whose name contains "combined" or "beauty" or is "rgba"; else `problem`. r = -1
/// and no problem: no layer holds R, G and B (read_color's grey / plain-channel rule).
struct ColorChannelChoice {
  int r = -1, g = -1, b = -1, a = -1;
  std::string problem;
};
ColorChannelChoice choose_color_channels(const std::vector<std::string>& names, const std::vector<std::string>& wanted,
                                         int alpha_channel);

/// Reads a colour image → RGBA premultiplied linear, 4 planes, from the channels
/// choose_color_channels picks (`channels`: --color-channels). Throws Error(bad_input)
/// naming the file on any failure.
Image read_color(const std::string& path, const std::vector<std::string>& channels = {});

/// Reads a depth map: the channel choose_depth_channel picks (a single-channel file whatever
/// its channel name; opt.channel if given), or R of a grey image stored as identical R, G, B
/// when no channel is named as depth; converts it to planar z per `opt` and multiplies by
/// opt.scale. `facts`, if given, receives what was read. 8/16-bit values are normalised to [0, 1] (no sRGB
/// decode). +inf is valid; values that are invalid for the kind (NaN, z <= 0, negative
/// disparity, NDC outside [0, 1]) throw Error(bad_input) with their count and the first
/// pixel, unless opt.invalid_as_far (they become +inf).
Image read_depth(const std::string& path, const DepthOptions& opt, DepthFacts* facts = nullptr);

/// Converts stored depth values (one plane; 8/16-bit ones normalised to [0, 1]) to planar z
/// in place, per opt.kind, times opt.scale: what read_depth does after reading. Invalid values
/// throw Error(bad_input) naming `what` with their count and first pixel, unless
/// opt.invalid_as_far (+inf). Error(usage) for options that do not suit the kind.
void convert_depth(Image& depth, const DepthOptions& opt, const std::string& what);

/// True if the file holds integer (8/16-bit) samples, i.e. display-referred sRGB colour that
/// clips at 1 (reads the header only; Error(bad_input) like read_color if it cannot).
bool is_display_referred(const std::string& path);

/// True if the file has more than one channel and choose_depth_channel finds one by name.
bool has_depth_channel(const std::string& path);

enum class Encoding { automatic, linear, srgb };

/// Writes an image. Format from the extension (.exr, .png, .jpg/.jpeg, .tif/.tiff).
/// 1-plane images are written as one channel (EXR channel name `channel_name`, default "Y");
/// 3- and 4-plane images are colour (R, G, B [, A]). Other plane counts are written as
/// generic channels (EXR and TIFF only).
/// Colour (3/4 planes) is encoded per `encoding`: automatic = linear for EXR and 32-bit
/// float TIFF, sRGB for 8/16-bit files. 4-plane colour is premultiplied in memory; EXR keeps
/// it premultiplied (the OpenEXR convention), 8/16-bit PNG/TIFF get un-premultiplied,
/// sRGB-encoded colour with a straight alpha; formats or options without alpha (JPEG,
/// keep_alpha = false) get the premultiplied colour, i.e. the image over black.
/// Values outside [0, 1] are clamped in 8/16-bit files.
/// The file appears atomically (temporary file + rename, see atomic_write.hpp): on any
/// error an existing file of that name is untouched and no partial file is left.
struct WriteOptions {
  Encoding encoding = Encoding::automatic;
  /// Bits per channel; 0 = format default: EXR 32 (float), PNG/TIFF/JPEG 8.
  /// EXR: 16 (half) or 32 (float); PNG: 8 or 16; TIFF: 8, 16 or 32 (float); JPEG: 8.
  int bits = 0;
  std::string channel_name = "Y";  ///< for single-channel EXR
  bool keep_alpha = true;          ///< write A (else RGB only)
  int jpeg_quality = 95;           ///< JPEG quality, 1..100
  /// EXR compression (kExrCompressions; "" = zip, OpenImageIO's default). Other formats: "".
  std::string compression;
  /// PNG zlib level, 0 (stored, fastest) … 9 (smallest); -1 = 6, libpng's usual default.
  /// Other formats: -1.
  int png_level = -1;
};
/// The EXR compressions write_image accepts (OpenEXR's, by OpenImageIO's names); pxr24, b44,
/// b44a, dwaa and dwab are lossy.
inline constexpr const char* kExrCompressions[] = {"none",  "rle", "zips", "zip",  "piz",
                                                   "pxr24", "b44", "b44a", "dwaa", "dwab"};
void write_image(const std::string& path, const Image& img, const WriteOptions& opt = {});

/// Like write_image but writes straight into `file` (no temporary file), choosing the
/// format from `format_path`'s extension. Used to fill an AtomicFile / OutputSet temporary.
void encode_image(const std::string& file, const std::string& format_path, const Image& img,
                  const WriteOptions& opt = {});

/// Throws Error(usage) naming `flag` if `path`'s extension is not a writable format or
/// `opt.bits` does not suit it. Lets a command reject an output name before rendering.
void check_output_format(const std::string& path, const WriteOptions& opt, const std::string& flag);

/// Whether write_image would write `path` as OpenEXR (its extension, in any case).
bool is_exr_path(const std::string& path);
/// Whether write_image would write `path` as PNG (its extension, in any case).
bool is_png_path(const std::string& path);

/// Reads a mask (1 plane, 0..1): a single-channel file whatever its name, or the A channel
/// of a multi-channel file. 8/16-bit values are taken as linear coverage (no sRGB decode).
Image read_mask(const std::string& path);

/// Reads a normal map → 3 planes (X, Y, Z as stored; no conversion): the channels N.X, N.Y,
/// N.Z (dofkit scene's gbuffer.exr), else X, Y, Z (or any layer's <layer>.X …, e.g. a
/// renderer's Normal.X), else R, G, B. Integer (8/16-bit) files are refused: normals need
/// signed values. Throws Error(bad_input) naming the file and the channels it has.
Image read_normals(const std::string& path);

/// Reads the channels `names` (each the exact name, else the one channel equal to it ignoring
/// case) → one plane per name, in that order, values as stored (8/16-bit normalised to [0, 1]).
/// A name absent from the file whose `optional` entry is true gives a plane of zeros and is
/// appended to *missing; any other absent name throws Error(bad_input) naming the file, `role`,
/// the channel and the channels the file has. (The G-buffer reader of `dofkit light`.)
Image read_named_channels(const std::string& path, const char* role, const std::vector<std::string>& names,
                          const std::vector<bool>& optional = {}, std::vector<std::string>* missing = nullptr);

/// Parses a --depth-kind name: z, distance, disparity, ndc, ndc-reversed, linear (Error(usage)).
DepthKind parse_depth_kind(const std::string& name);
/// The --depth-kind name of a kind.
const char* depth_kind_name(DepthKind kind);

/// Limits checked from a file's header before any pixel memory is allocated.
inline constexpr long long kMaxPixels = 1LL << 28;  ///< default pixel budget, width × height
inline constexpr int kMaxChannels = 64;
/// The pixel budget in force for every read in this process (default kMaxPixels; the CLI's
/// `--max-pixels`). Throws Error(usage) unless 1 <= pixels <= 2^34.
void set_pixel_budget(long long pixels);
long long pixel_budget();

/// An image as its file's header declares it, found without decoding a pixel: the
/// regular-file check and the header walk (header_check.hpp), and for a format the walk does
/// not read, the header as its reader opens it. Throws Error(bad_input) like the readers (a
/// missing, special, damaged or oversized file). Lets a command compare its inputs' sizes and
/// estimate its memory before it reads any of them.
struct ImageInfo {
  int width = 0, height = 0;  ///< what read_color / read_depth / read_layers return
  int channels = 0;           ///< 0 if the header walk does not say
  bool deep = false;          ///< a deep EXR (read_layers: the display window)
  std::uint64_t deep_sample_bytes = 0;
};
ImageInfo probe_image(const std::string& path, const char* role);

/// Loads a frame from colour + optional depth file (depth from the colour EXR's Z channel
/// when depth_path is empty) and validates it (sizes, invalid depth per opt). Both headers are
/// read first: sizes that differ are refused before a pixel is decoded.
/// Without a depth path the colour file's own depth channel is read (opt.channel, else by
/// name; a file with non-colour channels and no single depth channel is refused listing
/// them). A depth file smaller than the colour (check_depth_fit) is resampled to its size
/// (resample_depth, opt.upsample). `color_channels`: as read_color's.
Frame load_frame(const std::string& color_path, const std::string& depth_path, const DepthOptions& opt,
                 const std::vector<std::string>& color_channels = {}, DepthFacts* facts = nullptr);

}  // namespace dofkit::io
