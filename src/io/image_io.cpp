// Over 800 lines: every image read and write (colour, depth, masks, normals, encoders) shares one checked open.
// Image IO (see image_io.hpp for the conventions): the common EXRs, PNGs and JPEGs through
// exr_direct.hpp, png_direct.hpp and jpeg_direct.hpp, everything else through OpenImageIO 2.4
// in its module (oiio_module.hpp). The direct readers give what OpenImageIO gives (tested),
// so the code below does not care which reader opened a file.
//
// Reading: the header is opened first and its size checked against kMaxPixels /
// kMaxChannels before any pixel buffer is allocated; pixels are read as float (OIIO maps
// 8/16-bit integers to [0, 1] exactly: v/255, v/65535). Alpha handling: OIIO would
// premultiply straight-alpha PNG/TIFF data in the *encoded* (sRGB) domain, which darkens
// semi-transparent edges; we ask it for the file's own values ("oiio:UnassociatedAlpha")
// and premultiply after decoding to linear light instead.
#include "io/image_io.hpp"

#include <atomic>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <functional>
#include <limits>
#include <memory>
#include <numbers>
#include <sstream>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "dofkit/error.hpp"
#include "io/atomic_write.hpp"
#include "io/exr_direct.hpp"
#include "io/jpeg_direct.hpp"
#include "io/png_direct.hpp"
#include "io/tiff_direct.hpp"
#include "io/srgb.hpp"
#include "io/header_check.hpp"
#include "io/oiio_module.hpp"
#include "io/phone_depth.hpp"

namespace fs = std::filesystem;

