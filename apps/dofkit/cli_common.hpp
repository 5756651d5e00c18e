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
#include <optional>
#include <string>
#include <vector>

#include "dofkit/coc.hpp"
#include "dofkit/image.hpp"
#include "dofkit/render.hpp"
#include "io/atomic_write.hpp"
#include "io/image_io.hpp"

namespace dofkit::cli {

/// Parses "a,b,c" into exactly `count` numbers (each may be `inf`). Throws Error(usage):
/// "<flag>: expected <form> (<count> comma-separated numbers), got '<text>'".
std::vector<double> parse_numbers(const std::string& text, std::size_t count, const std::string& flag,
                                  const std::string& form);

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
class CameraFlags {
 public:
  /// Registers the flags on `cmd` in the option group `group`.
  void add(CLI::App* cmd, const std::string& group = "Camera (choose exactly one CoC model)");
  /// True if any model flag was given (lets a command supply a default camera instead).
  bool model_given() const;
  /// Checks the flag combination and every model value without needing the depth map (so a
  /// command can fail before reading inputs). Throws Error(usage).
  void check() const;
  /// Builds the camera. `depth` (planar z) is needed only for --focus-at; pass nullptr if
  /// there is none (then --focus-at is a usage error). Validates the model (dofkit::validate).
  CameraModel build(const Image* depth) const;
  /// The --focus-at pixel, if given.
  std::optional<std::pair<int, int>> focus_at() const;

 private:
  CameraModel assemble() const;  // the model from the flags, before --focus-at
  CLI::Option *focus_ = nullptr, *f_number_ = nullptr, *focal_length_ = nullptr, *sensor_width_ = nullptr,
              *blur_inf_ = nullptr, *planes_ = nullptr, *planes_ramp_ = nullptr, *near_radius_ = nullptr,
              *far_radius_ = nullptr, *starcraft_ = nullptr, *near_far_ = nullptr, *max_radius_ = nullptr,
              *max_coc_ = nullptr, *reference_width_ = nullptr, *focus_at_ = nullptr;
  double focus_m_ = 0, f_number_v_ = 0, focal_length_mm_ = 50, sensor_width_mm_ = 36, blur_inf_px_ = 0;
  std::string planes_text_, planes_ramp_v_ = "z", starcraft_text_, near_far_text_, focus_at_text_;
  double near_radius_px_ = 0, far_radius_px_ = 0, max_radius_px_ = 0, max_coc_px_ = 0, reference_width_px_ = 0;
};

/// Depth-convention flags: --depth-kind, --fov-deg, --disparity-scale, --clip NEAR,FAR,
/// --invalid-depth error|far.
class DepthFlags {
 public:
  void add(CLI::App* cmd, const std::string& group = "Depth conventions");
  /// Throws Error(usage) naming the flag if a value is malformed or a kind lacks its flag.
  io::DepthOptions build() const;

 private:
  CLI::Option *fov_ = nullptr, *scale_ = nullptr, *clip_ = nullptr;
  std::string kind_ = "z", clip_text_, invalid_ = "error";
  double fov_deg_ = 0, disparity_scale_ = 1;
};

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

/// Parses --threads (>= 0; 0 = all hardware threads). Throws Error(usage).
int check_threads(int threads);

/// Parses --backend cpu|vulkan. Throws Error(usage).
Backend parse_backend(const std::string& text);

}  // namespace dofkit::cli
