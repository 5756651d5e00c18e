// Multi-fragment (layered) input: deep EXR and dofkit's flat layered EXR. See layers_io.hpp.
//
// Both readers end in the same place: per pixel, a front-to-back list of fragments
// (premultiplied RGBA + z), padded with empty fragments (alpha 0, z = +inf) up to the largest
// count found, capped at `max_layers`. Deep files are read through OpenImageIO's DeepData
// (which wraps OpenEXR's deep scanline / tiled readers), in the OpenImageIO module
// (oiio_module.hpp); the layered EXR is written by exr_direct.
#include "io/layers_io.hpp"

#include "io/header_check.hpp"
#include "io/image_io.hpp"

#include "io/atomic_write.hpp"
#include "io/exr_direct.hpp"
#include "io/oiio_module.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <numeric>
#include <string>
#include <vector>

#include "dofkit/error.hpp"

namespace dofkit::io {

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

/// One fragment as read from a file.
struct Fragment {
  float r, g, b, a, z;
};

/// "L12.Z" → (12, 'Z'); returns false for any other name.
bool parse_layer_channel(const std::string& name, int& layer, char& comp) {
  if (name.size() < 4 || name[0] != 'L') return false;
  const auto dot = name.find('.');
  if (dot == std::string::npos || dot < 2 || dot + 2 != name.size()) return false;
  int v = 0;
  for (std::size_t i = 1; i < dot; ++i) {
    if (name[i] < '0' || name[i] > '9') return false;
    v = v * 10 + (name[i] - '0');
    if (v > 4096) return false;
  }
  comp = name[dot + 1];
  if (comp != 'R' && comp != 'G' && comp != 'B' && comp != 'A' && comp != 'Z') return false;
  layer = v;
  return true;
}

/// Last component of a channel name: "rgba.R" → "R".
std::string base_name(const std::string& name) {
  const auto dot = name.rfind('.');
  return dot == std::string::npos ? name : name.substr(dot + 1);
}

/// Allocates `n` empty layers (alpha 0, z = +inf) of w × h in the frame.
void allocate_layers(Frame& frame, int n, int w, int h) {
  frame.layer_color.assign(n, Image(w, h, 4, 0.0f));
  frame.layer_depth.assign(n, Image(w, h, 1, kInf));
}

/// Sets frame.color / frame.depth from the layers when the caller left them empty:
/// colour = front-to-back premultiplied "over", depth = nearest fragment with alpha > 0.
void fill_visible(Frame& frame, const std::string& path) {
  if (frame.layer_color.empty()) return;
  const int w = frame.layer_color[0].width(), h = frame.layer_color[0].height();
  if (!frame.color.empty() && (frame.color.width() != w || frame.color.height() != h))
    throw_bad_input(path + ": layers are " + std::to_string(w) + "x" + std::to_string(h) + " but the colour image is " +
                    std::to_string(frame.color.width()) + "x" + std::to_string(frame.color.height()));
  if (!frame.depth.empty() && (frame.depth.width() != w || frame.depth.height() != h))
    throw_bad_input(path + ": layers are " + std::to_string(w) + "x" + std::to_string(h) + " but the depth map is " +
                    std::to_string(frame.depth.width()) + "x" + std::to_string(frame.depth.height()));
  const bool want_color = frame.color.empty(), want_depth = frame.depth.empty();
  if (!want_color && !want_depth) return;
  if (want_color) frame.color = Image(w, h, 4, 0.0f);
  if (want_depth) frame.depth = Image(w, h, 1, kInf);
  const std::size_t n = frame.color.plane_size();
  for (std::size_t i = 0; i < n; ++i) {
    float acc[4] = {0, 0, 0, 0};
    float z = kInf;
    for (std::size_t l = 0; l < frame.layer_color.size(); ++l) {
      const Image& c = frame.layer_color[l];
      const float a = c.plane(3)[i];
      const float t = 1.0f - acc[3];  // transmittance left in front of this fragment
      for (int k = 0; k < 4; ++k) acc[k] += t * c.plane(k)[i];
      if (a > 0 && z == kInf) z = frame.layer_depth[l].plane(0)[i];
    }
    if (want_color)
      for (int k = 0; k < 4; ++k) frame.color.plane(k)[i] = acc[k];
    if (want_depth) frame.depth.plane(0)[i] = z;
  }
}

void read_deep(oiio::Input& in, const std::string& path, Frame& frame, int max_layers) {
  const oiio::Spec& spec = in.spec();
  oiio::DeepSamples dd;
  if (!in.read_deep(dd)) throw_bad_input(path + ": cannot read deep data: " + in.error());
  const int nc = static_cast<int>(dd.channelnames.size());
  const std::int64_t npix = static_cast<std::int64_t>(spec.width) * spec.height;
  if (static_cast<std::int64_t>(dd.counts.size()) != npix)
    throw_bad_input(path + ": deep data covers " + std::to_string(dd.counts.size()) + " pixels, not " +
                    std::to_string(npix));
  int ch[5] = {-1, -1, -1, -1, -1};  // R G B A Z
  for (int c = 0; c < nc; ++c) {
    const std::string b = base_name(dd.channelnames[c]);
    const char* names[5] = {"R", "G", "B", "A", "Z"};
    for (int k = 0; k < 5; ++k)
      if (b == names[k] && ch[k] < 0) ch[k] = c;
  }
  if (ch[4] < 0) throw_bad_input(path + ": deep image has no Z channel");
  // The frame covers the display window; the deep data window may be a part of it.
  const int fw = spec.full_width > 0 ? spec.full_width : spec.width;
  const int fh = spec.full_height > 0 ? spec.full_height : spec.height;
  // The frame is the display window: its size is what gets allocated (per kept layer), so it
  // is held to the pixel budget like any image (a 608-byte file with a 2x2 data window in a
  // 4000x4000 display window took 2 GB). The header walk checked it already; OpenImageIO's
  // reading of the header is checked too.
  if (static_cast<long long>(fw) * fh > pixel_budget() || fw > pixel_budget() || fh > pixel_budget())
    throw_bad_input(path + ": layered input image declares " + std::to_string(fw) + "x" + std::to_string(fh) +
                    " pixels (its display window), more than the limit of " + std::to_string(pixel_budget()) +
                    " (--max-pixels)");
  const int ox = spec.x - (spec.full_width > 0 ? spec.full_x : spec.x);
  const int oy = spec.y - (spec.full_height > 0 ? spec.full_y : spec.y);
  int most = 0;
  for (std::int64_t p = 0; p < npix; ++p) most = std::max(most, dd.counts[p]);
  const int nl = std::min(std::max(most, 1), max_layers);
  allocate_layers(frame, nl, fw, fh);
  std::vector<Fragment> frags;
  std::vector<int> order;
  for (int y = 0; y < spec.height; ++y) {
    const int fy = y + oy;
    if (fy < 0 || fy >= fh) continue;
    for (int x = 0; x < spec.width; ++x) {
      const int fx = x + ox;
      if (fx < 0 || fx >= fw) continue;
      const std::int64_t p = static_cast<std::int64_t>(y) * spec.width + x;
      const int ns = dd.counts[p];
      frags.clear();
      for (int s = 0; s < ns; ++s) {
        const float* v = dd.values.data() + (dd.first[p] + s) * nc;
        Fragment f;
        f.r = ch[0] >= 0 ? v[ch[0]] : 0.0f;
        f.g = ch[1] >= 0 ? v[ch[1]] : 0.0f;
        f.b = ch[2] >= 0 ? v[ch[2]] : 0.0f;
        f.a = ch[3] >= 0 ? v[ch[3]] : 1.0f;
        f.z = v[ch[4]];
        if (!(f.z > 0) || std::isnan(f.z))
          throw_bad_input(path + ": deep sample " + std::to_string(s) + " of pixel (" + std::to_string(fx) + ", " +
                          std::to_string(fy) + ") has invalid Z " + std::to_string(f.z));
        frags.push_back(f);
      }
      // Front to back; ties keep file order (stable) so the result is deterministic.
      order.resize(frags.size());
      std::iota(order.begin(), order.end(), 0);
      std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return frags[a].z < frags[b].z; });
      const int keep = std::min(static_cast<int>(order.size()), nl);
      for (int l = 0; l < keep; ++l) {
        const Fragment& f = frags[order[l]];
        Image& c = frame.layer_color[l];
        c.at(fx, fy, 0) = f.r;
        c.at(fx, fy, 1) = f.g;
        c.at(fx, fy, 2) = f.b;
        c.at(fx, fy, 3) = f.a;
        frame.layer_depth[l].at(fx, fy) = f.z;
      }
    }
  }
}