namespace dofkit::io {

namespace {
std::atomic<long long> g_pixel_budget{kMaxPixels};
}  // namespace

void set_pixel_budget(long long pixels) {
  if (pixels < 1 || pixels > (1LL << 34))
    throw_usage("--max-pixels " + std::to_string(pixels) + ": must be in [1, 2^34]");
  g_pixel_budget.store(pixels);
}

long long pixel_budget() { return g_pixel_budget.load(); }

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

// --- opening files ----------------------------------------------------------------------

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

std::string extension_of(const std::string& path) { return lower(fs::path(path).extension().string()); }

// What the readers need from a file's header, from either reader.
using FileSpec = oiio::Spec;

// The spec of a file opened by a direct reader: its size and names (what every reader has),
// then what differs.
template <typename Reader>
FileSpec size_and_names(const Reader& r) {
  FileSpec s;
  s.width = r.width();
  s.height = r.height();
  s.nchannels = static_cast<int>(r.names().size());
  s.channelnames = r.names();
  return s;
}

FileSpec spec_of(const exr::ScanlineReader& r) {
  FileSpec s = size_and_names(r);
  s.alpha_channel = r.alpha_channel();
  s.z_channel = r.z_channel();
  return s;
}

FileSpec spec_of(const png::Reader& r) {
  FileSpec s = size_and_names(r);
  s.alpha_channel = r.alpha_channel();
  s.integer = true;
  s.unassociated = r.alpha_channel() >= 0;  // PNG alpha is straight (OpenImageIO says so too)
  return s;
}

FileSpec spec_of(const tiff::Reader& r) {
  FileSpec s = size_and_names(r);
  s.alpha_channel = r.alpha_channel();
  s.integer = r.integer();
  s.unassociated = r.unassociated();  // read with straight alpha kept, as OpenImageIO is asked to
  return s;
}

FileSpec spec_of(const jpeg::Reader& r) {
  FileSpec s = size_and_names(r);
  s.integer = true;
  return s;
}

struct OpenedFile {
  std::unique_ptr<exr::ScanlineReader> exr;  // common EXR files (exr_direct.hpp),
  std::unique_ptr<png::Reader> png;          // common PNG files (png_direct.hpp),
  std::unique_ptr<jpeg::Reader> jpg;         // common JPEG files (jpeg_direct.hpp),
  std::unique_ptr<tiff::Reader> tif;         // common TIFF files (tiff_direct.hpp), else
  std::unique_ptr<oiio::Input> in;           // OpenImageIO (oiio_module.hpp)
  FileSpec spec;
};

void check_declared_size(const FileSpec& spec, const std::string& path, const char* role) {
  const long long w = spec.width, h = spec.height;
  if (w <= 0 || h <= 0) throw_bad_input(path + ": " + role + " image has an empty size");
  const long long budget = pixel_budget();
  if (w > budget || h > budget || w * h > budget)
    throw_bad_input(path + ": " + role + " image declares " + std::to_string(w) + "x" + std::to_string(h) +
                    " pixels, more than the limit of " + std::to_string(budget) + " (--max-pixels)");
  if (spec.nchannels <= 0 || spec.nchannels > kMaxChannels)
    throw_bad_input(path + ": " + role + " image declares " + std::to_string(spec.nchannels) + " channels (limit " +
                    std::to_string(kMaxChannels) + ")");
}

// Opens `path` with OpenImageIO into `f` (replacing any spec it had).
void open_oiio(OpenedFile& f, const std::string& path, const char* role) {
  std::string error;
  f.in = oiio::module().open(path, /*straight_alpha=*/true, error);
  if (!f.in) throw_bad_input(path + ": cannot read " + role + " image: " + error);
  f.spec = f.in->spec();
  check_declared_size(f.spec, path, role);
  if (f.spec.depth > 1) throw_bad_input(path + ": " + role + " is a volume image (depth > 1), not supported");
  if (f.spec.deep) throw_bad_input(path + ": " + role + " is a deep image; read it with --layers");
}

// The direct readers in turn (each gives nullptr for a file it does not take): true, with
// f.spec set, if one took the file. `broken` is set, and false returned, for a PNG that
// libpng would refuse too (png_direct.hpp: reported here, without libpng's stderr line).
bool open_direct(OpenedFile& f, const std::string& path, std::string& broken) {
  const auto taken = [&](const auto& reader) {
    if (!reader) return false;
    f.spec = spec_of(*reader);
    return true;
  };
  return taken(f.exr = exr::ScanlineReader::open(path)) || taken(f.png = png::Reader::open(path, &broken)) ||
         (broken.empty() && taken(f.jpg = jpeg::Reader::open(path, &broken))) ||
         (broken.empty() && taken(f.tif = tiff::Reader::open(path)));
}

OpenedFile open_checked(const std::string& path, const char* role) {
  check_file_header(path, role);  // a regular file, its structure and declared sizes sound
  // A HEIF photo is read by libheif, as colour only (read_color, read_embedded_depth).
  if (looks_like_heif(path))
    throw_bad_input(path +
                    ": a HEIF/HEIC file is read as a --color photo only (its own depth image is used "
                    "when no --depth is given)");
  OpenedFile f;
  std::string broken;
  if (open_direct(f, path, broken)) {
    check_declared_size(f.spec, path, role);
    return f;
  }
  if (!broken.empty()) throw_bad_input(path + ": cannot read " + role + " image: " + broken);
  open_oiio(f, path, role);
  return f;
}

// After a direct reader failed on the pixels (EXR: missing, truncated or undecodable
// chunks; PNG: a stream that does not inflate to the declared rows; JPEG: any libjpeg error
// or warning): OpenImageIO reads the file again and gives its error (or reads what that
// reader could not). A PNG or TIFF whose data does not decode is refused with the reason
// instead (png::Reader::read, tiff::Reader::read).
// The callers sized their buffers from the first reader's header, so OpenImageIO must see the
// same size and channels, else the file is refused (the fuzzer found an EXR whose header the
// two EXR libraries parse as 5×1835012 and 5×4 pixels: the buffers then overflowed).
void fall_back_to_oiio(OpenedFile& f, const std::string& path, const char* role) {
  const FileSpec before = f.spec;
  f.exr.reset();
  f.png.reset();
  f.jpg.reset();
  f.tif.reset();
  open_oiio(f, path, role);
  if (f.spec.channelnames != before.channelnames || f.spec.nchannels != before.nchannels)
    throw_bad_input(path + ": cannot read " + role + " pixels: the readers disagree on its channels");
  if (f.spec.width != before.width || f.spec.height != before.height)
    throw_bad_input(path + ": cannot read " + role + " pixels: the readers disagree on its size (" +
                    std::to_string(before.width) + "x" + std::to_string(before.height) + " or " +
                    std::to_string(f.spec.width) + "x" + std::to_string(f.spec.height) + ")");
}

// Reads channels [cb, ce) as float, interleaved, W·H·(ce − cb) values.
std::vector<float> read_channels(OpenedFile& f, const std::string& path, const char* role, int cb, int ce) {
  const std::size_t n = static_cast<std::size_t>(f.spec.width) * f.spec.height * (ce - cb);
  std::vector<float> buf(n);
  if (f.exr || f.png || f.jpg || f.tif) {
    std::string broken;  // set by the PNG and TIFF readers for data no reader can decode
    const auto read_by = [&](const auto& reader) { return reader && reader->read(cb, ce, buf.data()); };
    const auto read_or_refuse = [&](const auto& reader) { return reader && reader->read(cb, ce, buf.data(), &broken); };
    if (read_by(f.exr) || read_or_refuse(f.png) || read_or_refuse(f.jpg) || read_or_refuse(f.tif)) return buf;
    if (!broken.empty()) throw_bad_input(path + ": cannot read " + role + " pixels: " + broken);
    fall_back_to_oiio(f, path, role);
  }
  if (!f.in->read(cb, ce, buf.data()))
    throw_bad_input(path + ": cannot read " + role + " pixels (corrupt or truncated?): " + f.in->error());
  return buf;
}

// Index of the channel named `want` (exact), else of a layer-qualified "<layer>.<want>";
// -1 if none.
int find_channel(const FileSpec& spec, const std::string& want) {
  for (int c = 0; c < spec.nchannels; ++c)
    if (spec.channelnames[c] == want) return c;
  const std::string suffix = "." + want;
  for (int c = 0; c < spec.nchannels; ++c) {
    const std::string& n = spec.channelnames[c];
    if (n.size() > suffix.size() && n.compare(n.size() - suffix.size(), suffix.size(), suffix) == 0) return c;
  }
  return -1;
}

std::string channel_list(const FileSpec& spec);

// The channel named exactly `want`, else the one channel equal to it ignoring case; -1 if
// none, -2 if several differ only in case.
int find_named(const FileSpec& spec, const std::string& want) {
  for (int c = 0; c < spec.nchannels; ++c)
    if (spec.channelnames[c] == want) return c;
  int found = -1;
  for (int c = 0; c < spec.nchannels; ++c)
    if (lower(spec.channelnames[c]) == lower(want)) found = found == -1 ? c : -2;
  return found;
}

// A channel of a pass that is never depth: normals (N.*, *Normal*.*), positions (P.*,
// *Position*.*) and motion (*Vector*.*, *Motion*.*, Blender's velocity). Its layer is what
// precedes the last '.', compared in lower case.
bool is_excluded_pass(const std::string& name) {
  const auto dot = name.rfind('.');
  if (dot == std::string::npos) return false;
  const std::string layer = lower(name.substr(0, dot));
  const auto last_part = layer.rfind('.');
  const std::string leaf = last_part == std::string::npos ? layer : layer.substr(last_part + 1);
  if (leaf == "n" || leaf == "p") return true;
  for (const char* word : {"normal", "position", "vector", "motion", "velocity"})
    if (layer.find(word) != std::string::npos) return true;
  return false;
}

}  // namespace

