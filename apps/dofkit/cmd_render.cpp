// `dofkit render`: one colour image + depth → depth of field, written to a file; with
// --frames, a numbered sequence of them in one process.
//
// Order of work, so that a mistake costs as little as possible and never a file:
//   1. check every flag and path (usage errors, exit 2) before reading anything — with
//      --frames, every frame's paths, and that every frame's inputs exist;
//   2. read and validate the inputs (bad input, exit 3);
//   3. render completely in memory;
//   4. encode every output into a temporary file beside its target, then rename them all.
// An error at any step leaves every output path of the frame as it was; with --frames,
// steps 2–4 run frame by frame (one Renderer, its buffers reused), so the frames before a
// failing one stay written.
#include <sys/stat.h>

#include <climits>
#include <cmath>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <future>
#include <iostream>
#include <iterator>
#include <memory>
#include <optional>
#include <set>

#include "budget.hpp"
#include "chunks.hpp"
#include "cli_common.hpp"
#include "commands.hpp"
#include "dofkit/error.hpp"
#include "dofkit/render.hpp"
#include "io/exr_passthrough.hpp"
#include "io/image_io.hpp"
#include "io/layers_io.hpp"
#include "io/phone_depth.hpp"
#include "methods/params.hpp"

namespace dofkit::cli {

namespace {

// The progress callback of run_render_command (null on a plain command line): the render runs
// on the thread that parsed the arguments, so a thread-local pointer reaches it.
thread_local const ProgressCallback* t_render_progress = nullptr;

struct RenderArgs {
  std::string color, depth, layers, mask, mask_depth;
  std::string output, output_coc, debug_output;
  std::string frames;
  std::string color_channels;  // --color-channels R,G,B[,A]
  std::string compression;
  int png_level = -1;
  std::string method = "lens";
  CLI::Option* method_opt = nullptr;  // to tell the default from a --method given
  std::string debug_view;
  std::vector<std::string> sets;
  int threads = 0;
  std::string backend = "cpu";
  int max_layers = 8;
  int bits = 0;
  bool rgba_only = false;  // --rgba-only: an EXR --output without the colour EXR's other channels
  int coc_bits = 0;        // --coc-bits of a picture --output-coc (0 = the format's default)
  double max_work = 0;     // 0 = the library's default
  BudgetFlags budget;
  CameraFlags camera;
  DepthFlags depth_flags;
  ApertureFlags aperture;
  HighlightFlags highlights;
  FarmFlags farm;  // --chunk-index, --chunk-count, --chunk-from-env, --skip-existing (chunks.hpp)
};

const char* kFooter = R"(
Exactly one CoC model is required: --f-number (thin lens), --blur-at-infinity, --planes,
--starcraft or --near-far. Radii in pixels refer to the input width (or --reference-width)
and are clamped by --max-coc. Signed CoC: r > 0 in front of the focus, r < 0 behind it.

Examples:
  # thin lens given by its blur at infinity: r(z) = 24 (4/z - 1) px, clamped to +-40 px
  dofkit render --color c.exr --depth z.exr --focus 4 --blur-at-infinity 24 --max-coc 40 \
      --method reference --output out.exr
  # a 50 mm f/1.8 lens on a full-frame sensor, focused on what is at pixel (640, 360)
  dofkit render --color photo.png --depth disparity.png --depth-kind disparity --disparity-scale 2 \
      --f-number 1.8 --focus-at 640,360 --output blurred.png
  # artist planes, colour EXR with its own Z channel, CoC map as well
  dofkit render --color beauty.exr --planes 0.5,2,4,20 --near-radius 16 --far-radius 8 \
      --output out.exr --output-coc coc.exr
  # list a method's debug views
  dofkit render --method reference --debug-view list