void read_flat_layers(oiio::Input& in, const std::string& path, Frame& frame, int max_layers) {
  const oiio::Spec& spec = in.spec();
  int most = -1;
  std::vector<std::pair<int, char>> map(spec.nchannels, {-1, 0});
  for (int c = 0; c < spec.nchannels; ++c) {
    int l;
    char comp;
    if (parse_layer_channel(spec.channelnames[c], l, comp)) {
      map[c] = {l, comp};
      most = std::max(most, l);
    }
  }
  if (most < 0) throw_bad_input(path + ": neither a deep EXR nor a layered EXR (no L<i>.R/G/B/A/Z channels)");
  const int nl = std::min(most + 1, max_layers);
  // Every kept layer needs its Z; R, G, B default to 0 and A to 1 when missing.
  for (int l = 0; l < nl; ++l) {
    bool has_z = false;
    for (const auto& m : map) has_z |= (m.first == l && m.second == 'Z');
    if (!has_z) throw_bad_input(path + ": layered EXR lacks channel L" + std::to_string(l) + ".Z");
  }
  const int w = spec.width, h = spec.height, nc = spec.nchannels;
  std::vector<float> buf(static_cast<std::size_t>(w) * h * nc);
  if (!in.read(0, nc, buf.data())) throw_bad_input(path + ": cannot read pixels: " + in.error());
  allocate_layers(frame, nl, w, h);
  for (int l = 0; l < nl; ++l) {
    bool has_a = false;
    for (const auto& m : map) has_a |= (m.first == l && m.second == 'A');
    if (!has_a)
      std::fill(frame.layer_color[l].plane(3), frame.layer_color[l].plane(3) + frame.layer_color[l].plane_size(), 1.0f);
  }
  for (int c = 0; c < nc; ++c) {
    const auto [l, comp] = map[c];
    if (l < 0 || l >= nl) continue;
    float* dst = comp == 'Z' ? frame.layer_depth[l].plane(0)
                             : frame.layer_color[l].plane(comp == 'R'   ? 0
                                                          : comp == 'G' ? 1
                                                          : comp == 'B' ? 2
                                                                        : 3);
    for (std::size_t i = 0, n = static_cast<std::size_t>(w) * h; i < n; ++i) dst[i] = buf[i * nc + c];
  }
  // Validate depths of present fragments (NaN / <= 0 are corrupt; absent fragments may be inf).
  for (int l = 0; l < nl; ++l) {
    const float* z = frame.layer_depth[l].plane(0);
    for (std::size_t i = 0, n = static_cast<std::size_t>(w) * h; i < n; ++i)
      if (std::isnan(z[i]) || !(z[i] > 0))
        throw_bad_input(path + ": channel L" + std::to_string(l) + ".Z has invalid depth " + std::to_string(z[i]) +
                        " at pixel (" + std::to_string(i % w) + ", " + std::to_string(i / w) + ")");
  }
}

}  // namespace