DepthChannelChoice choose_depth_channel(const std::vector<std::string>& names, const std::string& wanted) {
  FileSpec spec;
  spec.nchannels = static_cast<int>(names.size());
  spec.channelnames = names;
  DepthChannelChoice out;
  auto list = [&] { return channel_list(spec); };
  if (!wanted.empty()) {
    out.index = find_named(spec, wanted);
    if (out.index == -2)
      out.problem = "--depth-channel " + wanted + ": several channels match it ignoring case (channels: " + list() +
                    "); give the exact name";
    else if (out.index < 0)
      out.problem = "--depth-channel " + wanted + ": no such channel (channels: " + list() + ")";
    if (out.index < 0) out.index = -1;
    return out;
  }
  if (spec.nchannels == 1) {  // a lone channel, whatever its name
    out.index = 0;
    return out;
  }
  // Tiers, first match wins; a tier with several candidates is ambiguous.
  const std::function<bool(const std::string&)> tiers[] = {
      [](const std::string& n) { return n == "z"; },
      [](const std::string& n) { return n == "depth.z" || n == "depth"; },
      [](const std::string& n) {
        return n.size() > 2 && n.compare(n.size() - 2, 2, ".z") == 0 && n.find("depth") != std::string::npos;
      },
      [](const std::string& n) { return n.size() > 2 && n.compare(n.size() - 2, 2, ".z") == 0; },
  };
  for (const auto& tier : tiers) {
    std::vector<int> hits;
    for (int c = 0; c < spec.nchannels; ++c)
      if (!is_excluded_pass(names[c]) && tier(lower(names[c]))) hits.push_back(c);
    if (hits.size() == 1) {
      out.index = hits[0];
      return out;
    }
    if (hits.size() > 1) {
      std::string which;
      for (const int c : hits) which += (which.empty() ? "" : ", ") + names[c];
      out.problem = "several depth channels (" + which + ") among " + list() + "; choose one with --depth-channel";
      return out;
    }
  }
  out.problem = "no depth channel among " + list() +
                " (normal N.*, position P.* and motion passes are never taken as depth); name one with "
                "--depth-channel or give a depth file with --depth";
  return out;
}

namespace {

std::string channel_list(const FileSpec& spec) {
  std::string s;
  for (int c = 0; c < spec.nchannels && c < 24; ++c) s += (c ? "," : "") + spec.channelnames[c];
  if (spec.nchannels > 24) s += ",… (" + std::to_string(spec.nchannels) + " channels)";
  return s;
}

std::string fmt_num(double v) {
  std::ostringstream o;
  o << v;
  return o.str();
}

}  // namespace

// --- colour -------------------------------------------------------------------------------

ColorChannelChoice choose_color_channels(const std::vector<std::string>& names, const std::vector<std::string>& wanted,
                                         int alpha_channel) {
  FileSpec spec;
  spec.nchannels = static_cast<int>(names.size());
  spec.channelnames = names;
  ColorChannelChoice out;
  if (!wanted.empty()) {
    int* slot[4] = {&out.r, &out.g, &out.b, &out.a};
    for (std::size_t k = 0; k < wanted.size() && k < 4; ++k) {
      const int c = find_named(spec, wanted[k]);
      if (c < 0) {
        out.problem = "--color-channels: " +
                      (c == -2 ? "several channels match " + wanted[k] + " ignoring case" : "no channel " + wanted[k]) +
                      " (channels: " + channel_list(spec) + ")";
        return out;
      }
      *slot[k] = c;
    }
    return out;
  }
  // Layers (what precedes the last '.', "" for bare names) that hold R, G and B.
  struct Layer {
    std::string name;
    int c[4] = {-1, -1, -1, -1};
  };
  std::vector<Layer> layers;
  for (int i = 0; i < spec.nchannels; ++i) {
    const std::string& n = names[i];
    const auto dot = n.rfind('.');
    const std::string layer = dot == std::string::npos ? "" : n.substr(0, dot);
    const std::string leaf = lower(dot == std::string::npos ? n : n.substr(dot + 1));
    const int k = leaf == "r" ? 0 : leaf == "g" ? 1 : leaf == "b" ? 2 : leaf == "a" ? 3 : -1;
    if (k < 0) continue;
    auto it = std::find_if(layers.begin(), layers.end(), [&](const Layer& l) { return l.name == layer; });
    if (it == layers.end()) it = layers.insert(layers.end(), Layer{layer, {-1, -1, -1, -1}});
    if (it->c[k] < 0) it->c[k] = i;
  }
  std::erase_if(layers, [](const Layer& l) { return l.c[0] < 0 || l.c[1] < 0 || l.c[2] < 0; });
  const auto pick = [&](const Layer& l) {
    out.r = l.c[0], out.g = l.c[1], out.b = l.c[2], out.a = l.c[3];
    if (out.a < 0 && l.name.empty()) out.a = alpha_channel;
    return out;
  };
  for (const Layer& l : layers)
    if (l.name.empty()) return pick(l);  // bare R, G, B
  if (layers.size() == 1) return pick(layers[0]);
  std::vector<const Layer*> beauty;
  for (const Layer& l : layers) {
    const std::string n = lower(l.name);
    if (n.find("combined") != std::string::npos || n == "rgba" || n.find("beauty") != std::string::npos)
      beauty.push_back(&l);
  }
  if (beauty.size() == 1) return pick(*beauty[0]);
  if (!layers.empty()) {
    std::string which;
    for (const Layer& l : layers) which += (which.empty() ? "" : ", ") + l.name;
    out.problem = "several colour layers (" + which + ") among " + channel_list(spec) +
                  "; choose one with --color-channels R,G,B[,A]";
    return out;
  }
  out.r = -1;  // no R, G, B anywhere: the caller's grey / plain-channel rule
  out.a = alpha_channel;
  return out;
}

