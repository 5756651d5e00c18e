// dofkit — screen-space ambient occlusion (AO) from a depth map and optional normals.
//
// Two methods of one effect (docs/methods/ssao.md):
//  * "sc2": StarCraft II's SSAO (Filion & McNaughton 2008, §5.5): view-space offset vectors
//    reflected through a per-pixel random vector, flipped into the normal's hemisphere,
//    compared with a quarter-resolution depth through an artist occlusion function, in two
//    sample sets (small + steep, wide + gentle, the darker kept), then a depth- and
//    normal-aware Gaussian blur;
//  * "gtao": ground-truth-based AO after Jimenez et al. 2016 (horizon search per screen
//    slice, cosine-weighted visibility integrated per slice), with the same blur.
//
// Camera convention (docs/gbuffer.md): a pinhole whose pixel (x, y) (y down) looks along
// ((x + 0.5 − W/2)/F, (y + 0.5 − H/2)/F, 1) with F = (W/2)/tan(hfov/2); depth is planar z
// along the optical axis in metres (+inf = sky); normals are unit vectors in camera space,
// X right, Y up, Z towards the camera.
#pragma once
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "dofkit/error.hpp"
#include "dofkit/image.hpp"
#include "dofkit/render.hpp"

namespace dofkit {

/// Everything an AO render needs besides the buffers.
struct AoSettings {
  /// "sc2" (default) or "gtao" — see ao_methods().
  std::string method = "sc2";
  /// Horizontal field of view of the depth map, degrees, in (0, 180). Required.
  double hfov_deg = 0;
  /// AO radius in metres (> 0, finite): how far an occluder can be and still occlude. sc2's
  /// wide sample set reaches it (the chapter's artist-controlled sampling area); gtao's
  /// horizon search ignores samples farther than it.
  double radius_m = 0.5;
  /// Method parameters as key → value text (the CLI's `--set k=v`); sc2 also takes the key
  /// "preset" = "chapter" (default) or "tuned". Unknown keys and out-of-range values throw
  /// Error(usage) naming the key.
  std::map<std::string, std::string> params;
  /// Worker threads; 0 = all hardware threads. The output is identical for every count.
  int threads = 0;
  /// Name of an intermediate buffer to return in AoResult::debug ("" = none); see
  /// MethodInfo::debug_views of ao_methods().
  std::string debug_view;
};

struct AoResult {
  Image ao;                            ///< 1 plane, same size as the depth: 1 = open, 0 = fully occluded; 1 on the sky
  Image debug;                         ///< the requested debug view (empty if none)
  bool normals_reconstructed = false;  ///< no normals were given: they were derived from the depth
};

/// Computes ambient occlusion. `depth`: 1 plane, z > 0 or +inf. `normals`: null, or 3 planes
/// of the depth's size (X, Y, Z as above; normalised here; read only where z is finite).
/// Throws Error(bad_input) for an invalid depth or normal value and mismatched sizes,
/// Error(usage) for bad settings. (One-shot; AoRenderer keeps its buffers between frames.)
AoResult ambient_occlusion(const Image& depth, const Image* normals, const AoSettings& settings);

/// Renders AO for a sequence of frames with the same settings, keeping every intermediate
/// buffer between frames of the same size. Not thread-safe: one AoRenderer per caller thread.
class AoRenderer {
 public:
  explicit AoRenderer(AoSettings settings);  ///< validates the settings (throws Error(usage))
  ~AoRenderer();
  AoRenderer(AoRenderer&&) noexcept;
  AoRenderer& operator=(AoRenderer&&) noexcept;
  /// Renders one frame; the reference stays valid until the next call.
  const AoResult& render(const Image& depth, const Image* normals);
  const AoSettings& settings() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// The AO methods with their parameters (units, defaults, ranges) and debug views.
std::vector<MethodInfo> ao_methods();

}  // namespace dofkit