  # a sequence in one process (paths carry #### or %04d; one Renderer for all frames)
  dofkit render --color beauty.####.exr --depth depth.####.exr --frames 1001-1100 \
      --blur-at-infinity 24 --focus 4 --method sterna --output dof.####.exr
  # the same shot as task 3 of a 10-task farm job (frames 1031-1040), resumable
  dofkit render ... --frames 1001-1100 --chunk-index 3 --chunk-count 10 --skip-existing

Exit codes: 0 success, 2 usage error, 3 bad input (missing, corrupt or inconsistent files),
1 internal error. On any error no output file is created or changed (with --frames: none of
the failing frame's; the frames before it stay written).
See docs/cli.md for the full reference.)";

// --frames and the frame patterns of the paths (with --frames only; without it a path is
// taken as written). A pattern is a run of '#' (the frame number zero-padded to the run's
// length: shot.####.exr → shot.0012.exr), printf's %d (no padding) or %0Nd (zero-padded to N
// digits); "%%" stands for one '%', as in printf. Any other '%' is a usage error, and so is a
// width above kMaxFrameWidth (frame numbers have at most 9 digits).
constexpr int kMaxFrameWidth = 16;
constexpr long kMaxFrames = 100000;  // frames in one --frames range
constexpr long kMaxFrameNumber = 999999999;

struct FramePattern {
  std::size_t pos = 0, len = 0;  // the pattern's characters in the path
  int width = 0;                 // zero-padded to this many digits
};

// The pattern of `path` (none: nullopt) and the path with every "%%" made one '%'
// (`unescaped`; positions in FramePattern refer to it).
std::optional<FramePattern> find_frame_pattern(const std::string& flag, const std::string& path,
                                               std::string& unescaped) {
  std::optional<FramePattern> found;
  unescaped.clear();
  auto add = [&](FramePattern p) {
    if (found) throw_usage(flag + " " + path + ": more than one frame pattern (#### or %04d)");
    if (p.width > kMaxFrameWidth)
      throw_usage(flag + " " + path + ": a frame number padded to " + std::to_string(p.width) + " digits (at most " +
                  std::to_string(kMaxFrameWidth) + ")");
    found = p;
  };
  for (std::size_t i = 0; i < path.size();) {
    if (path[i] == '#') {
      std::size_t j = i;
      while (j < path.size() && path[j] == '#') ++j;
      add({unescaped.size(), j - i, static_cast<int>(j - i)});
      unescaped.append(path, i, j - i);
      i = j;
    } else if (path[i] == '%') {
      if (i + 1 < path.size() && path[i + 1] == '%') {  // "%%": a literal '%'
        unescaped += '%';
        i += 2;
        continue;
      }
      std::size_t j = i + 1;
      int width = 0;
      bool zero = false;
      if (j < path.size() && path[j] == '0') {
        zero = true;
        ++j;
        while (j < path.size() && std::isdigit(static_cast<unsigned char>(path[j]))) {
          width = std::min(width * 10 + (path[j++] - '0'), 1000);
        }
      }
      if (j >= path.size() || path[j] != 'd' || (zero && width == 0))
        throw_usage(flag + " " + path + ": '" + path.substr(i, std::min<std::size_t>(j + 1, path.size()) - i) +
                    "' is not a frame pattern; use %d, %0Nd (N digits, zero-padded) or ####, and %% for a literal %");
      add({unescaped.size(), j + 1 - i, width});
      unescaped.append(path, i, j + 1 - i);
      i = j + 1;
    } else {
      unescaped += path[i++];
    }
  }
  return found;
}

std::string expand_frame(const std::string& path, const FramePattern& p, long frame) {
  std::string n = std::to_string(frame);
  if (static_cast<int>(n.size()) < p.width) n.insert(0, static_cast<std::size_t>(p.width) - n.size(), '0');
  return path.substr(0, p.pos) + n + path.substr(p.pos + p.len);
}

// A path the system can take: no name longer than NAME_MAX, the whole below PATH_MAX.
void check_path_length(const std::string& flag, const std::string& path, long frame) {
  std::size_t name = 0;
  for (const char c : path) {
    name = c == '/' ? 0 : name + 1;
    if (name > NAME_MAX)
      throw_usage(flag + " " + path + ": a name in frame " + std::to_string(frame) + "'s path is longer than " +
                  std::to_string(NAME_MAX) + " bytes");
  }
  if (path.size() >= PATH_MAX)
    throw_usage(flag + ": frame " + std::to_string(frame) + "'s path is longer than " + std::to_string(PATH_MAX - 1) +
                " bytes");
}

// FIRST-LAST or FIRST-LASTxSTEP (inclusive, FIRST >= 0), or one frame number: digits only.
struct FrameRange {
  long first = 0, last = 0, step = 1;
  long count() const { return (last - first) / step + 1; }
  long at(long i) const { return first + i * step; }
};
FrameRange parse_frames(const std::string& text) {
  auto bad = [&] {
    throw_usage("--frames " + text +
                ": expected FIRST-LAST or FIRST-LASTxSTEP (e.g. 1001-1100, 1-99x2), frame numbers 0 to " +
                std::to_string(kMaxFrameNumber));
  };
  std::size_t i = 0;
  auto number = [&](long& out) {
    const std::size_t start = i;
    out = 0;
    while (i < text.size() && std::isdigit(static_cast<unsigned char>(text[i])) && i - start < 10)
      out = out * 10 + (text[i++] - '0');
    if (i == start || i - start >= 10 || out > kMaxFrameNumber) bad();
  };
  FrameRange r;
  number(r.first);
  r.last = r.first;
  if (i < text.size()) {
    if (text[i++] != '-') bad();
    number(r.last);
    if (i < text.size()) {
      if (text[i++] != 'x') bad();
      number(r.step);
    }
  }
  if (i != text.size() || r.last < r.first || r.step < 1) bad();
  if (r.count() > kMaxFrames)
    throw_usage("--frames " + text + ": " + std::to_string(r.count()) + " frames, more than the limit of " +
                std::to_string(kMaxFrames) + " in one run (split the range)");
  return r;
}

void list_debug_views(const std::string& method) {
  for (const auto& m : methods()) {
    if (m.name != method) continue;
    if (m.debug_views.empty()) std::cout << "method " << m.name << " has no debug views\n";
    for (const auto& v : m.debug_views) std::cout << v.name << "  " << v.help << "\n";
    return;
  }
  std::string known;
  for (const auto& m : methods()) known += (known.empty() ? "" : ", ") + m.name;
  throw_usage("--method " + method + ": unknown method (known: " + known + ")");
}

// Checks the method name, its --set keys and the debug view before any file is read (the
// library checks them again, with the same messages, when it renders).
void check_method(const std::string& method, const std::map<std::string, std::string>& params,
                  const std::string& debug_view) {
  for (const auto& m : methods()) {
    if (m.name != method) continue;
    std::string keys, views;
    for (const auto& p : m.params) keys += (keys.empty() ? "" : ", ") + p.name;
    for (const auto& v : m.debug_views) views += (views.empty() ? "" : ", ") + v.name;
    for (const auto& kv : params) {
      // Not a structured binding: clang 14 cannot capture those in a lambda.
      const std::string& key = kv.first;
      const std::string& value = kv.second;
      const auto it = std::find_if(m.params.begin(), m.params.end(), [&](const ParamInfo& p) { return p.name == key; });
      if (it == m.params.end())
        throw_usage("--set " + key + "=" + value + ": unknown parameter for method " + method +
                    (keys.empty() ? std::string(" (it has none)") : " (known: " + keys + ")"));
      detail::check_param_value(method, *it, value);  // type and range, before any file is read
    }
    if (!debug_view.empty()) {
      const bool known = std::any_of(m.debug_views.begin(), m.debug_views.end(),
                                     [&](const DebugViewInfo& v) { return v.name == debug_view; });
      if (!known)
        throw_usage("--debug-view " + debug_view + ": method " + method + " has no such view (" +
                    (views.empty() ? std::string("it has none") : "known: " + views) + ")");
    }
    return;
  }
  list_debug_views(method);  // throws the "unknown method" usage error
}

// The paths of one frame (the flags' own paths without --frames).
struct FramePaths {
  std::string color, depth, layers, mask, mask_depth, output, output_coc, debug_output;
  std::vector<NamedPath> inputs() const { return named(false); }
  std::vector<NamedPath> outputs() const { return named(true); }
  std::vector<NamedPath> named_all() const {
    std::vector<NamedPath> v = inputs(), o = outputs();
    v.insert(v.end(), o.begin(), o.end());
    return v;
  }

