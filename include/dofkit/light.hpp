// dofkit — deferred lighting from a G-buffer (StarCraft II §5.4, §5.8 translucent shadows; docs/lighting.md).
//
// Local point and spot lights with a finite radius of influence are applied from the deferred
// buffers (depth, normals, diffuse albedo, specular colour + gloss, emissive): each light
// touches only the 16×16 screen tiles whose frustum (between the tile's nearest and farthest
// depth) its sphere or cone can reach, and within those only the pixels whose reconstructed
// position lies inside its volume — the CPU form of the chapter's light shapes with the
// stencil test, for the camera outside and inside the shape alike. Directional and ambient
// lights have no extent and are applied to every pixel ("forward" in the chapter).
//
// Camera convention (docs/gbuffer.md): pixel (x, y) (y down) sees along
// ((x + 0.5 − W/2)/F, −(y + 0.5 − H/2)/F, −1) in camera space (X right, Y up, Z towards the
// camera), F = (W/2)/tan(hfov/2); depth is planar (a point at depth z is that ray times z).
//
// Shading (per light, linear RGB): radiance = (albedo/π + specular·(n+8)/(8π)·(N·H)ⁿ) ·
// colour · intensity · (N·L)⁺ · attenuation · spot, with n = 2^(1 + 12·gloss), attenuation =
// saturate(1 − (d/r)⁴)² / max(d², 1e-4 m²) (exactly 0 from d = r on) and spot = t² with
// t = saturate((cos θ − cos outer)/(cos inner − cos outer)). The lit image is emissive + Σ
// lights, summed in the lights' order in double precision.
#pragma once
#include <array>
#include <memory>
#include <string>
#include <vector>

#include "dofkit/image.hpp"