Image read_color(const std::string& path, const std::vector<std::string>& channels) {
  if (looks_like_heif(path)) {
    check_file_header(path, "colour");
    return read_heif_color(path);
  }
  OpenedFile f = open_checked(path, "colour");
  const FileSpec& spec = f.spec;
  const ColorChannelChoice choice = choose_color_channels(spec.channelnames, channels, spec.alpha_channel);
  if (!choice.problem.empty()) throw_bad_input(path + ": " + choice.problem);
  int r = choice.r, g = choice.g, b = choice.b, a = choice.a;
  if (r < 0) {
    // No named RGB: grey (Y / one channel, optionally with alpha) or the first three
    // non-alpha, non-depth channels.
    std::vector<int> plain;
    for (int c = 0; c < spec.nchannels; ++c)
      if (c != a && c != spec.z_channel && spec.channelnames[c] != "Z") plain.push_back(c);
    if (plain.empty())
      throw_bad_input(path + ": colour image has no colour channel (channels " + channel_list(spec) + ")");
    if (plain.size() < 3)
      r = g = b = plain[0];
    else
      r = plain[0], g = plain[1], b = plain[2];
  }
  if (f.exr) {
    // The direct EXR reader fills the planes itself (float, premultiplied: as the loop below
    // would leave them), without an interleaved copy.
    Image img(spec.width, spec.height, 4);
    std::vector<int> channels = {r};
    std::vector<float*> planes = {img.plane(0)};
    if (g != r) channels.push_back(g), planes.push_back(img.plane(1));
    if (b != r) channels.push_back(b), planes.push_back(img.plane(2));
    if (a >= 0) channels.push_back(a), planes.push_back(img.plane(3));
    if (f.exr->read_planes(channels, planes)) {
      const std::size_t n = img.plane_size();
      if (g == r) std::copy(img.plane(0), img.plane(0) + n, img.plane(1));
      if (b == r) std::copy(img.plane(0), img.plane(0) + n, img.plane(2));
      if (a < 0) std::fill(img.plane(3), img.plane(3) + n, 1.0f);
      return img;
    }
    fall_back_to_oiio(f, path, "colour");
  }
  const int cb = std::min({r, g, b, a < 0 ? r : a});
  const int ce = std::max({r, g, b, a < 0 ? r : a}) + 1;
  const std::vector<float> buf = read_channels(f, path, "colour", cb, ce);
  const int stride = ce - cb;
  const int W = spec.width, H = spec.height;
  Image img(W, H, 4);
  float* out[4] = {img.plane(0), img.plane(1), img.plane(2), img.plane(3)};
  const int src[3] = {r - cb, g - cb, b - cb};
  const bool has_alpha = a >= 0;
  const bool integer = f.spec.integer, unassociated = f.spec.unassociated;
  // Per pixel, independent: both cores (a 1080p JPEG's serial loop was ~6 % of its call).
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, img.plane_size(), 1 << 14),
                    [&](const tbb::blocked_range<std::size_t>& range) {
                      for (std::size_t i = range.begin(); i < range.end(); ++i) {
                        const float* p = buf.data() + i * stride;
                        const float alpha = has_alpha ? p[a - cb] : 1.0f;
                        out[3][i] = alpha;
                        for (int c = 0; c < 3; ++c) {
                          float v = p[src[c]];
                          if (integer) {
                            // Integer files hold sRGB-encoded colour. With straight alpha the stored value is
                            // the encoded colour itself; with associated alpha it is encoded·α (the encoder's
                            // premultiplication), so divide α out before decoding and multiply it back after.
                            if (has_alpha && !unassociated) v = alpha > 0 ? v / alpha : 0.0f;
                            v = decode_srgb(v);
                            if (has_alpha) v *= alpha;
                          } else if (has_alpha && unassociated) {
                            v *= alpha;  // a float file that declares straight alpha
                          }
                          out[c][i] = v;
                        }
                      }
                    });
  return img;
}

// --- depth --------------------------------------------------------------------------------

DepthKind parse_depth_kind(const std::string& name) {
  if (name == "z") return DepthKind::z;
  if (name == "distance") return DepthKind::distance;
  if (name == "disparity") return DepthKind::disparity;
  if (name == "ndc") return DepthKind::ndc;
  if (name == "ndc-reversed") return DepthKind::ndc_reversed;
  if (name == "linear") return DepthKind::linear;
  throw_usage("--depth-kind " + name + ": unknown kind (known: z, distance, disparity, ndc, ndc-reversed)");
}

const char* depth_kind_name(DepthKind kind) {
  switch (kind) {
    case DepthKind::z:
      return "z";
    case DepthKind::distance:
      return "distance";
    case DepthKind::disparity:
      return "disparity";
    case DepthKind::ndc:
      return "ndc";
    case DepthKind::ndc_reversed:
      return "ndc-reversed";
    case DepthKind::linear:
      return "linear";
  }
  return "?";
}

namespace {

void check_depth_options(const DepthOptions& opt) {
  if (!(opt.scale > 0 && std::isfinite(opt.scale)))
    throw_usage("--depth-scale " + fmt_num(opt.scale) + ": must be a finite number > 0 (file value x scale = metres)");
  switch (opt.kind) {
    case DepthKind::z:
      break;
    case DepthKind::distance:
      if (!(opt.fov_deg > 0 && opt.fov_deg < 180))
        throw_usage(
            "--fov-deg: --depth-kind distance needs the horizontal field of view in degrees, 0 < FOV < 180 (got " +
            fmt_num(opt.fov_deg) + ")");
      break;
    case DepthKind::disparity:
      if (!(opt.disparity_scale > 0 && std::isfinite(opt.disparity_scale)))
        throw_usage("--disparity-scale: must be > 0 (got " + fmt_num(opt.disparity_scale) + ")");
      break;
    case DepthKind::ndc:
    case DepthKind::ndc_reversed:
      if (!(opt.clip_near > 0 && std::isfinite(opt.clip_near)))
        throw_usage("--clip: NEAR must be > 0 (got " + fmt_num(opt.clip_near) + ")");
      if (!(opt.clip_far > opt.clip_near))
        throw_usage("--clip: FAR must be greater than NEAR, or inf (got " + fmt_num(opt.clip_near) + "," +
                    fmt_num(opt.clip_far) + ")");
      break;
    case DepthKind::linear:
      if (!(opt.clip_near > 0 && std::isfinite(opt.clip_near) && opt.clip_far > opt.clip_near &&
            std::isfinite(opt.clip_far)))
        throw_usage("--clip: --depth-kind linear needs finite 0 < NEAR < FAR (got " + fmt_num(opt.clip_near) + "," +
                    fmt_num(opt.clip_far) + ")");
      break;
  }
}

// Converts one stored value to planar z; NaN marks an invalid value.
struct DepthConverter {
  DepthOptions opt;
  int W = 0, H = 0;
  double focal_px = 0;  // distance kind: pinhole focal length in pixels

  DepthConverter(const DepthOptions& o, int w, int h) : opt(o), W(w), H(h) {
    if (opt.kind == DepthKind::distance) {
      // A horizontal FOV θ spans W pixels: tan(θ/2) = (W/2) / F.
      focal_px = (W / 2.0) / std::tan(opt.fov_deg * std::numbers::pi / 360.0);
    }
  }