 private:
  std::vector<NamedPath> named(bool outputs) const;
};

// Every path of a frame with its flag: the one list the path checks and the frame-pattern
// expansion both walk.
struct FrameField {
  const char* flag;
  std::string FramePaths::*path;
  bool output;
};
constexpr FrameField kFrameFields[] = {
    {"--color", &FramePaths::color, false},           {"--depth", &FramePaths::depth, false},
    {"--layers", &FramePaths::layers, false},         {"--mask", &FramePaths::mask, false},
    {"--mask-depth", &FramePaths::mask_depth, false}, {"--output", &FramePaths::output, true},
    {"--output-coc", &FramePaths::output_coc, true},  {"--debug-output", &FramePaths::debug_output, true}};

std::vector<NamedPath> FramePaths::named(bool outputs) const {
  std::vector<NamedPath> v;
  for (const FrameField& f : kFrameFields)
    if (f.output == outputs) v.push_back({f.flag, this->*f.path});
  return v;
}

// File identity for the overlap checks of a sequence: an existing file by its device and
// inode (so symlinks and hard links match), a new one by its folder's canonical path (cached
// per folder) and its name. An output's folder must exist and the output must not be one.
class FileKeys {
 public:
  std::string of(const std::string& path, const NamedPath* output = nullptr) {
    struct stat st {};
    if (::stat(path.c_str(), &st) == 0) {
      if (output && S_ISDIR(st.st_mode)) throw_bad_input(output->flag + " " + path + ": is a folder");
      return "i:" + std::to_string(st.st_dev) + ":" + std::to_string(st.st_ino);
    }
    // Not there (yet): its folder, as written, canonicalised once, and its name.
    const auto slash = path.rfind('/');
    const std::string dir = slash == std::string::npos ? "." : path.substr(0, slash == 0 ? 1 : slash);
    const std::string name = slash == std::string::npos ? path : path.substr(slash + 1);
    auto it = dirs_.find(dir);
    if (it == dirs_.end()) {
      std::error_code ec;
      const std::filesystem::path c = std::filesystem::canonical(dir, ec);
      it = dirs_.emplace(dir, ec || !std::filesystem::is_directory(c, ec) ? std::string() : c.string()).first;
    }
    if (it->second.empty() && output)
      throw_bad_input(output->flag + " " + path + ": folder " + dir + " does not exist");
    return "p:" + (it->second.empty() ? dir : it->second) + "/" + name;
  }

