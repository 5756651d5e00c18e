// Pieces of the AO commands shared by `dofkit ssao`, `dofkit quality --effect ao` and
// `dofkit bench --effect ao`: camera.json, the AO method list syntax, the parameter help and
// the AO quality run (own AO scenes against the tracer's AO, and an external folder such as a
// Blender render with pinhole_depth.exr, normal.exr, ao.exr and params.json).
#pragma once
#include <array>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "dofkit/image.hpp"

namespace dofkit::cli {

/// What a camera.json (docs/gbuffer.md) holds for the screen-space effects.
struct CameraFile {
  double hfov_deg = 0;
  /// world → camera space, row-major 4×4 (key view_matrix; only when the file has one).
  bool has_view = false;
  std::array<double, 16> view{};
};
/// Reads a camera.json: hfov_deg, and view_matrix when present; if the file gives a width and
/// height they must match the depth's. Throws Error(bad_input) naming the file and the key.
CameraFile read_camera_file(const std::string& path, int width, int height);
/// read_camera_file's hfov_deg.
double read_camera_fov(const std::string& path, int width, int height);
/// Checks a view matrix (16 finite numbers, a rotation + translation, last row 0 0 0 1);
/// throws Error(bad_input) "<where>: …" otherwise.
std::array<double, 16> parse_view_matrix(const nlohmann::json& j, const std::string& where);

/// The AO methods' parameters and debug views as help text.
std::string ssao_params_help();

/// One row of an AO method list: "sc2", "sc2:preset=tuned", "gtao:slices=4,steps=8".
struct AoSpec {
  std::string label;
  std::string name;
  std::map<std::string, std::string> params;
};
/// Parses a comma-separated list (a key=value piece continues the method before it); throws
/// Error(usage) for an unknown method or a bad parameter.
std::vector<AoSpec> parse_ao_method_list(const std::string& list);

struct AoQualityOptions {
  std::vector<std::string> scenes;  ///< built-in AO scenes (empty = all)
  std::vector<double> radii;        ///< AO radii, metres (empty = each scene's own)
  std::vector<AoSpec> methods;      ///< empty = sc2, sc2:preset=tuned, gtao
  int width = 640, height = 360;
  int rays = 4096;                    ///< ground-truth rays per pixel
  std::vector<std::string> external;  ///< folders with pinhole_depth.exr, normal.exr, ao.exr, params.json
  std::string out_dir;
  std::string cache_dir;  ///< where reference AO images are kept between runs ("" = none)
  int threads = 0;
  bool fit = false;         ///< fit sc2's artist parameters on the built-in scenes (prints the preset)
  bool no_normals = false;  ///< give the methods no normals (they reconstruct them from the depth)
  std::string command_line;
};

/// Runs the AO quality report: tables (Markdown + JSON) and contact sheets in out_dir.
void run_ao_quality(const AoQualityOptions& opt);

}  // namespace dofkit::cli