  double operator()(double d, int x, int y) const {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    if (std::isnan(d)) return nan;
    const double n = opt.clip_near, f = opt.clip_far;
    switch (opt.kind) {
      case DepthKind::z:
        return d > 0 ? d : nan;
      case DepthKind::distance: {
        if (!(d > 0)) return nan;
        // The ray through the pixel centre makes angle φ with the axis, tan φ = ρ / F where
        // ρ is the centre's distance from the principal point (W/2, H/2) in pixels; planar
        // z = d cos φ = d / sqrt(1 + ρ²/F²).
        const double dx = x + 0.5 - W / 2.0, dy = y + 0.5 - H / 2.0;
        return d / std::sqrt(1.0 + (dx * dx + dy * dy) / (focal_px * focal_px));
      }
      case DepthKind::disparity:
        if (d < 0) return nan;
        return d == 0 ? std::numeric_limits<double>::infinity() : opt.disparity_scale / d;
      case DepthKind::ndc:
        // Standard window depth: d = 0 at the near plane, 1 at the far plane.
        // z = n f / (f − d (f − n)); for f → ∞ this is n / (1 − d).
        if (d < 0 || d > 1) return nan;
        if (std::isinf(f)) return d >= 1 ? std::numeric_limits<double>::infinity() : n / (1.0 - d);
        return n * f / (f - d * (f - n));
      case DepthKind::ndc_reversed:
        // Reversed-Z: d = 1 at the near plane, 0 at the far plane.
        // z = n f / (n + d (f − n)); for f → ∞ this is n / d.
        if (d < 0 || d > 1) return nan;
        if (std::isinf(f)) return d <= 0 ? std::numeric_limits<double>::infinity() : n / d;
        return n * f / (n + d * (f - n));
      case DepthKind::linear:
        if (d < 0 || d > 1) return nan;
        return n + d * (f - n);
    }
    return nan;
  }
};

const char* valid_range_text(DepthKind k) {
  switch (k) {
    case DepthKind::z:
    case DepthKind::distance:
      return "NaN, zero or negative";
    case DepthKind::disparity:
      return "NaN or negative";
    case DepthKind::ndc:
    case DepthKind::ndc_reversed:
    case DepthKind::linear:
      return "NaN or outside [0, 1]";
  }
  return "invalid";
}

}  // namespace

Image read_depth(const std::string& path, const DepthOptions& opt, DepthFacts* facts) {
  check_depth_options(opt);
  OpenedFile f = open_checked(path, "depth");
  const FileSpec& spec = f.spec;
  const DepthChannelChoice choice = choose_depth_channel(spec.channelnames, opt.channel);
  int c = choice.index;
  bool grey_rgb = false;
  if (c < 0) {
    // A grey depth map saved as RGB(A) (common for 8/16-bit disparity maps): accept it if
    // R, G and B are identical everywhere, checked below.
    const int r = find_channel(spec, "R"), g = find_channel(spec, "G"), b = find_channel(spec, "B");
    const bool ambiguous = choice.problem.rfind("several", 0) == 0 || !opt.channel.empty();
    if (!ambiguous && r == 0 && g == 1 && b == 2 && spec.nchannels <= 4) {
      c = 0;
      grey_rgb = true;
    } else {
      throw_bad_input(path + ": " + choice.problem);
    }
  }
  if (facts) {
    facts->integer = spec.integer;
    facts->channel = grey_rgb ? "R=G=B" : spec.channelnames[c];
  }
  const int W = spec.width, H = spec.height;
  Image depth(W, H, 1);
  if (grey_rgb) {
    const std::vector<float> buf = read_channels(f, path, "depth", 0, 3);
    for (std::size_t i = 0; i < depth.plane_size(); ++i) {
      const float* p = buf.data() + 3 * i;
      if (!(p[0] == p[1] && p[0] == p[2]) && !(std::isnan(p[0]) && std::isnan(p[1]) && std::isnan(p[2])))
        throw_bad_input(path + ": depth image has channels " + channel_list(spec) +
                        " that differ (not a grey depth map) and no Z channel; give a single-channel depth file");
      depth.plane(0)[i] = p[0];
    }
  } else {
    const std::vector<float> buf = read_channels(f, path, "depth", c, c + 1);
    std::copy(buf.begin(), buf.end(), depth.plane(0));
  }

  convert_depth(depth, opt, path);
  return depth;
}

void convert_depth(Image& depth, const DepthOptions& opt, const std::string& path) {
  check_depth_options(opt);
  const int W = depth.width(), H = depth.height();
  const DepthConverter conv(opt, W, H);
  std::size_t bad = 0, first = 0;
  float first_value = 0;
  for (int y = 0; y < H; ++y) {
    float* row = depth.row(0, y);
    for (int x = 0; x < W; ++x) {
      const double z = conv(row[x], x, y) * opt.scale;
      if (std::isnan(z) || !(z > 0)) {
        if (bad++ == 0) {
          first = static_cast<std::size_t>(y) * W + x;
          first_value = row[x];
        }
        row[x] = kInf;
      } else {
        row[x] = static_cast<float>(z);
        // A finite z that rounds to 0 or overflows to inf in float stays valid (inf = far).
        if (!(row[x] > 0)) row[x] = std::numeric_limits<float>::min();
      }
    }
  }
  if (bad && !opt.invalid_as_far) {
    throw_bad_input(path + ": depth has " + std::to_string(bad) + " invalid value(s) (" + valid_range_text(opt.kind) +
                    " for --depth-kind " + depth_kind_name(opt.kind) + "), first at pixel (" +
                    std::to_string(first % W) + ", " + std::to_string(first / W) + ") = " + fmt_num(first_value) +
                    "; use --invalid-depth far to treat them as infinitely far");
  }
}

bool is_display_referred(const std::string& path) {
  // A probe: a file that cannot be opened is not display-referred here; the colour read that
  // follows (after every input's size is checked) reports why.
  try {
    if (looks_like_heif(path)) return true;  // 8-16-bit samples
    OpenedFile f = open_checked(path, "colour");
    return f.spec.integer;
  } catch (const Error&) {
    return false;
  }
}

namespace {
// The channel names of a file that opens ({} if it does not: the read that follows reports it).
std::vector<std::string> probe_channel_names(const std::string& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) return {};
  try {
    check_file_header(path, "colour");
  } catch (const Error&) {
    return {};
  }
  // The readers read_depth will use: a PNG or JPEG (never a Z channel) no longer loads
  // OpenImageIO just to be asked.
  OpenedFile f;
  std::string broken;
  if (!open_direct(f, path, broken)) {
    if (!broken.empty()) return {};
    std::string error;
    auto in = oiio::module().open(path, /*straight_alpha=*/false, error);
    if (!in) return {};
    f.spec = in->spec();
  }
  return f.spec.channelnames;
}