void read_layers(const std::string& path, Frame& frame, int max_layers) {
  if (max_layers < 1) throw_usage("read_layers: max_layers must be >= 1 (got " + std::to_string(max_layers) + ")");
  check_file_header(path, "layered input");
  std::string error;
  auto in = oiio::module().open(path, /*straight_alpha=*/false, error);
  if (!in) throw_bad_input(path + ": cannot open layered input: " + error);
  if (in->spec().deep)
    read_deep(*in, path, frame, max_layers);
  else
    read_flat_layers(*in, path, frame, max_layers);
  fill_visible(frame, path);
}

void write_layers_exr(const std::string& path, const Frame& frame) {
  if (frame.layer_color.empty()) throw_usage(path + ": frame has no layers to write");
  if (frame.layer_color.size() != frame.layer_depth.size())
    throw_usage(path + ": frame has " + std::to_string(frame.layer_color.size()) + " colour layers but " +
                std::to_string(frame.layer_depth.size()) + " depth layers");
  const int w = frame.layer_color[0].width(), h = frame.layer_color[0].height();
  const int nl = static_cast<int>(frame.layer_color.size());
  for (int l = 0; l < nl; ++l) {
    const Image& c = frame.layer_color[l];
    const Image& d = frame.layer_depth[l];
    if (c.width() != w || c.height() != h || c.channels() != 4 || d.width() != w || d.height() != h ||
        d.channels() != 1)
      throw_usage(path + ": layer " + std::to_string(l) + " is not a " + std::to_string(w) + "x" + std::to_string(h) +
                  " RGBA + Z pair");
  }
  std::vector<exr::OutChannel> channels;
  for (int l = 0; l < nl; ++l) {
    const char* comps[5] = {".R", ".G", ".B", ".A", ".Z"};
    for (int k = 0; k < 5; ++k)
      channels.push_back(
          {"L" + std::to_string(l) + comps[k], k < 4 ? frame.layer_color[l].plane(k) : frame.layer_depth[l].plane(0)});
  }
  // Written to a temporary next to the target and renamed, so a failure never leaves a
  // partial file.
  write_atomically(
      path, [&](const std::string& temp) { exr::write_scanline(temp, path, w, h, channels, /*half=*/false, "zip"); });
}

}  // namespace dofkit::io
