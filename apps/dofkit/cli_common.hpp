// Command-line pieces shared by the subcommands that take a camera and inputs (render,
// quality, demo, …): camera-model flags → CameraModel, depth-kind flags → DepthOptions,
// `--set k=v` parsing, path checks and all-or-nothing output writing.
//
// Usage in a subcommand:
//   auto flags = std::make_shared<CameraFlags>();
//   flags->add(cmd);                       // registers --focus, --f-number, …
//   cmd->callback([flags] { CameraModel cam = flags->build(&depth); … });
// Every error is a dofkit::Error naming the flag (usage, exit 2) or the file (bad input, 3).
#pragma once
#include <CLI/CLI.hpp>

#include <map>
#include <new>
#include <stdexcept>
#include <optional>
#include <string>
#include <vector>

#include "dofkit/aperture.hpp"
#include "dofkit/coc.hpp"
#include "dofkit/image.hpp"
#include "dofkit/ranges.hpp"
#include "dofkit/render.hpp"
#include "io/atomic_write.hpp"
#include "io/image_io.hpp"

namespace dofkit::cli {

/// Parses "a,b,c" into exactly `count` numbers, each checked against the range table's row
/// (dofkit/ranges.hpp) `rows[i]` (one row for all when `rows` has one). Throws Error(usage):
/// "<flag>: expected <form> (<count> comma-separated numbers), got '<text>'", or the row's
/// range message naming the value.
std::vector<double> parse_numbers(const std::string& text, std::size_t count, const std::string& flag,
                                  const std::string& form, const std::vector<std::string>& rows);

/// Registers a numeric option whose value must lie in the range table's row `row` (default:
/// the flag itself; dofkit/ranges.hpp): the value is parsed strictly when the command line
/// is parsed (a bad one throws Error(usage) naming the flag and its range) and the help
/// shows the range. Works for double and int variables.
template <typename T>
CLI::Option* add_number(CLI::App* cmd, const std::string& flag, T& var, const std::string& help, std::string row = "");
/// The CLI11 check behind add_number (for options registered otherwise).
CLI::Validator range_check(const std::string& row);

/// --max-pixels and --max-memory (the budgets of docs/robustness.md): registered on a
/// command by add(), put in force by apply() when the command runs (before any file is read).
struct BudgetFlags {
  long long max_pixels = io::kMaxPixels;
  long long max_memory_mib = 0;  ///< 0 = the default (budget.hpp)
  void add(CLI::App* cmd, bool pixels = true);
  void apply() const;
};

/// Parses repeated `--set key=value` into a map. Throws Error(usage) for a missing '=', an
/// empty key or a key given twice.
std::map<std::string, std::string> parse_sets(const std::vector<std::string>& sets);

/// The camera / CoC-model flags. Exactly one model must be chosen:
///   --f-number N            physical thin lens (with --focus or --focus-at, --focal-length,
///                           --sensor-width)
///   --blur-at-infinity PX   thin lens given by its blur radius at infinity K (with --focus or
///                           --focus-at)
///   --planes NB,NS,FS,FB    four-plane artist model (with --near-radius, --far-radius)
///   --starcraft F,FULL,NONE,AMOUNT   StarCraft II levels (with --max-radius)
///   --near-far NB,NE,FB,FE  Sterna near/far blend (with --max-radius)
/// plus --max-coc PX (clamp), --reference-width PX, --focus-at X,Y (refocus any model on the
/// median depth around that pixel).
/// One key of --focus-keys (focus_m) or --focus-at-keys (x, y).
struct FocusKey {
  long frame = 0;
  double focus_m = 0;
  int x = 0, y = 0;
};

/// The value at `frame` from keys at increasing frames `key_frames` with values `key_focus_m`
/// (a focus distance, an f-number or a blur at infinity): the first key's before it, the last
/// key's after it, and between keys i and i+1 the smoothstep ease z_i + (z_{i+1} − z_i)·s,
/// s = t²(3 − 2t), t = (frame − f_i) / (f_{i+1} − f_i). A pure function of the frame number
/// (any chunking gives the same frames).
double eased_focus(const std::vector<double>& key_focus_m, const std::vector<long>& key_frames, long frame);

class CameraFlags {
 public:
  /// Registers the flags on `cmd` in the option group `group`.
  void add(CLI::App* cmd, const std::string& group = "Camera (choose exactly one CoC model)");
  /// True if any model flag was given (lets a command supply a default camera instead).
  bool model_given() const;
  /// Checks the flag combination and every model value without needing the depth map (so a
  /// command can fail before reading inputs). Throws Error(usage). `focus_from_input`: the
  /// input may record its focus distance (a phone photo without --depth), so a thin-lens model
  /// without a focus flag is not refused yet (build() refuses it if the input records none).
  void check(bool focus_from_input = false) const;
  /// Builds the camera. `depth` (planar z) is needed only for --focus-at; pass nullptr if
  /// there is none (then --focus-at is a usage error). Validates the model (dofkit::validate).
  /// `frame`: the frame number with --frames (-1 without); drives --focus-keys /
  /// --focus-at-keys, --f-number-keys and --blur-at-infinity-keys (a usage error without
  /// --frames). `recorded_focus_m`: the focus distance the input records (a phone photo's), the
  /// thin lens's focus when no focus flag is given.
  CameraModel build(const Image* depth, long frame = -1, std::optional<double> recorded_focus_m = std::nullopt) const;
  /// Whether anything is animated by keys (--focus-keys, --focus-at-keys, --f-number-keys,
  /// --blur-at-infinity-keys).
  bool animated() const;
  /// Whether a thin-lens model (--f-number, --blur-at-infinity or their keys) lacks a focus flag.
  bool focus_missing() const;
  /// After check(true): Error(usage) if the focus is missing and `input` (a phone photo)
  /// records none either.
  void require_focus(const std::optional<double>& recorded_focus_m, const std::string& input) const;
  /// The keys of --focus-keys / --focus-at-keys, checked: increasing frames, no frame twice,
  /// each value in its flag's range (Error(usage) naming the flag). Empty if neither is given.
  std::vector<FocusKey> focus_keys() const;
  /// The --focus-at pixel, if given.
  std::optional<std::pair<int, int>> focus_at() const;