// Whether a channel name is a colour channel (R, G, B, A or Y, bare or in a layer).
bool is_colour_channel(const std::string& name) {
  const auto dot = name.rfind('.');
  const std::string leaf = lower(dot == std::string::npos ? name : name.substr(dot + 1));
  return leaf == "r" || leaf == "g" || leaf == "b" || leaf == "a" || leaf == "y";
}
}  // namespace

bool has_depth_channel(const std::string& path) {
  const std::vector<std::string> names = probe_channel_names(path);
  return names.size() > 1 && choose_depth_channel(names, "").index >= 0;
}

Image read_mask(const std::string& path) {
  OpenedFile f = open_checked(path, "mask");
  int c = 0;
  if (f.spec.nchannels > 1) {
    c = find_channel(f.spec, "A");
    if (c < 0) c = f.spec.alpha_channel;
    if (c < 0)
      throw_bad_input(path + ": mask image has " + std::to_string(f.spec.nchannels) + " channels (" +
                      channel_list(f.spec) + ") and no alpha; give a single-channel mask");
  }
  const std::vector<float> buf = read_channels(f, path, "mask", c, c + 1);
  Image m(f.spec.width, f.spec.height, 1);
  for (std::size_t i = 0; i < buf.size(); ++i) {
    const float v = buf[i];
    if (std::isnan(v))
      throw_bad_input(path + ": mask has NaN at pixel (" + std::to_string(i % f.spec.width) + ", " +
                      std::to_string(i / f.spec.width) + ")");
    m.plane(0)[i] = std::clamp(v, 0.0f, 1.0f);
  }
  return m;
}

ImageInfo probe_image(const std::string& path, const char* role) {
  HeaderFacts facts;
  check_file_header(path, role, &facts);
  ImageInfo info;
  if (facts.width > 0 && facts.height > 0) {
    info.width = static_cast<int>(facts.width);
    info.height = static_cast<int>(facts.height);
    info.channels = facts.channels;
    info.deep = facts.deep;
    info.deep_sample_bytes = facts.deep_sample_bytes;
    return info;
  }
  OpenedFile f;
  std::string broken;
  if (!open_direct(f, path, broken)) {
    if (!broken.empty()) throw_bad_input(path + ": cannot read " + role + " image: " + broken);
    std::string error;
    auto in = oiio::module().open(path, /*straight_alpha=*/true, error);
    if (!in) throw_bad_input(path + ": cannot read " + role + " image: " + error);
    f.spec = in->spec();
    info.deep = f.spec.deep;
    if (f.spec.deep && f.spec.full_width > 0 && f.spec.full_height > 0) {
      f.spec.width = f.spec.full_width;
      f.spec.height = f.spec.full_height;
    }
  }
  check_declared_size(f.spec, path, role);
  info.width = f.spec.width;
  info.height = f.spec.height;
  info.channels = f.spec.nchannels;
  return info;
}

Image read_normals(const std::string& path) {
  OpenedFile f = open_checked(path, "normals");
  const FileSpec& spec = f.spec;
  if (spec.integer)
    throw_bad_input(path +
                    ": normals must be a float image (EXR or float TIFF); an 8/16-bit file cannot hold signed "
                    "components");
  static const char* const kSets[3][3] = {{"N.X", "N.Y", "N.Z"}, {"X", "Y", "Z"}, {"R", "G", "B"}};
  int c[3] = {-1, -1, -1};
  for (const auto& names : kSets) {
    for (int k = 0; k < 3; ++k) c[k] = find_channel(spec, names[k]);
    if (c[0] >= 0 && c[1] >= 0 && c[2] >= 0) break;
  }
  if (c[0] < 0 || c[1] < 0 || c[2] < 0)
    throw_bad_input(path + ": no normal channels (N.X N.Y N.Z, X Y Z or R G B) among " + channel_list(spec));
  // One read of the channel range that holds the three, then split.
  const int lo = std::min({c[0], c[1], c[2]}), hi = std::max({c[0], c[1], c[2]}) + 1;
  const std::vector<float> buf = read_channels(f, path, "normals", lo, hi);
  Image n(spec.width, spec.height, 3);
  const std::size_t stride = hi - lo;
  for (int k = 0; k < 3; ++k) {
    float* out = n.plane(k);
    for (std::size_t i = 0; i < n.plane_size(); ++i) out[i] = buf[i * stride + (c[k] - lo)];
  }
  return n;
}

Image read_named_channels(const std::string& path, const char* role, const std::vector<std::string>& names,
                          const std::vector<bool>& optional, std::vector<std::string>* missing) {
  OpenedFile f = open_checked(path, role);
  const FileSpec& spec = f.spec;
  std::vector<int> c(names.size(), -1);
  int lo = spec.nchannels, hi = 0;
  for (std::size_t k = 0; k < names.size(); ++k) {
    c[k] = find_named(spec, names[k]);
    if (c[k] == -2)
      throw_bad_input(path + ": " + role + " channel " + names[k] + ": several channels differ from it only in case (" +
                      channel_list(spec) + ")");
    if (c[k] < 0) {
      if (k < optional.size() && optional[k]) {
        if (missing) missing->push_back(names[k]);
        continue;
      }
      throw_bad_input(path + ": no " + role + " channel " + names[k] + " among " + channel_list(spec));
    }
    lo = std::min(lo, c[k]);
    hi = std::max(hi, c[k] + 1);
  }
  Image out(spec.width, spec.height, static_cast<int>(names.size()), 0.0f);
  if (hi <= lo) return out;
  const std::vector<float> buf = read_channels(f, path, role, lo, hi);
  const std::size_t stride = hi - lo;
  for (std::size_t k = 0; k < names.size(); ++k) {
    if (c[k] < 0) continue;
    float* o = out.plane(static_cast<int>(k));
    for (std::size_t i = 0; i < out.plane_size(); ++i) o[i] = buf[i * stride + (c[k] - lo)];
  }
  return out;
}

