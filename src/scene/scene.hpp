// Built-in procedural scenes and the thin-lens ray tracer that renders their ground truth.
#pragma once
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "dofkit/aperture.hpp"
#include "dofkit/coc.hpp"
#include "dofkit/frame.hpp"
#include "dofkit/image.hpp"

namespace dofkit::scene {

struct SceneOptions {
  int width = 640;
  int height = 360;
  /// Lens samples per pixel for the ground truth (0 = the scene's default, enough for
  /// >= 45 dB between two seeds at the default size).
  int samples = 0;
  /// Focus distance, metres (0 = the scene's default).
  double focus_m = 0;
  /// Blur radius at infinity K, px at this width (0 = the scene's default).
  double blur_at_infinity_px = 0;
  /// Hidden fragments to record per pixel (front to back) in Frame::layer_* (0 = none).
  int layers = 0;
  /// The lens aperture (dofkit/aperture.hpp; the same model the methods draw): blades,
  /// rotation, curvature, anamorphic squeeze, cat's eye, or an aperture image.
  ApertureShape aperture;
  std::uint64_t seed = 1;
  /// Worker threads (0 = all hardware threads). The output does not depend on it.
  int threads = 0;
  /// Optional progress callback for the ground truth: fraction done in [0, 1]. Called from
  /// worker threads (must be thread-safe).
  std::function<void(double)> progress;
};

/// The camera and sampling a scene render resolves to for given options (defaults filled in).
struct SceneDefaults {
  double focus_m = 0;              ///< z_F, metres
  double blur_at_infinity_px = 0;  ///< K, px at opt.width
  int samples = 0;                 ///< lens samples per pixel
  double hfov_deg = 0;             ///< horizontal field of view, degrees
};

/// A rendered scene: the pinhole RGB-D input (+ layers) and the thin-lens ground truth.
struct SceneRender {
  Frame pinhole;       ///< colour RGBA (alpha 1), depth z, optional layers
  Image ground_truth;  ///< RGBA, thin-lens image of the same camera
  CameraModel camera;  ///< BlurAtInfinity{focus, K} at this width: pass to render()
  std::string name;
};

/// Names of the built-in scenes: occluder, fence, ground, highlights, portrait, sky, ….
std::vector<std::string> scene_names();
/// One-line description of a scene.
std::string scene_description(const std::string& name);

/// Resolves the scene's defaults for `opt` (throws Error(usage) for an unknown name or a bad
/// option).
SceneDefaults scene_defaults(const std::string& name, const SceneOptions& opt);

/// Renders the pinhole frame only (fast).
SceneRender render_pinhole(const std::string& name, const SceneOptions& opt);
/// Renders the pinhole frame and the ground truth. Throws Error(usage) for an unknown name.
SceneRender render_scene(const std::string& name, const SceneOptions& opt);

}  // namespace dofkit::scene
