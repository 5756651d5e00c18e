// The quality run shared by `dofkit quality` and `dofkit demo`: render each built-in scene
// (pinhole input + thin-lens ground truth) once, run each method on the pinhole frame, time
// and score it against the ground truth, and write a contact sheet per scene plus a
// Markdown and a JSON table.
#pragma once
#include <map>
#include <string>
#include <vector>

#include "dofkit/render.hpp"
#include "metrics/report.hpp"

namespace dofkit::cli {

/// One row of the method list: "input" (the unblurred pinhole colour) or a method with
/// optional parameters, written `name` or `name:key=value,key=value`.
struct MethodSpec {
  std::string label;                          ///< as the user wrote it (row name)
  std::string name;                           ///< method name, or "input"
  std::map<std::string, std::string> params;  ///< from the spec (override --set)
  /// Fragments per pixel (front to back, the first is the visible surface) this row's input
  /// frame carries: the spec key `input_layers=N`, taken out of `params`;
  /// -1 = QualityOptions::layers; 0 = plain single-layer RGB-D.
  int input_layers = -1;
};

/// Splits a --methods list on commas, keeping "key=value" pieces with the method before
/// them: "mcguire:variant=book,quality=2,reference" → two specs. Throws Error(usage) for an
/// empty or malformed entry or an unknown method (naming the available ones).
std::vector<MethodSpec> parse_method_list(const std::string& list);
/// "input" followed by every available method, sorted by name.
std::vector<MethodSpec> default_method_list();

struct QualityOptions {
  std::vector<std::string> scenes;  ///< empty = all built-in scenes
  std::vector<MethodSpec> methods;  ///< empty = default_method_list()
  int width = 320;                  ///< scene size, pixels
  int height = 180;
  int samples = 0;  ///< ground-truth lens samples per pixel (0 = scene default)
  /// Fragments per pixel (front to back) in the input frames' layer_* (0 = single-layer
  /// RGB-D). Methods that do not use layers ignore them; the layered method uses them.
  int layers = 0;
  std::string out_dir;             ///< where sheets and tables go (created if missing)
  int threads = 0;                 ///< worker threads (0 = all)
  Backend backend = Backend::cpu;  ///< where the methods run (--backend)
  /// --set method.key=value: parameters for every row of that method.
  std::map<std::string, std::map<std::string, std::string>> set;
  std::string command_line;  ///< recorded in the Markdown and JSON (how to regenerate)
};

struct QualityResult {
  std::vector<metrics::QualityRow> rows;  ///< scene × method rows, then the per-method means
  std::vector<std::string> files;         ///< everything written, in order
};

/// Parses "WxH" (1..16384 each); throws Error(usage) naming `option`.
void parse_size(const std::string& text, const char* option, int& width, int& height);
/// Parses "method.key=value" into `set`; throws Error(usage) if malformed.
void parse_set(const std::string& text, std::map<std::string, std::map<std::string, std::string>>& set);

/// Runs the whole thing, printing progress on stderr (an animated line on a terminal, one
/// line per step otherwise). Throws dofkit::Error on bad options or failed writes.
QualityResult run_quality(const QualityOptions& opt);

}  // namespace dofkit::cli