 private:
  std::map<std::string, std::string> dirs_;
};

// Step 2 for one frame: the inputs, read and validated.
struct FrameInputs {
  Frame frame;
  Image mask, mask_depth;
  io::DepthFacts depth_facts;  // for the sanity warnings
  long frame_number = -1;      // with --frames: drives --focus-keys / --focus-at-keys
  // An EXR --output: what the colour EXR carries beyond its colour (exr_passthrough.hpp), and
  // the notes on what it could not carry (said once, with the first frame).
  std::shared_ptr<const io::ExrPassthrough> passthrough;
  std::vector<std::string> passthrough_notes;
};
// Sizes before pixels: every input's header (no pixel decoded), their sizes compared, and
// the frame's estimated memory held to --max-memory. A mismatch, a bomb or a request too large
// for the machine is refused here, at the cost of reading a few headers.
void check_frame_headers(const RenderArgs& a, const FramePaths& p, const RenderSettings& settings, bool sequence) {
  struct Seen {
    std::string path;
    const char* what;
    io::ImageInfo info;
  };
  std::vector<Seen> seen;
  if (!p.color.empty()) seen.push_back({p.color, "colour", io::probe_image(p.color, "colour")});
  if (!p.layers.empty()) seen.push_back({p.layers, "layers", io::probe_image(p.layers, "layered input")});
  if (!p.depth.empty()) seen.push_back({p.depth, "depth", io::probe_image(p.depth, "depth")});
  if (!p.mask.empty()) seen.push_back({p.mask, "mask", io::probe_image(p.mask, "mask")});
  if (!p.mask_depth.empty()) seen.push_back({p.mask_depth, "mask depth", io::probe_image(p.mask_depth, "mask depth")});
  const Seen& first = seen.front();
  for (const Seen& s : seen) {
    if (s.path == p.depth && p.layers.empty() && &s != &first) {
      // A smaller depth map is resampled to the colour's size (--depth-upsample).
      io::check_depth_fit(p.depth, s.info.width, s.info.height, first.path, first.info.width, first.info.height,
                          a.depth_flags.build().stretch);
      continue;
    }
    if (s.info.width != first.info.width || s.info.height != first.info.height)
      throw_bad_input(s.path + ": " + s.what + " is " + std::to_string(s.info.width) + "x" +
                      std::to_string(s.info.height) + " but " + first.what + " " + first.path + " is " +
                      std::to_string(first.info.width) + "x" + std::to_string(first.info.height));
  }
  FrameShape shape;
  shape.width = first.info.width;
  shape.height = first.info.height;
  shape.mask = !p.mask.empty();
  if (!a.rgba_only && !p.output.empty() && !p.color.empty() && io::is_exr_path(p.output) && io::is_exr_path(p.color))
    shape.passthrough_channels = std::max(0, seen.front().info.channels);
  if (!p.layers.empty()) {
    const io::ImageInfo& l = seen[p.color.empty() ? 0 : 1].info;
    // Deep: as many layers as the deepest pixel has samples, at most --max-layers (not known
    // before the samples are read: the most); layered EXR: five channels per layer.
    shape.layers = l.deep || l.channels <= 0 ? a.max_layers : std::min(a.max_layers, (l.channels + 4) / 5);
    shape.deep_sample_bytes = l.deep_sample_bytes;
    if (!l.deep) shape.layer_file_channels = l.channels;
  }
  check_memory(render_frame_bytes(settings, shape, sequence),
               "rendering " + std::to_string(shape.width) + "x" + std::to_string(shape.height) +
                   (shape.layers ? " with " + std::to_string(shape.layers) + " layers" : std::string()) +
                   " with method " + settings.method,
               "use a smaller image" + std::string(shape.layers ? " or fewer --max-layers" : "") +
                   ", or raise --max-memory if the machine has the memory");
}

FrameInputs read_inputs_checked(const RenderArgs& a, const FramePaths& p, const io::DepthOptions& depth_opt);

FrameInputs read_inputs(const RenderArgs& a, const FramePaths& p, const io::DepthOptions& depth_opt,
                        const RenderSettings& settings, bool sequence) {
  check_frame_headers(a, p, settings, sequence);
  return while_doing("reading " + (p.color.empty() ? p.layers : p.color) + " and the frame's other inputs",
                     [&] { return read_inputs_checked(a, p, depth_opt); });
}

// --color-channels as names (checked when the flags are: 3 or 4 non-empty names).
std::vector<std::string> color_channel_names(const std::string& text) {
  std::vector<std::string> names;
  if (text.empty()) return names;
  std::size_t start = 0;
  while (true) {
    const auto comma = text.find(',', start);
    names.push_back(text.substr(start, comma == std::string::npos ? std::string::npos : comma - start));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  const bool empty_name = std::any_of(names.begin(), names.end(), [](const std::string& n) { return n.empty(); });
  if (names.size() < 3 || names.size() > 4 || empty_name)
    throw_usage("--color-channels " + text + ": expected R,G,B or R,G,B,A (3 or 4 channel names)");
  return names;
}

FrameInputs read_inputs_checked(const RenderArgs& a, const FramePaths& p, const io::DepthOptions& depth_opt) {
  FrameInputs in;
  Frame& frame = in.frame;
  const std::vector<std::string> color_channels = color_channel_names(a.color_channels);
  if (p.layers.empty()) {
    frame = io::load_frame(p.color, p.depth, depth_opt, color_channels, &in.depth_facts);
  } else {
    frame = read_layered_frame(p.color, p.depth, p.layers, depth_opt, color_channels, a.max_layers, &in.depth_facts);
  }
  if (!a.rgba_only && !p.output.empty() && !p.color.empty() && io::is_exr_path(p.output) && io::is_exr_path(p.color))
    in.passthrough = io::ExrPassthrough::read(p.color, color_channels, frame.color.width(), frame.color.height(),
                                              in.passthrough_notes);
  Image& mask = in.mask;
  Image& mask_depth = in.mask_depth;
  if (!p.mask.empty()) {
    mask = io::read_mask(p.mask);
    // Outside the mask this depth is never used, so files may hold 0 or NaN there; inside,
    // an invalid value is taken as infinitely far.
    io::DepthOptions mopt = depth_opt;
    mopt.invalid_as_far = true;
    mask_depth = io::read_depth(p.mask_depth, mopt);
    if (!mask.same_size(frame.color) || !mask_depth.same_size(frame.color))
      throw_bad_input((mask.same_size(frame.color) ? p.mask_depth : p.mask) + ": is " +
                      std::to_string((mask.same_size(frame.color) ? mask_depth : mask).width()) + "x" +
                      std::to_string((mask.same_size(frame.color) ? mask_depth : mask).height()) + " but colour is " +
                      std::to_string(frame.color.width()) + "x" + std::to_string(frame.color.height()));
  }
  return in;
}

double render_and_write(const RenderArgs& a, const FramePaths& p, const FrameInputs& in, RenderSettings& settings,
                        std::optional<Renderer>& renderer, const io::WriteOptions& out_opt,
                        const io::WriteOptions& coc_opt, const io::WriteOptions& debug_opt);

// Steps 3–4 for one frame. `renderer` (kept across the frames of a sequence) is made on the
// first call; masked renders go through render_masked. Returns the largest |CoC| in pixels.
double render_frame(const RenderArgs& a, const FramePaths& p, const FrameInputs& in, RenderSettings& settings,
                    std::optional<Renderer>& renderer, const io::WriteOptions& out_opt, const io::WriteOptions& coc_opt,
                    const io::WriteOptions& debug_opt) {
  return while_doing("rendering " + std::to_string(in.frame.width()) + "x" + std::to_string(in.frame.height()) +
                         " with method " + a.method + " and writing " + p.output,
                     [&] { return render_and_write(a, p, in, settings, renderer, out_opt, coc_opt, debug_opt); });
}

double render_and_write(const RenderArgs& a, const FramePaths& p, const FrameInputs& in, RenderSettings& settings,
                        std::optional<Renderer>& renderer, const io::WriteOptions& out_opt,
                        const io::WriteOptions& coc_opt, const io::WriteOptions& debug_opt) {
  const Frame& frame = in.frame;
  a.camera.require_focus(in.depth_facts.focus_m, p.color);
  settings.camera = a.camera.build(&frame.depth, in.frame_number, in.depth_facts.focus_m);

  // 3. Render.
  const auto t0 = std::chrono::steady_clock::now();
  RenderResult masked;
  const RenderResult* result = &masked;
  if (!p.mask.empty()) {
    masked = render_masked(frame, in.mask, in.mask_depth, settings);
  } else {
    if (!renderer)
      renderer.emplace(settings);
    else
      renderer->set_camera(settings.camera);
    result = &renderer->render(frame);
  }
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();

  // 4. Outputs, all or nothing.
  OutputWriter out;
  if (!p.output.empty() && in.passthrough && !in.passthrough->empty())
    out.add_file(p.output, [&](const std::string& temp) {
      io::encode_exr_passthrough(temp, p.output, result->image, out_opt, *in.passthrough);
    });
  else if (!p.output.empty())
    out.add_image(p.output, result->image, out_opt);
  if (!p.output_coc.empty())
    out.add_image(p.output_coc, io::is_exr_path(p.output_coc) ? result->coc : focus_zone_picture(result->coc), coc_opt);
  if (!p.debug_output.empty()) out.add_image(p.debug_output, result->debug, debug_opt);
  out.commit();
  std::cerr << "dofkit: wrote "
            << (!p.output.empty()         ? p.output
                : !p.debug_output.empty() ? p.debug_output
                                          : p.output_coc)
            << " (" << frame.width() << "x" << frame.height() << ", method " << a.method << ", "
            << describe(settings.camera) << ", render " << static_cast<long>(ms + 0.5) << " ms)\n";
  double largest = 0;
  for (const float r : result->coc.data())
    if (std::isfinite(r)) largest = std::max(largest, static_cast<double>(std::fabs(r)));
  return largest;
}

// Whether the camera asks for any blur of half a pixel or more somewhere (so that a CoC map
// without one says the depth's units are off).
bool blur_asked(const CameraModel& cam) {
  if (cam.max_coc_px < 0.5) return false;
  return std::visit(
      [](const auto& m) -> bool {
        using T = std::decay_t<decltype(m)>;
        if constexpr (std::is_same_v<T, ThinLens>) return true;
        if constexpr (std::is_same_v<T, BlurAtInfinity>) return m.blur_at_infinity_px >= 0.5;
        if constexpr (std::is_same_v<T, FourPlane>) return std::max(m.near_radius_px, m.far_radius_px) >= 0.5;
        if constexpr (std::is_same_v<T, StarCraft>) return m.amount * m.max_radius_px >= 0.5;
        if constexpr (std::is_same_v<T, NearFarBlend>) return m.max_radius_px >= 0.5;
        return false;
      },
      cam.model);
}

// The two sanity warnings (each once per run, one line on stderr; the picture is never
// changed): a CoC map below half a pixel everywhere while the camera asks for blur, and an
// 8/16-bit depth file read as z (its values are 0..1 m, which is what a normalised
// disparity map gives).
struct SanityWarnings {
  bool coc_done = false, integer_done = false;
  void check(const RenderArgs& a, const io::DepthOptions& opt, const FramePaths& p, const FrameInputs& in,
             const RenderSettings& settings, double largest_coc_px) {
    if (!integer_done && in.depth_facts.integer && opt.kind == io::DepthKind::z && opt.scale == 1.0) {
      integer_done = true;
      std::cerr << "dofkit: warning: " << (p.depth.empty() ? p.color : p.depth)
                << ": 8/16-bit depth read as z in metres gives 0..1 m; if it is a disparity map (bright = near) use "
                   "--depth-kind disparity, if z in other units --depth-scale\n";
    }
    if (!coc_done && largest_coc_px < 0.5 && blur_asked(settings.camera)) {
      coc_done = true;
      std::cerr << "dofkit: warning: every CoC radius is below 0.5 px (largest " << largest_coc_px
                << " px) though the camera asks for blur: is the depth in metres? use --depth-units (cm, mm, in, "
                   "ft) or --depth-scale"
                << (a.depth_flags.kind_given() ? "" : ", or --depth-kind if it is not planar z") << "\n";
    }
  }
};

// What the first frame's inputs say (once per run): where an embedded depth map came from,
// and what an EXR output could not pass through.
void say_input_notes(const FrameInputs& in) {
  if (!in.depth_facts.embedded.empty()) std::cerr << "dofkit: note: depth from " << in.depth_facts.embedded << "\n";
  for (const std::string& n : in.passthrough_notes) std::cerr << "dofkit: note: " << n << "\n";
}

void run_render(RenderArgs& a) {
  // 1. Flags and paths.
  if (a.debug_view == "list") {
    list_debug_views(a.method);
    return;
  }
  const std::map<std::string, std::string> params = parse_sets(a.sets);
  check_method(a.method, params, a.debug_view);
  if (a.color.empty() && a.layers.empty()) throw_usage("--color: required (or --layers)");
  if (a.output.empty() && a.debug_output.empty() && a.output_coc.empty())
    throw_usage("--output: required (or --output-coc / --debug-output alone)");
  if (!a.debug_view.empty() && a.debug_output.empty()) throw_usage("--debug-view: needs --debug-output FILE");
  if (a.debug_view.empty() && !a.debug_output.empty()) throw_usage("--debug-output: needs --debug-view NAME");
  if (a.mask.empty() != a.mask_depth.empty()) throw_usage("--mask and --mask-depth: give both or neither");
  if (!a.mask.empty() && !a.layers.empty()) throw_usage("--mask and --layers: cannot be combined");
  color_channel_names(a.color_channels);  // syntax
  a.budget.apply();
  // A phone photo without --depth may record its focus distance (checked once it is read).
  const bool photo_depth = a.layers.empty() && io::reads_embedded_depth(a.color, a.depth, a.depth_flags.channel());
  a.camera.check(photo_depth);
  if (a.camera.animated() && a.frames.empty())
    throw_usage(
        "--focus-keys / --focus-at-keys / --f-number-keys / --blur-at-infinity-keys: the keys need --frames (one "
        "still plate is fine: --frames FIRST-LAST with an unnumbered --color)");
  a.aperture.check();
  a.highlights.check();
  const io::DepthOptions depth_opt = a.depth_flags.build();
  RenderSettings settings;
  settings.method = a.method;
  settings.params = params;
  settings.threads = a.threads;
  settings.debug_view = a.debug_view;
  settings.max_work = a.max_work;
  settings.backend = parse_backend(a.backend);
  if (t_render_progress) settings.progress = *t_render_progress;

  // --compression: every EXR output of the run (at least one must be EXR).
  if (!a.compression.empty() && !io::is_exr_path(a.output) && !io::is_exr_path(a.output_coc) &&
      !io::is_exr_path(a.debug_output))
    throw_usage("--compression " + a.compression + ": applies to .exr outputs, and none is given");
  auto exr_compression = [&](const std::string& p) { return io::is_exr_path(p) ? a.compression : std::string(); };
  // --png-level: every PNG output of the run (at least one must be PNG).
  if (a.png_level != -1 && !io::is_png_path(a.output) && !io::is_png_path(a.debug_output) &&
      !io::is_png_path(a.output_coc))
    throw_usage("--png-level " + std::to_string(a.png_level) + ": applies to .png outputs, and none is given");
  auto png_level = [&](const std::string& p) { return io::is_png_path(p) ? a.png_level : -1; };
  io::WriteOptions out_opt;
  out_opt.bits = a.bits;
  out_opt.compression = exr_compression(a.output);
  out_opt.png_level = png_level(a.output);
  if (!a.output.empty()) io::check_output_format(a.output, out_opt, "--output");
  if (a.rgba_only && !io::is_exr_path(a.output)) throw_usage("--rgba-only: applies to an .exr --output");
  if (a.output.empty() && a.bits != 0) throw_usage("--bits " + std::to_string(a.bits) + ": applies to --output");
  io::WriteOptions coc_opt;
  coc_opt.channel_name = "Y";
  coc_opt.compression = exr_compression(a.output_coc);
  if (!a.output_coc.empty()) {
    // EXR: the signed float map; any other format: the focus-zone picture, display codes.
    if (!io::is_exr_path(a.output_coc)) {
      coc_opt.encoding = io::Encoding::linear;
      coc_opt.bits = a.coc_bits;
      coc_opt.png_level = png_level(a.output_coc);
    } else if (a.coc_bits != 0) {
      throw_usage("--coc-bits " + std::to_string(a.coc_bits) + ": applies to a .png/.tif/.jpg --output-coc");
    }
    io::check_output_format(a.output_coc, coc_opt, "--output-coc");
  } else if (a.coc_bits != 0) {
    throw_usage("--coc-bits " + std::to_string(a.coc_bits) + ": needs --output-coc");
  }
  io::WriteOptions debug_opt;
  debug_opt.compression = exr_compression(a.debug_output);
  debug_opt.png_level = png_level(a.debug_output);
  if (!a.debug_output.empty()) io::check_output_format(a.debug_output, debug_opt, "--debug-output");

  // The frames: without --frames one, with the flags' paths as given (a '#' or '%' in them
  // is just a character); with --frames every path's pattern takes the frame number. The
  // outputs need one (each frame its own files), and so does --color or --layers (else every
  // frame would render the same input); a depth, mask or mask depth without one serves every
  // frame.
  const bool sequence = !a.frames.empty();
  FrameRange range = sequence ? parse_frames(a.frames) : FrameRange{-1, -1, 1};
  // A farm task's chunk of the list (chunks.hpp): a contiguous slice, so again a FrameRange.
  if (const auto chunk = resolve_chunk(a.farm, a.frames, sequence ? static_cast<std::size_t>(range.count()) : 0)) {
    const ChunkRange r = chunk_range(static_cast<std::size_t>(range.count()), chunk->index, chunk->count);
    const long total = range.count();
    range = FrameRange{range.at(static_cast<long>(r.begin)), range.at(static_cast<long>(r.end) - 1), range.step};
    std::cerr << "dofkit: chunk " << chunk->index << " of " << chunk->count << " (from 0): frames " << range.first
              << ".." << range.last << ", " << range.count() << " of the " << total << " of --frames " << a.frames
              << "\n";
  }
  FramePaths given{a.color, a.depth, a.layers, a.mask, a.mask_depth, a.output, a.output_coc, a.debug_output};
  std::optional<FramePattern> pattern[std::size(kFrameFields)];
  if (sequence) {
    for (std::size_t k = 0; k < std::size(kFrameFields); ++k) {
      const FrameField& f = kFrameFields[k];
      std::string& path = given.*f.path;
      if (path.empty()) continue;
      std::string unescaped;
      pattern[k] = find_frame_pattern(f.flag, path, unescaped);
      if (f.output && !pattern[k])
        throw_usage(std::string(f.flag) + " " + path +
                    ": needs a frame pattern (#### or %04d) with --frames, so that every frame has its own file");
      path = unescaped;
    }
    auto has_pattern = [&](std::string FramePaths::*path) {
      for (std::size_t k = 0; k < std::size(kFrameFields); ++k)
        if (kFrameFields[k].path == path) return pattern[k].has_value();
      return false;
    };
    // One still plate is fine when the frames differ by their focus keys.
    if (!has_pattern(&FramePaths::color) && !has_pattern(&FramePaths::layers) && !a.camera.animated())
      throw_usage(std::string(a.layers.empty() ? "--color " + a.color : "--layers " + a.layers) +
                  ": needs a frame pattern (#### or %04d) with --frames");
  }
  auto paths_of = [&](long frame) {
    FramePaths p = given;
    for (std::size_t k = 0; k < std::size(kFrameFields); ++k)
      if (pattern[k]) p.*kFrameFields[k].path = expand_frame(given.*kFrameFields[k].path, *pattern[k], frame);
    return p;
  };
  // Every frame's paths are checked before the first frame is read: no output may be an
  // input or another output of any frame (usage errors first), and with --frames every input
  // must exist (so a missing frame stops the run before anything is written).
  // The aperture image is an input of every frame.
  auto with_aperture = [&](std::vector<NamedPath> ins) {
    ins.push_back({"--aperture-image", a.aperture.image_path()});
    return ins;
  };
  if (!sequence) {
    check_paths(with_aperture(given.inputs()), given.outputs());
  } else {
    // The longest numbers make the longest paths: the first and the last frame.
    for (const long f : {range.first, range.at(range.count() - 1)})
      for (const NamedPath& np : paths_of(f).named_all()) check_path_length(np.flag, np.path, f);
    check_paths(with_aperture(paths_of(range.first).inputs()), paths_of(range.first).outputs());
    // The overlaps of all frames, by file identity (cheap enough for 100,000 frames).
    FileKeys keys;
    std::map<std::string, std::pair<NamedPath, long>> inputs_seen, outputs_seen;
    // (An input without a pattern is the same file in every frame: keyed once.)
    for (std::size_t k = 0; k < std::size(kFrameFields); ++k) {
      const FrameField& f = kFrameFields[k];
      if (f.output || (given.*f.path).empty()) continue;
      for (long i = 0; i < (pattern[k] ? range.count() : 1); ++i) {
        const long frame = range.at(i);
        const std::string path = pattern[k] ? expand_frame(given.*f.path, *pattern[k], frame) : given.*f.path;
        inputs_seen.emplace(keys.of(path), std::make_pair(NamedPath{f.flag, path}, frame));
      }
    }
    for (long i = 0; i < range.count(); ++i)
      for (const NamedPath& out : paths_of(range.at(i)).outputs()) {
        if (out.path.empty()) continue;
        const std::string key = keys.of(out.path, &out);
        if (const auto it = inputs_seen.find(key); it != inputs_seen.end())
          throw_usage(out.flag + " " + out.path + ": is the same file as " + it->second.first.flag + " " +
                      it->second.first.path + " (frame " + std::to_string(it->second.second) +
                      "; refusing to overwrite an input)");
        if (!outputs_seen.emplace(key, std::make_pair(out, range.at(i))).second)
          throw_usage(out.flag + " " + out.path + ": is also an output of another frame of --frames " + a.frames);
      }
  }
  // The frames to render: all, or with --skip-existing those whose outputs do not all exist.
  std::vector<long> frames;
  for (long i = 0; i < range.count(); ++i)
    if (!a.farm.skip_existing || !outputs_exist(paths_of(range.at(i)).outputs())) frames.push_back(range.at(i));
  if (a.farm.skip_existing) {
    std::cerr << "dofkit: --skip-existing: " << range.count() - static_cast<long>(frames.size()) << " of "
              << range.count() << (range.count() == 1 ? " frame" : " frames") << " already written, skipped\n";
    if (frames.empty()) return;
  }
  if (sequence) {
    // Then the first missing input, in frame order, before any frame is read.
    for (const long frame : frames)
      for (const NamedPath& in : paths_of(frame).inputs()) {
        struct stat st {};
        if (!in.path.empty() && ::stat(in.path.c_str(), &st) != 0)
          throw_bad_input(in.flag + " " + in.path + ": does not exist (frame " + std::to_string(frame) +
                          " of --frames " + a.frames + ")");
      }
  }

  // The aperture (its image is an input too) and highlight recovery, whose default depends on
  // whether the colour is display-referred (an 8/16-bit file).
  settings.aperture = a.aperture.build();
  std::string aperture_note;  // said with the highlight note, once the first inputs are read
  if (!settings.aperture.is_circle()) {
    bool honoured = true;  // an unknown method is render()'s error to report
    for (const auto& m : methods())
      if (m.name == a.method) honoured = !m.aperture.empty();
    // lens, the default, draws the analytic shapes but refuses the cat's eye and an aperture
    // image (a usage error naming --method reference); with neither --method nor --set such an
    // aperture goes to reference, the accurate method that draws every aperture.
    const bool lens_refuses =
        a.method == "lens" && (settings.aperture.image != nullptr || settings.aperture.cat_eye != 0.0);
    const bool defaulted = a.method_opt && a.method_opt->count() == 0 && a.sets.empty() && a.debug_view.empty();
    if ((!honoured || lens_refuses) && defaulted) {
      aperture_note = "dofkit: note: " + a.method + " (the default method) does not draw this aperture (" +
                      (settings.aperture.image ? "an aperture image" : "the cat's eye") +
                      "); rendering with reference, which does (--method chooses)\n";
      a.method = settings.method = "reference";
    } else if (!honoured) {
      aperture_note = "dofkit: note: method " + a.method +
                      " draws its own kernel; the aperture flags apply to the methods that honour them (see dofkit "
                      "methods)\n";
    }
  }
  const FramePaths first = sequence ? paths_of(range.first) : paths_of(-1);
  const bool display = !first.color.empty() && io::is_display_referred(first.color);
  settings.highlights = a.highlights.build(display);
  // Notes are said once the first frame's inputs have been read (an input error stays one line).
  bool noted = false;
  auto say_notes = [&] {
    if (noted) return;
    noted = true;
    std::cerr << aperture_note;
    if (!display || !settings.highlights.enabled()) return;
    std::cerr << "dofkit: " << first.color
              << " is display-referred (8/16-bit): highlight recovery on (--highlight-boost "
              << settings.highlights.boost << "; --highlight-boost 0 turns it off)\n";
  };

  // 2–4, frame by frame. In a sequence the next frame's inputs are read on another thread
  // while this frame renders and is written; a read error is reported when that frame's turn
  // comes, after the frames before it are written.
  std::optional<Renderer> renderer;
  SanityWarnings warnings;
  const auto t0 = std::chrono::steady_clock::now();
  if (!sequence) {
    const FramePaths p = paths_of(-1);
    FrameInputs in = read_inputs(a, p, depth_opt, settings, false);
    say_notes();
    say_input_notes(in);
    const double largest = render_frame(a, p, in, settings, renderer, out_opt, coc_opt, debug_opt);
    warnings.check(a, depth_opt, p, in, settings, largest);
  } else {
    auto read_async = [&](long frame) {
      return std::async(std::launch::async, [&a, &depth_opt, s = settings, p = paths_of(frame), frame] {
        FrameInputs in = read_inputs(a, p, depth_opt, s, true);
        in.frame_number = frame;
        return in;
      });
    };
    const GracefulStop stop;
    std::future<FrameInputs> next = read_async(frames[0]);
    for (std::size_t i = 0; i < frames.size(); ++i) {
      if (i > 0)
        GracefulStop::stop_if_requested("stopped by SIGTERM after " + std::to_string(i) + " of " +
                                        std::to_string(frames.size()) + " frames; frame " + std::to_string(frames[i]) +
                                        " on not rendered (rerun with --skip-existing to resume)");
      const FrameInputs in = next.get();
      say_notes();
      if (i == 0) say_input_notes(in);
      if (i + 1 < frames.size()) next = read_async(frames[i + 1]);
      const double largest = render_frame(a, paths_of(frames[i]), in, settings, renderer, out_opt, coc_opt, debug_opt);
      warnings.check(a, depth_opt, paths_of(frames[i]), in, settings, largest);
    }
    std::cerr << "dofkit: " << frames.size() << " frames in "
              << static_cast<long>(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() * 1000 +
                                   0.5)
              << " ms\n";
  }
}

}  // namespace

void run_render_command(const std::vector<std::string>& args, const ProgressCallback& progress) {
  CLI::App app{"dofkit"};
  app.require_subcommand(1);
  add_render_command(app);
  std::vector<std::string> argv{"render"};
  argv.insert(argv.end(), args.begin(), args.end());
  std::reverse(argv.begin(), argv.end());  // CLI11 takes a vector last argument first
  struct Restore {
    ~Restore() { t_render_progress = nullptr; }
  } restore;
  t_render_progress = progress ? &progress : nullptr;
  try {
    app.parse(argv);
  } catch (const CLI::ParseError& e) {
    throw_usage(e.what());
  }
}

void add_render_command(CLI::App& app) {
  auto args = std::make_shared<RenderArgs>();
  auto* cmd = app.add_subcommand("render", "render depth of field from a colour image and a depth map");
  cmd->footer(kFooter);
  const std::string in = "Input", outg = "Output", meth = "Method";
  cmd->add_option("--color", args->color,
                  "colour image: EXR (linear), PNG/JPEG/TIFF 8/16-bit (sRGB), float TIFF (linear); RGB or RGBA")
      ->group(in);
  cmd->add_option("--depth", args->depth,
                  "depth map, same size: a single-channel file (any channel name) or an EXR with a Z channel; "
                  "default: the Z channel of --color")
      ->group(in);
  cmd->add_option(
         "--layers", args->layers,
         "multi-fragment input for the layered method: deep EXR or the layered EXR of `dofkit scene --layers`; "
         "without --color its front-to-back composite is the colour")
      ->group(in);
  args->budget.add(cmd);
  add_number(cmd, "--max-layers", args->max_layers, "--layers: keep at most this many fragments per pixel (default 8)")
      ->group(in);
  cmd->add_option("--color-channels", args->color_channels,
                  "R,G,B[,A]: the colour channels of --color by name (default: bare R,G,B[,A], else the one layer "
                  "holding them, else the *Combined* / *beauty* layer)")
      ->group(in);
  cmd->add_option("--mask", args->mask,
                  "transparency coverage 0..1 (single channel, or the alpha of a multi-channel file): re-render there "
                  "with --mask-depth and blend (StarCraft II key transparencies)")
      ->group(in);
  cmd->add_option("--mask-depth", args->mask_depth,
                  "depth of the transparency under --mask (same --depth-kind); values outside the mask are ignored")
      ->group(in);
  args->depth_flags.add(cmd);
  args->camera.add(cmd);
  args->aperture.add(cmd);
  args->highlights.add(cmd);
  args->farm.add(cmd);
  args->method_opt = cmd->add_option("--method", args->method,
                                     "technique (default lens; with --cat-eye or --aperture-image and no --method "
                                     "or --set: reference; see `dofkit methods`)")
                         ->group(meth);
  cmd->add_option("--set", args->sets, "KEY=VALUE method parameter, repeatable (see `dofkit methods`)")
      ->allow_extra_args(false)
      ->group(meth);
  add_threads(cmd, args->threads,
              "worker threads, 0 = all hardware threads (default); output is identical for every count")
      ->group(meth);
  add_number(cmd, "--max-work", args->max_work,
             "reference / scatter: refuse a frame whose discs need more pixel visits than this (default 2e11, about "
             "half a minute on two cores); see docs/robustness.md")
      ->group(meth);
  cmd->add_option("--backend", args->backend,
                  "cpu (default) or vulkan: run the method's passes as Vulkan compute shaders on the GPU "
                  "(mcguire, sterna, starcraft; DOFKIT_VK_DEVICE=<index|name> picks the device)")
      ->group(meth);
  cmd->add_option("--debug-view", args->debug_view,
                  "NAME of an intermediate buffer to save with --debug-output; `list` prints the method's views")
      ->group(meth);
  cmd->add_option("--output", args->output,
                  "result image: .exr (float, linear, premultiplied RGBA), .png/.tif (sRGB, straight alpha), .jpg")
      ->group(outg);
  add_number(cmd, "--bits", args->bits,
             "bits per channel of --output: EXR 32 (default) or 16 (half); PNG/TIFF 8 (default) or 16; TIFF 32 "
             "(float)")
      ->group(outg);
  cmd->add_flag("--rgba-only", args->rgba_only,
                "an .exr --output holds R, G, B, A only; by default it also keeps an EXR --color's other channels "
                "(AOVs, depth; unchanged, not blurred) and its metadata (docs/cli.md)")
      ->group(outg);
  cmd->add_option("--compression", args->compression,
                  "compression of every .exr output: none, rle, zips, zip (default), piz, or the lossy pxr24, b44, "
                  "b44a, dwaa, dwab. none writes a 1080p float frame ~4x faster than zip and ~40 % larger")
      ->group(outg);
  add_number(cmd, "--png-level", args->png_level,
             "zlib level of every .png output, 0 (stored, fastest) to 9 (smallest); default 6. A 1080p call with "
             "a PNG out takes ~0.34 s at level 1 against ~0.63 s at 6, for a ~16 % larger file")
      ->group(outg);
  cmd->add_option("--output-coc", args->output_coc,
                  "also write the CoC radius used: .exr = signed float, pixels (> 0 near, < 0 far); .png/.tif/.jpg = "
                  "the focus-zone picture (near orange, far blue, in focus grey; docs/coc.md)")
      ->group(outg);
  add_number(cmd, "--coc-bits", args->coc_bits,
             "bits per channel of a picture --output-coc: PNG/TIFF 8 (default) or 16", "--bits")
      ->group(outg);
  cmd->add_option("--debug-output", args->debug_output, "file for --debug-view (EXR keeps exact values)")->group(outg);
  cmd->add_option("--frames", args->frames,
                  "FIRST-LAST[xSTEP]: render a numbered sequence in one process (one Renderer, buffers reused); "
                  "the frame number replaces a #### run (zero-padded to its length) or %d / %04d in the paths. "
                  "--output (and --output-coc, --debug-output) and --color or --layers need one (--color not with "
                  "--focus-keys: one still plate); a path without one serves every frame; %% is a literal %. At most "
                  "100000 frames. Every frame's inputs must exist "
                  "before the first is rendered; an error stops the run and keeps the frames written before it")
      ->check(CLI::Validator(
          [](std::string& v) -> std::string {
            if (v.empty()) throw_usage("--frames: empty (expected FIRST-LAST or FIRST-LASTxSTEP)");
            return {};
          },
          "", "non-empty"))
      ->group(in);
  cmd->callback([args] { run_render(*args); });
}

}  // namespace dofkit::cli