Frame load_frame(const std::string& color_path, const std::string& depth_path, const DepthOptions& opt,
                 const std::vector<std::string>& color_channels, DepthFacts* facts) {
  check_depth_options(opt);
  // Sizes before pixels: a depth map of another size is refused from the headers alone.
  if (!depth_path.empty()) {
    const ImageInfo c = probe_image(color_path, "colour"), d = probe_image(depth_path, "depth");
    check_depth_fit(depth_path, d.width, d.height, color_path, c.width, c.height, opt.stretch);
  }
  Frame frame;
  frame.color = read_color(color_path, color_channels);
  bool resampled = false;  // a smaller map brought up (then --depth-refine has nothing to add)
  if (reads_embedded_depth(color_path, depth_path, opt.channel)) {
    // A phone photo: the depth map it carries (GDepth XMP, HEIC auxiliary depth image),
    // converted per its own metadata, at its own size, then brought to the photo's.
    std::string missing;
    frame.depth = read_embedded_depth(color_path, frame.color.width(), frame.color.height(), opt, facts, missing);
    if (frame.depth.empty())
      throw_usage("--depth: not given and " + color_path + " holds no embedded depth map (" + missing +
                  "); pass a depth file with --depth");
    if (!frame.depth.same_size(frame.color)) {
      const std::string what = color_path + " (its embedded depth map)";
      check_depth_fit(what, frame.depth.width(), frame.depth.height(), color_path, frame.color.width(),
                      frame.color.height(), opt.stretch);
      frame.depth = resample_depth(frame.depth, frame.color, opt.upsample);
      resampled = true;
      if (facts)
        facts->embedded += ", upsampled to " + std::to_string(frame.color.width()) + "x" +
                           std::to_string(frame.color.height()) + " (--depth-upsample " +
                           depth_upsample_name(opt.upsample) + ")";
    }
  } else if (depth_path.empty()) {
    // The colour file's own depth channel: named by --depth-channel, else chosen by name. A
    // file with channels beyond colour but none of them depth (or several) is refused with
    // its channel list; a plain colour file without depth is a usage error.
    if (opt.channel.empty()) {
      const std::vector<std::string> names = probe_channel_names(color_path);
      const bool extra =
          std::any_of(names.begin(), names.end(), [](const std::string& n) { return !is_colour_channel(n); });
      if (names.size() < 2 || (!extra && choose_depth_channel(names, "").index < 0))
        throw_usage("--depth: not given and " + color_path + " has no Z channel; pass a depth file with --depth");
    }
    frame.depth = read_depth(color_path, opt, facts);
  } else {
    frame.depth = read_depth(depth_path, opt, facts);
    if (!frame.depth.same_size(frame.color)) {
      check_depth_fit(depth_path, frame.depth.width(), frame.depth.height(), color_path, frame.color.width(),
                      frame.color.height(), opt.stretch);
      frame.depth = resample_depth(frame.depth, frame.color, opt.upsample);
      resampled = true;
    }
  }
  if (opt.refine && !resampled && frame.depth.same_size(frame.color))
    frame.depth = refine_depth(frame.depth, frame.color);
  if (!frame.depth.same_size(frame.color)) {
    throw_bad_input((depth_path.empty() ? color_path : depth_path) + ": depth is " +
                    std::to_string(frame.depth.width()) + "x" + std::to_string(frame.depth.height()) + " but colour " +
                    color_path + " is " + std::to_string(frame.color.width()) + "x" +
                    std::to_string(frame.color.height()));
  }
  // Depth values were already checked (or mapped to +inf) above; this catches anything else.
  validate_frame(frame, color_path.c_str());
  return frame;
}

// --- writing ------------------------------------------------------------------------------

namespace {

enum class Format { exr, png, jpeg, tiff, unknown };

Format format_of(const std::string& path) {
  const std::string e = extension_of(path);
  if (e == ".exr") return Format::exr;
  if (e == ".png") return Format::png;
  if (e == ".jpg" || e == ".jpeg") return Format::jpeg;
  if (e == ".tif" || e == ".tiff") return Format::tiff;
  return Format::unknown;
}

int effective_bits(Format fmt, int bits) {
  if (bits != 0) return bits;
  return fmt == Format::exr ? 32 : 8;
}

}  // namespace

void check_output_format(const std::string& path, const WriteOptions& opt, const std::string& flag) {
  const Format fmt = format_of(path);
  if (fmt == Format::unknown)
    throw_usage(flag + " " + path + ": unsupported output format '" + extension_of(path) +
                "' (use .exr, .png, .jpg, .jpeg, .tif or .tiff)");
  const int bits = effective_bits(fmt, opt.bits);
  const bool ok = (fmt == Format::exr && (bits == 16 || bits == 32)) ||
                  (fmt == Format::png && (bits == 8 || bits == 16)) || (fmt == Format::jpeg && bits == 8) ||
                  (fmt == Format::tiff && (bits == 8 || bits == 16 || bits == 32));
  if (!ok)
    throw_usage(flag + " " + path + ": " + std::to_string(bits) +
                " bits per channel is not available for this format (EXR 16/32, PNG 8/16, JPEG 8, TIFF 8/16/32)");
  if (opt.jpeg_quality < 1 || opt.jpeg_quality > 100) throw_usage(flag + ": JPEG quality must be 1..100");
  if (!opt.compression.empty()) {
    if (fmt != Format::exr)
      throw_usage(flag + " " + path + ": --compression " + opt.compression + " applies to .exr files only");
    std::string known;
    bool ok_name = false;
    for (const char* c : kExrCompressions) {
      known += (known.empty() ? "" : ", ") + std::string(c);
      ok_name = ok_name || opt.compression == c;
    }
    if (!ok_name) throw_usage("--compression " + opt.compression + ": unknown EXR compression (known: " + known + ")");
  }
  if (opt.png_level != -1) {
    if (fmt != Format::png)
      throw_usage(flag + " " + path + ": --png-level " + std::to_string(opt.png_level) + " applies to .png files only");
    if (opt.png_level < 0 || opt.png_level > 9)
      throw_usage("--png-level " + std::to_string(opt.png_level) + ": must be 0 (fastest) to 9 (smallest)");
  }
}

bool is_exr_path(const std::string& path) { return format_of(path) == Format::exr; }
bool is_png_path(const std::string& path) { return format_of(path) == Format::png; }