 private:
  CameraModel assemble() const;  // the model from the flags, before --focus-at
  // The keys FRAME:VALUE of a scalar key flag: increasing frames, each value checked as
  // `value_flag` checks it (Error(usage) naming `flag`).
  std::vector<std::pair<long, double>> value_keys(const std::string& flag, const std::string& text,
                                                  const std::string& value_flag) const;
  CLI::Option *f_number_keys_ = nullptr, *blur_inf_keys_ = nullptr;
  std::string f_number_keys_text_, blur_inf_keys_text_;
  CLI::Option *focus_ = nullptr, *f_number_ = nullptr, *focal_length_ = nullptr, *sensor_width_ = nullptr,
              *blur_inf_ = nullptr, *planes_ = nullptr, *planes_ramp_ = nullptr, *near_radius_ = nullptr,
              *far_radius_ = nullptr, *starcraft_ = nullptr, *near_far_ = nullptr, *max_radius_ = nullptr,
              *max_coc_ = nullptr, *reference_width_ = nullptr, *focus_at_ = nullptr, *focus_keys_ = nullptr,
              *focus_at_keys_ = nullptr;
  std::string focus_keys_text_, focus_at_keys_text_;
  double focus_m_ = 0, f_number_v_ = 0, focal_length_mm_ = 50, sensor_width_mm_ = 36, blur_inf_px_ = 0;
  std::string planes_text_, planes_ramp_v_ = "z", starcraft_text_, near_far_text_, focus_at_text_;
  double near_radius_px_ = 0, far_radius_px_ = 0, max_radius_px_ = 0, max_coc_px_ = 0, reference_width_px_ = 0;
};

/// Depth-convention flags: --depth-kind, --fov-deg, --disparity-scale, --clip NEAR,FAR,
/// --depth-channel, --depth-scale / --depth-units, --invalid-depth error|far.
class DepthFlags {
 public:
  void add(CLI::App* cmd, const std::string& group = "Depth conventions");
  /// Throws Error(usage) naming the flag if a value is malformed or a kind lacks its flag.
  io::DepthOptions build() const;
  /// Whether --depth-kind was given.
  bool kind_given() const { return kind_opt_ && kind_opt_->count() > 0; }
  /// The --depth-channel name ("" if not given).
  const std::string& channel() const { return channel_; }

 private:
  CLI::Option* kind_opt_ = nullptr;
  CLI::Option *fov_ = nullptr, *scale_ = nullptr, *clip_ = nullptr, *depth_scale_ = nullptr, *depth_units_ = nullptr;
  std::string kind_ = "z", clip_text_, invalid_ = "error", channel_, units_ = "m", upsample_ = "guided",
              fit_ = "same-aspect";
  double fov_deg_ = 0, disparity_scale_ = 1, depth_scale_v_ = 1;
  bool refine_ = false;
};

/// The aperture flags of render, scene and quality: --blades, --blade-rotation,
/// --blade-curvature, --anamorphic, --cat-eye, --aperture-image (dofkit/aperture.hpp).
class ApertureFlags {
 public:
  /// `rotation_alias`: also accept --rotation (the spelling `dofkit scene` had before).
  void add(CLI::App* cmd, bool rotation_alias = false, const std::string& group = "Aperture (bokeh shape)");
  /// Checks every number (Error(usage) naming the flag) before any file is read.
  void check() const;
  /// The shape, with --aperture-image read: an unreadable file is Error(bad_input) naming the
  /// flag; an empty, all-black or too large one Error(usage).
  ApertureShape build() const;
  /// The flags as given, for logs and params.json ("" for the default circle).
  std::string text() const;
  /// The --aperture-image path ("" if none).
  const std::string& image_path() const { return image_; }