namespace dofkit {

/// The most lights one lighting pass accepts (a lights file with more is refused).
inline constexpr int kMaxLights = 1024;
/// The most lights whose contributions can be returned as separate layers.
inline constexpr int kMaxLightLayers = 64;
/// The floor of d² in the attenuation, m² (keeps a surface at the light's centre finite).
inline constexpr double kMinLightDistance2 = 1e-4;

/// The largest side of a shadow map, texels.
inline constexpr int kMaxShadowMapSide = 8192;

/// A light's translucent shadow maps (StarCraft II §5.8), all of one size, rendered from the
/// light's view. A camera-space point p is looked up by q = view · p (light space: the light
/// looks along −Z), c = projection · q, texel (⌊(c.x/c.w + 1)/2 · W⌋, ⌊(1 − c.y/c.w)/2 · H⌋)
/// (row 0 at the top); its depth from the light is d = −q.z (metres; the maps store the same
/// measure, not the projection's z). Nearest texel, no filtering. With the bias b:
///   opaque test passes      iff d <= opaque_depth + b;
///   translucent test passes iff d <= translucent_depth + b (no translucent map: passes);
///   factor = 1; if the translucent test fails, factor ·= translucent_color; if the opaque
///   test fails, factor = 0.
/// A point behind the light (c.w <= 0) or outside the map's square is not shadowed.
struct ShadowMaps {
  Image opaque_depth;       ///< 1 plane: depth of the nearest opaque caster, metres (+inf: none)
  Image translucent_depth;  ///< 1 plane or empty: depth of the nearest translucent caster (+inf: none)
  Image translucent_color;  ///< 3 planes or empty: white filtered by the translucent casters in
                            ///< front of the opaque depth (the product of their colours)
  std::array<double, 16> view{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};  ///< camera → light space, row-major
  std::array<double, 16> projection{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};  ///< light space → clip
  double bias_m = 0.02;  ///< depth bias of both tests, metres (>= 0)
};

/// Throws Error(bad_input) with `where` + the field for maps of mismatched size or channel
/// count, a side above kMaxShadowMapSide, NaN or negative depths, colours outside [0, 1] or
/// non-finite matrices / bias.
void validate_shadow_maps(const ShadowMaps& m, const std::string& where);

/// The §5.8 lookup above: the light's RGB transmittance at camera-space point p, in [0, 1].
std::array<double, 3> shadow_factor(const ShadowMaps& m, const std::array<double, 3>& p);

struct Light {
  enum class Kind { point, spot, directional, ambient };
  Kind kind = Kind::point;
  std::string name;
  /// point / spot: position in camera space (X right, Y up, Z towards the camera), metres.
  std::array<double, 3> position_m{0, 0, 0};
  /// spot: unit axis the cone opens along; directional: unit direction the light travels;
  /// camera space. Normalised by validate_light.
  std::array<double, 3> direction{0, 0, -1};
  /// Linear RGB colour, each >= 0.
  std::array<double, 3> color{1, 1, 1};
  /// point / spot: intensity (radiance = BRDF · colour · intensity · (N·L)⁺ / d² inside the
  /// window); directional: irradiance on a surface facing the light; ambient: the radiance of
  /// a uniform surrounding (a Lambert surface reflects albedo · colour · intensity). >= 0.
  double intensity = 1;
  /// point / spot: radius of influence, metres (> 0): the light is exactly 0 from here on.
  double radius_m = 1;
  /// spot: half angles of the full-intensity cone and of the cone where the light ends,
  /// degrees, 0 <= inner < outer <= 90.
  double inner_deg = 20, outer_deg = 30;
  /// Whether an ambient-occlusion term (LightSettings::ao) modulates this light (default:
  /// ambient lights only; docs/methods/lighting.md).
  bool ao = false;
  /// Whether the light casts shadows (the tracer's ground truth traces shadow rays for it; the
  /// built-in scenes render its maps).
  bool casts_shadows = false;
  /// The maps the deferred pass looks up (null: unshadowed). Any kind but ambient.
  std::shared_ptr<const ShadowMaps> shadow;
};

/// Throws Error(bad_input) with `where` + the field name for any value out of range (NaN or
/// infinite numbers, radius <= 0, colour or intensity < 0, cone angles out of order, a zero
/// direction); normalises the direction.
void validate_light(Light& light, const std::string& where);

/// The deferred buffers (docs/gbuffer.md), all of the depth's size. Only `depth`, `normals`
/// and `albedo` are required; a null specular, gloss or emissive counts as 0.
struct GBufferRef {
  const Image* depth = nullptr;     ///< 1 plane: planar depth, metres (> 0; +inf = background)
  const Image* normals = nullptr;   ///< 3 planes: camera-space normals (normalised here)
  const Image* albedo = nullptr;    ///< 3 planes: diffuse albedo
  const Image* specular = nullptr;  ///< 3 planes: specular colour
  const Image* gloss = nullptr;     ///< 1 plane: gloss in [0, 1] (clamped)
  const Image* emissive = nullptr;  ///< 3 planes: emitted radiance (also on the background)
};

struct LightSettings {
  double hfov_deg = 0;  ///< horizontal field of view, degrees, in (0, 180). Required.
  int threads = 0;      ///< worker threads (0 = all); the output is identical for every count
  /// "tiled" (default): tile + per-pixel volume culling; "brute": every light at every pixel
  /// (the oracle the tiled path is held to, bit for bit).
  std::string impl = "tiled";
  bool layers = false;        ///< also return each light's contribution (at most kMaxLightLayers lights)
  bool emissive = true;       ///< add the emissive buffer
  const Image* ao = nullptr;  ///< optional AO term (1 plane), multiplies the lights whose `ao` is set
};

struct LightStats {
  long long tiles = 0;                   ///< screen tiles (16×16)
  std::vector<long long> tiles_touched;  ///< per light: tiles whose list it entered
  std::vector<long long> pixels_shaded;  ///< per light: pixels it was evaluated at
};

struct LightResult {
  Image lit;                  ///< 3 planes: emissive + Σ lights, linear RGB
  std::vector<Image> layers;  ///< per light (when requested): its contribution, 3 planes
  LightStats stats;
};

/// Deferred lighting. Throws Error(bad_input) for mismatched sizes or an invalid depth
/// (NaN, <= 0), Error(usage) for bad settings or too many lights.
LightResult deferred_lighting(const GBufferRef& g, const std::vector<Light>& lights, const LightSettings& s);

/// The forward evaluation of the same buffers and lights: the shading formulas above written
/// out plainly in long double for every pixel and light, with no culling and no precomputed
/// constants. The oracle the deferred output is held to (within 1e-5 relative).
Image forward_lighting(const GBufferRef& g, const std::vector<Light>& lights, double hfov_deg,
                       const Image* ao = nullptr, bool emissive = true);

/// One light's radiance (linear RGB) towards the viewer at a surface point `p` (camera space,
/// metres) with unit normal `n`, unit direction to the viewer `v`, and the material; long
/// double, as forward_lighting. The ray tracer's ground truth (scene `lights`) calls it at
/// exact hits.
std::array<double, 3> shade_light(const Light& l, const std::array<double, 3>& p, const std::array<double, 3>& n,
                                  const std::array<double, 3>& v, const std::array<double, 3>& albedo,
                                  const std::array<double, 3>& specular, double gloss);

}  // namespace dofkit
