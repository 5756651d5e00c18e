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

#include "cli_common.hpp"
#include "commands.hpp"
#include "dofkit/error.hpp"
#include "dofkit/render.hpp"
#include "io/image_io.hpp"
#include "io/layers_io.hpp"

namespace dofkit::cli {

namespace {

struct RenderArgs {
  std::string color, depth, layers, mask, mask_depth;
  std::string output, output_coc, debug_output;
  std::string frames;
  std::string compression;
  int png_level = -1;
  std::string method = "reference";
  std::string debug_view;
  std::vector<std::string> sets;
  int threads = 0;
  std::string backend = "cpu";
  int max_layers = 8;
  long long max_pixels = io::kMaxPixels;
  int bits = 0;
  CameraFlags camera;
  DepthFlags depth_flags;
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

Exit codes: 0 success, 2 usage error, 3 bad input (missing, corrupt or inconsistent files),
1 internal error. On any error no output file is created or changed (with --frames: none of
the failing frame's; the frames before it stay written).
See docs/cli.md for the full reference.)";

// --frames and the frame patterns of the paths. A pattern is a run of '#' (the frame number
// zero-padded to the run's length: shot.####.exr → shot.0012.exr) or printf's %d / %0Nd.
struct FramePattern {
  std::size_t pos = 0, len = 0;  // the pattern's characters in the path
  int width = 0;                 // zero-padded to this many digits
};

std::optional<FramePattern> find_frame_pattern(const std::string& flag, const std::string& path) {
  std::optional<FramePattern> found;
  auto add = [&](FramePattern p) {
    if (found) throw_usage(flag + " " + path + ": more than one frame pattern (#### or %04d)");
    found = p;
  };
  for (std::size_t i = 0; i < path.size();) {
    if (path[i] == '#') {
      std::size_t j = i;
      while (j < path.size() && path[j] == '#') ++j;
      add({i, j - i, static_cast<int>(j - i)});
      i = j;
    } else if (path[i] == '%') {
      std::size_t j = i + 1;
      int width = 0;
      if (j < path.size() && path[j] == '0') {
        ++j;
        while (j < path.size() && std::isdigit(static_cast<unsigned char>(path[j])) && width < 10)
          width = width * 10 + (path[j++] - '0');
      }
      if (j < path.size() && path[j] == 'd') {
        add({i, j + 1 - i, width});
        i = j + 1;
      } else {
        ++i;  // a literal '%'
      }
    } else {
      ++i;
    }
  }
  return found;
}

std::string expand_frame(const std::string& path, const FramePattern& p, int frame) {
  std::string n = std::to_string(frame);
  if (static_cast<int>(n.size()) < p.width) n.insert(0, static_cast<std::size_t>(p.width) - n.size(), '0');
  return path.substr(0, p.pos) + n + path.substr(p.pos + p.len);
}

// FIRST-LAST or FIRST-LASTxSTEP (inclusive, FIRST >= 0), or one frame number.
std::vector<int> parse_frames(const std::string& text) {
  auto bad = [&] {
    throw_usage("--frames " + text +
                ": expected FIRST-LAST or FIRST-LASTxSTEP (e.g. 1001-1100, 1-99x2), frame numbers >= 0");
  };
  long first = 0, last = 0, step = 1;
  char dash = 0, x = 0;
  int used = 0;
  const char* s = text.c_str();
  if (std::sscanf(s, "%ld%n", &first, &used) == 1 && s[used] == '\0') {
    last = first;
  } else if (std::sscanf(s, "%ld%c%ld%n", &first, &dash, &last, &used) == 3 && dash == '-' && s[used] == '\0') {
  } else if (std::sscanf(s, "%ld%c%ld%c%ld%n", &first, &dash, &last, &x, &step, &used) == 5 && dash == '-' &&
             x == 'x' && s[used] == '\0') {
  } else {
    bad();
  }
  if (first < 0 || last < first || step < 1 || last > 999999999) bad();
  if ((last - first) / step + 1 > 1000000) throw_usage("--frames " + text + ": more than 1000000 frames");
  std::vector<int> frames;
  for (long f = first; f <= last; f += step) frames.push_back(static_cast<int>(f));
  return frames;
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
      const bool known =
          std::any_of(m.params.begin(), m.params.end(), [&](const ParamInfo& p) { return p.name == key; });
      if (!known)
        throw_usage("--set " + key + "=" + value + ": unknown parameter for method " + method +
                    (keys.empty() ? std::string(" (it has none)") : " (known: " + keys + ")"));
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

// Step 2 for one frame: the inputs, read and validated.
struct FrameInputs {
  Frame frame;
  Image mask, mask_depth;
};
FrameInputs read_inputs(const RenderArgs& a, const FramePaths& p, const io::DepthOptions& depth_opt) {
  FrameInputs in;
  Frame& frame = in.frame;
  if (p.layers.empty()) {
    frame = io::load_frame(p.color, p.depth, depth_opt);
  } else {
    if (!p.color.empty()) frame.color = io::read_color(p.color);
    if (!p.depth.empty()) frame.depth = io::read_depth(p.depth, depth_opt);
    io::read_layers(p.layers, frame, a.max_layers);
    if (frame.depth.empty() && !p.color.empty()) {
      // --color without --depth: its own Z channel if it has one, else the layers' depth.
      if (io::has_depth_channel(p.color)) frame.depth = io::read_depth(p.color, depth_opt);
    }
    if (!frame.depth.same_size(frame.color))
      throw_bad_input((p.depth.empty() ? p.layers : p.depth) + ": depth is " + std::to_string(frame.depth.width()) +
                      "x" + std::to_string(frame.depth.height()) + " but colour is " +
                      std::to_string(frame.color.width()) + "x" + std::to_string(frame.color.height()));
    validate_frame(frame, (p.color.empty() ? p.layers : p.color).c_str());
  }
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

// Steps 3–4 for one frame. `renderer` (kept across the frames of a sequence) is made on the
// first call; masked renders go through render_masked.
void render_frame(const RenderArgs& a, const FramePaths& p, const FrameInputs& in, RenderSettings& settings,
                  std::optional<Renderer>& renderer, const io::WriteOptions& out_opt, const io::WriteOptions& coc_opt,
                  const io::WriteOptions& debug_opt) {
  const Frame& frame = in.frame;
  settings.camera = a.camera.build(&frame.depth);

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
  out.add_image(p.output, result->image, out_opt);
  if (!p.output_coc.empty()) out.add_image(p.output_coc, result->coc, coc_opt);
  if (!p.debug_output.empty()) out.add_image(p.debug_output, result->debug, debug_opt);
  out.commit();
  std::cerr << "dofkit: wrote " << p.output << " (" << frame.width() << "x" << frame.height() << ", method " << a.method
            << ", " << describe(settings.camera) << ", render " << static_cast<long>(ms + 0.5) << " ms)\n";
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
  if (a.output.empty()) throw_usage("--output: required");
  if (!a.debug_view.empty() && a.debug_output.empty()) throw_usage("--debug-view: needs --debug-output FILE");
  if (a.debug_view.empty() && !a.debug_output.empty()) throw_usage("--debug-output: needs --debug-view NAME");
  if (a.mask.empty() != a.mask_depth.empty()) throw_usage("--mask and --mask-depth: give both or neither");
  if (!a.mask.empty() && !a.layers.empty()) throw_usage("--mask and --layers: cannot be combined");
  if (a.max_layers < 1 || a.max_layers > 64) throw_usage("--max-layers: must be 1..64");
  io::set_pixel_budget(a.max_pixels);
  check_threads(a.threads);
  a.camera.check();
  const io::DepthOptions depth_opt = a.depth_flags.build();
  RenderSettings settings;
  settings.method = a.method;
  settings.params = params;
  settings.threads = a.threads;
  settings.debug_view = a.debug_view;
  settings.backend = parse_backend(a.backend);

  // --compression: every EXR output of the run (at least one must be EXR).
  if (!a.compression.empty() && !io::is_exr_path(a.output) && !io::is_exr_path(a.output_coc) &&
      !io::is_exr_path(a.debug_output))
    throw_usage("--compression " + a.compression + ": applies to .exr outputs, and none is given");
  auto exr_compression = [&](const std::string& p) { return io::is_exr_path(p) ? a.compression : std::string(); };
  // --png-level: every PNG output of the run (at least one must be PNG).
  if (a.png_level != -1 && !io::is_png_path(a.output) && !io::is_png_path(a.debug_output))
    throw_usage("--png-level " + std::to_string(a.png_level) + ": applies to .png outputs, and none is given");
  auto png_level = [&](const std::string& p) { return io::is_png_path(p) ? a.png_level : -1; };
  io::WriteOptions out_opt;
  out_opt.bits = a.bits;
  out_opt.compression = exr_compression(a.output);
  out_opt.png_level = png_level(a.output);
  io::check_output_format(a.output, out_opt, "--output");
  io::WriteOptions coc_opt;
  coc_opt.channel_name = "Y";
  coc_opt.compression = exr_compression(a.output_coc);
  if (!a.output_coc.empty()) {
    io::check_output_format(a.output_coc, coc_opt, "--output-coc");
    if (!io::is_exr_path(a.output_coc))
      throw_usage("--output-coc " + a.output_coc + ": the CoC map is signed float; write it as .exr");
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
  const std::vector<int> frames = a.frames.empty() ? std::vector<int>{-1} : parse_frames(a.frames);
  const FramePaths given{a.color, a.depth, a.layers, a.mask, a.mask_depth, a.output, a.output_coc, a.debug_output};
  std::optional<FramePattern> pattern[std::size(kFrameFields)];
  if (!a.frames.empty()) {
    for (std::size_t k = 0; k < std::size(kFrameFields); ++k) {
      const FrameField& f = kFrameFields[k];
      const std::string& path = given.*f.path;
      if (path.empty()) continue;
      pattern[k] = find_frame_pattern(f.flag, path);
      if (f.output && !pattern[k])
        throw_usage(std::string(f.flag) + " " + path +
                    ": needs a frame pattern (#### or %04d) with --frames, so that every frame has its own file");
    }
    auto has_pattern = [&](std::string FramePaths::*path) {
      for (std::size_t k = 0; k < std::size(kFrameFields); ++k)
        if (kFrameFields[k].path == path) return pattern[k].has_value();
      return false;
    };
    if (!has_pattern(&FramePaths::color) && !has_pattern(&FramePaths::layers))
      throw_usage(std::string(a.layers.empty() ? "--color " + a.color : "--layers " + a.layers) +
                  ": needs a frame pattern (#### or %04d) with --frames");
  }
  auto paths_of = [&](int frame) {
    FramePaths p = given;
    for (std::size_t k = 0; k < std::size(kFrameFields); ++k)
      if (pattern[k]) p.*kFrameFields[k].path = expand_frame(given.*kFrameFields[k].path, *pattern[k], frame);
    return p;
  };
  std::vector<FramePaths> paths;
  paths.reserve(frames.size());
  for (const int f : frames) paths.push_back(paths_of(f));
  // Every frame's paths are checked before the first frame is read: no output may be an
  // input or another output of any frame (usage errors first), and with --frames every input
  // must exist (so a missing frame stops the run before anything is written).
  std::set<std::filesystem::path> inputs_seen, outputs_seen;
  auto canonical = [](const std::string& path) {
    std::error_code ec;
    return std::filesystem::weakly_canonical(std::filesystem::absolute(path), ec);
  };
  for (const FramePaths& p : paths) {
    check_paths(p.inputs(), p.outputs());
    if (a.frames.empty()) continue;
    for (const NamedPath& in : p.inputs())
      if (!in.path.empty()) inputs_seen.insert(canonical(in.path));
    for (const NamedPath& out : p.outputs())
      if (!out.path.empty() && !outputs_seen.insert(canonical(out.path)).second)
        throw_usage(out.flag + " " + out.path + ": is also an output of another frame of --frames " + a.frames);
  }
  for (const auto& out : outputs_seen)
    if (inputs_seen.count(out))
      throw_usage("--frames " + a.frames + ": output " + out.string() + " is the input of another frame");
  if (!a.frames.empty())
    for (std::size_t i = 0; i < frames.size(); ++i)
      for (const NamedPath& in : paths[i].inputs()) {
        std::error_code ec;
        if (!in.path.empty() && !std::filesystem::exists(in.path, ec))
          throw_bad_input(in.flag + " " + in.path + ": does not exist (frame " + std::to_string(frames[i]) +
                          " of --frames " + a.frames + ")");
      }

  // 2–4, frame by frame. In a sequence the next frame's inputs are read on another thread
  // while this frame renders and is written; a read error is reported when that frame's turn
  // comes, after the frames before it are written.
  std::optional<Renderer> renderer;
  const auto t0 = std::chrono::steady_clock::now();
  if (a.frames.empty()) {
    render_frame(a, paths[0], read_inputs(a, paths[0], depth_opt), settings, renderer, out_opt, coc_opt, debug_opt);
  } else {
    auto read_async = [&](std::size_t i) {
      return std::async(std::launch::async, [&a, &depth_opt, &p = paths[i]] { return read_inputs(a, p, depth_opt); });
    };
    std::future<FrameInputs> next = read_async(0);
    for (std::size_t i = 0; i < frames.size(); ++i) {
      const FrameInputs in = next.get();
      if (i + 1 < frames.size()) next = read_async(i + 1);
      render_frame(a, paths[i], in, settings, renderer, out_opt, coc_opt, debug_opt);
    }
  }
  if (!a.frames.empty())
    std::cerr << "dofkit: " << frames.size() << " frames in "
              << static_cast<long>(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() * 1000 +
                                   0.5)
              << " ms\n";
}

}  // namespace

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
  cmd->add_option("--max-pixels", args->max_pixels,
                  "refuse input files whose header declares more than this many pixels (width x height), "
                  "checked before any pixel memory is allocated (default 268435456 = 2^28)");
  cmd->add_option("--max-layers", args->max_layers, "--layers: keep at most this many fragments per pixel (default 8)")
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
  cmd->add_option("--method", args->method, "technique (default reference; see `dofkit methods`)")->group(meth);
  cmd->add_option("--set", args->sets, "KEY=VALUE method parameter, repeatable (see `dofkit methods`)")
      ->allow_extra_args(false)
      ->group(meth);
  cmd->add_option("--threads", args->threads,
                  "worker threads, 0 = all hardware threads (default); output is identical "
                  "for every count")
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
  cmd->add_option("--bits", args->bits,
                  "bits per channel of --output: EXR 32 (default) or 16 (half); PNG/TIFF 8 (default) or 16; TIFF 32 "
                  "(float)")
      ->group(outg);
  cmd->add_option("--compression", args->compression,
                  "compression of every .exr output: none, rle, zips, zip (default), piz, or the lossy pxr24, b44, "
                  "b44a, dwaa, dwab. none writes a 1080p float frame ~4x faster than zip and ~40 % larger")
      ->group(outg);
  cmd->add_option("--png-level", args->png_level,
                  "zlib level of every .png output, 0 (stored, fastest) to 9 (smallest); default 6. A 1080p call with "
                  "a PNG out takes ~0.34 s at level 1 against ~0.63 s at 6, for a ~16 % larger file")
      ->group(outg);
  cmd->add_option("--output-coc", args->output_coc,
                  "also write the signed CoC radius used, pixels (> 0 near, < 0 far), as a single-channel float EXR")
      ->group(outg);
  cmd->add_option("--debug-output", args->debug_output, "file for --debug-view (EXR keeps exact values)")->group(outg);
  cmd->add_option("--frames", args->frames,
                  "FIRST-LAST[xSTEP]: render a numbered sequence in one process (one Renderer, buffers reused); "
                  "the frame number replaces a #### run (zero-padded to its length) or %d / %04d in the paths. "
                  "--output (and --output-coc, --debug-output) and --color or --layers need one; a path without one "
                  "serves every frame. Every frame's inputs must exist before the first is rendered; an error stops "
                  "the run and keeps the frames written before it")
      ->group(in);
  cmd->callback([args] { run_render(*args); });
}

}  // namespace dofkit::cli
