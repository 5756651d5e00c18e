// `dofkit render`: one colour image + depth → depth of field, written to a file.
//
// Order of work, so that a mistake costs as little as possible and never a file:
//   1. check every flag and path (usage errors, exit 2) before reading anything;
//   2. read and validate the inputs (bad input, exit 3);
//   3. render completely in memory;
//   4. encode every output into a temporary file beside its target, then rename them all.
// An error at any step leaves every output path as it was.
#include <algorithm>
#include <chrono>
#include <filesystem>
#include <iostream>
#include <memory>

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
  std::string method = "reference";
  std::string debug_view;
  std::vector<std::string> sets;
  int threads = 0;
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

Exit codes: 0 success, 2 usage error, 3 bad input (missing, corrupt or inconsistent files),
1 internal error. On any error no output file is created or changed.
See docs/cli.md for the full reference.)";

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
      const bool known = std::any_of(m.params.begin(), m.params.end(), [&](const ParamInfo& p) { return p.name == key; });
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

  io::WriteOptions out_opt;
  out_opt.bits = a.bits;
  io::check_output_format(a.output, out_opt, "--output");
  io::WriteOptions coc_opt;
  coc_opt.channel_name = "Y";
  if (!a.output_coc.empty()) {
    io::check_output_format(a.output_coc, coc_opt, "--output-coc");
    if (std::filesystem::path(a.output_coc).extension() != ".exr")
      throw_usage("--output-coc " + a.output_coc + ": the CoC map is signed float; write it as .exr");
  }
  if (!a.debug_output.empty()) io::check_output_format(a.debug_output, {}, "--debug-output");
  check_paths({{"--color", a.color}, {"--depth", a.depth}, {"--layers", a.layers}, {"--mask", a.mask},
               {"--mask-depth", a.mask_depth}},
              {{"--output", a.output}, {"--output-coc", a.output_coc}, {"--debug-output", a.debug_output}});

  // 2. Inputs.
  Frame frame;
  if (a.layers.empty()) {
    frame = io::load_frame(a.color, a.depth, depth_opt);
  } else {
    if (!a.color.empty()) frame.color = io::read_color(a.color);
    if (!a.depth.empty()) frame.depth = io::read_depth(a.depth, depth_opt);
    io::read_layers(a.layers, frame, a.max_layers);
    if (frame.depth.empty() && !a.color.empty()) {
      // --color without --depth: its own Z channel if it has one, else the layers' depth.
      if (io::has_depth_channel(a.color)) frame.depth = io::read_depth(a.color, depth_opt);
    }
    if (!frame.depth.same_size(frame.color))
      throw_bad_input((a.depth.empty() ? a.layers : a.depth) + ": depth is " + std::to_string(frame.depth.width()) + "x" +
                      std::to_string(frame.depth.height()) + " but colour is " + std::to_string(frame.color.width()) +
                      "x" + std::to_string(frame.color.height()));
    validate_frame(frame, (a.color.empty() ? a.layers : a.color).c_str());
  }
  Image mask, mask_depth;
  if (!a.mask.empty()) {
    mask = io::read_mask(a.mask);
    // Outside the mask this depth is never used, so files may hold 0 or NaN there; inside,
    // an invalid value is taken as infinitely far.
    io::DepthOptions mopt = depth_opt;
    mopt.invalid_as_far = true;
    mask_depth = io::read_depth(a.mask_depth, mopt);
    if (!mask.same_size(frame.color) || !mask_depth.same_size(frame.color))
      throw_bad_input((mask.same_size(frame.color) ? a.mask_depth : a.mask) + ": is " +
                      std::to_string((mask.same_size(frame.color) ? mask_depth : mask).width()) + "x" +
                      std::to_string((mask.same_size(frame.color) ? mask_depth : mask).height()) + " but colour is " +
                      std::to_string(frame.color.width()) + "x" + std::to_string(frame.color.height()));
  }
  settings.camera = a.camera.build(&frame.depth);

  // 3. Render.
  const auto t0 = std::chrono::steady_clock::now();
  const RenderResult result =
      a.mask.empty() ? render(frame, settings) : render_masked(frame, mask, mask_depth, settings);
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();

  // 4. Outputs, all or nothing.
  OutputWriter out;
  out.add_image(a.output, result.image, out_opt);
  if (!a.output_coc.empty()) out.add_image(a.output_coc, result.coc, coc_opt);
  if (!a.debug_output.empty()) out.add_image(a.debug_output, result.debug);
  out.commit();
  std::cerr << "dofkit: wrote " << a.output << " (" << frame.width() << "x" << frame.height() << ", method " << a.method
            << ", " << describe(settings.camera) << ", render " << static_cast<long>(ms + 0.5) << " ms)\n";
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
  cmd->add_option("--layers", args->layers,
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
  cmd->add_option("--threads", args->threads, "worker threads, 0 = all hardware threads (default); output is identical "
                                              "for every count")
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
  cmd->add_option("--output-coc", args->output_coc,
                  "also write the signed CoC radius used, pixels (> 0 near, < 0 far), as a single-channel float EXR")
      ->group(outg);
  cmd->add_option("--debug-output", args->debug_output, "file for --debug-view (EXR keeps exact values)")->group(outg);
  cmd->callback([args] { run_render(*args); });
}

}  // namespace dofkit::cli