 private:
  ApertureShape shape_;  // the flags' numbers (the image is read by build())
  std::string image_;
};

/// The measured default --highlight-boost for display-referred (8/16-bit) colour files
/// (docs/methods/highlights.md: within 1 dB of the best boost on night_8 and `highlights`).
inline constexpr double kDefaultDisplayBoost = 64.0;

/// --highlight-threshold, --highlight-boost, --highlight-restore.
class HighlightFlags {
 public:
  void add(CLI::App* cmd, const std::string& group = "Highlight recovery");
  /// Checks the numbers (Error(usage) naming the flag).
  void check() const;
  /// The settings; `display_referred`: the colour came from an 8/16-bit file, so the default
  /// boost (kDefaultDisplayBoost) applies unless --highlight-boost was given.
  HighlightRecovery build(bool display_referred) const;
  /// The flags as given ("" if none).
  std::string text() const;

 private:
  CLI::Option* boost_opt_ = nullptr;
  HighlightRecovery h_;
};

/// The focus-zone picture of a signed CoC map (docs/coc.md has the legend), 3 planes of
/// display codes in [0, 1] (to be written without an sRGB curve): in focus (|r| < 0.5 px, or
/// NaN) neutral grey 0.5; the near field (r > 0) orange (1, 0.55, 0), the far field (r < 0)
/// blue (0, 0.45, 1), each times t = |r| / max |r| over the map (an infinite |r| counts as t = 1).
Image focus_zone_picture(const Image& coc);

/// One file a command reads or writes, with the flag that named it (for messages).
struct NamedPath {
  std::string flag;  ///< e.g. "--output"
  std::string path;
};

/// Refuses (Error(usage)) an output that is the same file as an input or as another
/// output (compared as canonical paths, so "./a.exr" and "a.exr" and symlinks match), and an
/// output whose folder does not exist (Error(bad_input)). Empty paths are ignored.
void check_paths(const std::vector<NamedPath>& inputs, const std::vector<NamedPath>& outputs);

/// Collects a command's outputs and writes them all-or-nothing: each image is encoded into
/// a temporary file next to its target as it is added; commit() renames them all into place.
/// If the command fails before commit() (or add() throws), no target is created or changed.
class OutputWriter {
 public:
  void add_image(const std::string& path, const Image& img, const io::WriteOptions& opt = {});
  /// Arbitrary content (e.g. a JSON report) through a writer callback on the temporary path.
  void add_file(const std::string& path, const std::function<void(const std::string& temp_path)>& write);
  void commit();

 private:
  io::OutputSet set_;
};

/// --threads on `cmd` (0 = all hardware threads, at most 1024).
CLI::Option* add_threads(CLI::App* cmd, int& threads, const std::string& help);

/// Runs `fn`; an allocation that fails inside it (std::bad_alloc, std::length_error) becomes
/// Error(bad_input) "out of memory while <what>" (exit 3), never an internal error.
template <typename F>
auto while_doing(const std::string& what, F&& fn) -> decltype(fn());
[[noreturn]] void out_of_memory(const std::string& what);

template <typename F>
auto while_doing(const std::string& what, F&& fn) -> decltype(fn()) {
  try {
    return fn();
  } catch (const std::bad_alloc&) {
    out_of_memory(what);
  } catch (const std::length_error&) {
    out_of_memory(what);
  }
}

template <typename T>
CLI::Option* add_number(CLI::App* cmd, const std::string& flag, T& var, const std::string& help, std::string row) {
  if (row.empty()) row = flag;
  return cmd->add_option(flag, var, help + " [" + range_text(numeric_range(row)) + "]")->transform(range_check(row));
}

/// Parses --backend cpu|vulkan. Throws Error(usage).
Backend parse_backend(const std::string& text);

/// A `--layers` frame as render and view read it: the multi-layer or deep EXR `layers` gives
/// the colour and depth unless `color` / `depth` (may be empty) override them; `color` without
/// `depth` uses its own depth channel when it has one. Checks sizes and validates the frame
/// (Error(bad_input) naming the file). `facts` (may be null) as io::read_depth.
Frame read_layered_frame(const std::string& color, const std::string& depth, const std::string& layers,
                         const io::DepthOptions& depth_opt, const std::vector<std::string>& color_channels,
                         int max_layers, io::DepthFacts* facts);

}  // namespace dofkit::cli