void encode_image(const std::string& file, const std::string& format_path, const Image& img, const WriteOptions& opt) {
  check_output_format(format_path, opt, "output");
  if (img.empty() || img.width() <= 0 || img.height() <= 0)
    throw_internal(format_path + ": cannot write an empty image");
  const Format fmt = format_of(format_path);
  const int bits = effective_bits(fmt, opt.bits);
  const bool float_file = fmt == Format::exr || bits == 32;
  const int C = img.channels();
  const bool colour = C == 3 || C == 4;
  if (!colour && C != 1 && (fmt == Format::png || fmt == Format::jpeg))
    throw_usage(format_path + ": cannot write a " + std::to_string(C) + "-channel image as " +
                extension_of(format_path) + " (use .exr or .tif)");
  const bool srgb = colour && (opt.encoding == Encoding::srgb || (opt.encoding == Encoding::automatic && !float_file));
  const bool in_alpha = C == 4;
  const bool out_alpha = in_alpha && opt.keep_alpha && fmt != Format::jpeg;
  // Straight alpha in integer files (PNG's definition; TIFF written as "unassociated").
  const bool straight = out_alpha && !float_file;
  const int out_c = colour ? (out_alpha ? 4 : 3) : C;

  if (fmt == Format::exr && (colour || C == 1) && exr::writes_compression(opt.compression)) {
    // The common EXR outputs skip OpenImageIO (exr_direct.hpp: ~2x faster, both cores).
    std::vector<exr::OutChannel> ch;
    std::vector<Image> encoded;  // sRGB-encoded copies, only when asked for
    const auto plane = [&](int c) -> const float* {
      if (!srgb || c == 3) return img.plane(c);
      Image e(img.width(), img.height(), 1);
      const float* s = img.plane(c);
      for (std::size_t i = 0; i < img.plane_size(); ++i) e.plane(0)[i] = encode_srgb(s[i]);
      encoded.push_back(std::move(e));
      return encoded.back().plane(0);
    };
    if (colour) {
      encoded.reserve(3);
      ch = {{"R", plane(0)}, {"G", plane(1)}, {"B", plane(2)}};
      if (out_alpha) ch.push_back({"A", plane(3)});
    } else {
      ch = {{opt.channel_name, img.plane(0)}};
    }
    exr::write_scanline(file, format_path, img.width(), img.height(), ch, bits == 16, opt.compression);
    return;
  }

  // Interleave (and encode) into one buffer; both cores (the sRGB encoding's pow was ~10 % of
  // a 1080p PNG-out call on one).
  const std::size_t n = img.plane_size();
  std::vector<float> buf(n * out_c);
  const bool eight_bit = bits == 8 && !float_file;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 1 << 14), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t i = r.begin(); i < r.end(); ++i) {
      float* o = buf.data() + i * out_c;
      if (!colour) {
        for (int c = 0; c < C; ++c) o[c] = img.plane(c)[i];
        continue;
      }
      const float alpha = in_alpha ? img.plane(3)[i] : 1.0f;
      for (int c = 0; c < 3; ++c) {
        float v = img.plane(c)[i];
        if (straight) v = alpha > 0 ? v / alpha : 0.0f;
        // 8-bit files: the code itself (srgb8_code, the same code as quantising
        // encode_srgb(v), ~4× faster), stored as code / 255, which quantises back to it.
        if (srgb) v = eight_bit ? srgb8_code(v) * (1.0f / 255.0f) : encode_srgb(v);
        o[c] = v;
      }
      if (out_alpha) o[3] = alpha;
    }
  });

  if (fmt == Format::png) {
    // PNG is written here (png_direct.hpp: parallel deflate, no OpenImageIO).
    png::write(file, format_path, png::Layout{img.width(), img.height(), out_c, bits}, buf.data(),
               opt.png_level < 0 ? 6 : opt.png_level, srgb);
    return;
  }
  if (fmt == Format::tiff && tiff::writes(out_c, bits)) {
    // TIFF as OpenImageIO writes it, strips deflated on all cores (tiff_direct.hpp).
    tiff::write(file, format_path, tiff::Layout{img.width(), img.height(), out_c, bits, srgb}, buf.data());
    return;
  }
  if (fmt == Format::jpeg) {
    // JPEG through libjpeg directly (jpeg_direct.hpp: OpenImageIO's settings, no loading it).
    jpeg::write(file, format_path, img.width(), img.height(), out_c, buf.data(), opt.jpeg_quality);
    return;
  }

  // TIFF layouts tiff_direct.hpp does not write (2 or 5+ channels), and the EXR compressions
  // exr_direct.hpp does not write: OpenImageIO.
  oiio::OutSpec spec;
  spec.width = img.width();
  spec.height = img.height();
  spec.nchannels = out_c;
  spec.type = fmt == Format::exr ? (bits == 16 ? oiio::PixelType::half : oiio::PixelType::float32)
              : bits == 32       ? oiio::PixelType::float32
              : bits == 16       ? oiio::PixelType::uint16
                                 : oiio::PixelType::uint8;
  if (colour) {
    spec.channelnames = {"R", "G", "B"};
    if (out_alpha) {
      spec.channelnames.push_back("A");
      spec.alpha_channel = 3;
    }
  } else if (C == 1) {
    spec.channelnames = {fmt == Format::exr ? opt.channel_name : std::string("Y")};
  }
  if (straight) spec.int_attributes.emplace_back("oiio:UnassociatedAlpha", 1);
  if (fmt == Format::exr && !opt.compression.empty())
    spec.string_attributes.emplace_back("Compression", opt.compression);
  if (!float_file) spec.string_attributes.emplace_back("oiio:ColorSpace", srgb ? "sRGB" : "Linear");

  std::string error;
  switch (oiio::module().write(file, format_path, spec, buf.data(), error)) {
    case oiio::WriteResult::ok:
      return;
    case oiio::WriteResult::no_writer:
      throw_internal(format_path + ": no writer for this format: " + error);
    case oiio::WriteResult::failed:
      throw_bad_input(format_path + ": cannot write: " + error);
  }
}

void write_image(const std::string& path, const Image& img, const WriteOptions& opt) {
  check_output_format(path, opt, "output");
  write_atomically(path, [&](const std::string& temp) { encode_image(temp, path, img, opt); });
}

}  // namespace dofkit::io
