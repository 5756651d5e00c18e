// A small ray tracer for the built-in scenes: analytic primitives with emissive (unlit)
// procedural textures, a pinhole pass (the RGB-D input a technique gets, plus hidden layers)
// and a thin-lens pass (the ground truth) with the camera model that `dofkit render` uses.
//
// Coordinates: camera at the origin, x right, y DOWN, z forward (the image convention lifted
// to 3-D, so no axis flips anywhere). Distances in metres. Every ray is written
// o + t·d with d.z = 1, so the ray parameter t of a hit IS its planar depth z.
//
// Camera geometry (derivation). Pinhole focal length in pixels F = (W/2) / tan(hfov/2); pixel
// (px, py) looks along d = ((px − W/2)/F, (py − H/2)/F, 1). The thin lens of radius a (metres)
// sits in the plane z = 0 and is focused on the plane z = z_F: every ray through pixel p passes
// through the focus-plane point P = z_F·d(p). A scene point Q at depth z seen through lens
// point L lands where the line L→Q crosses the focus plane, X = Q·z_F/z + L·(1 − z_F/z), i.e.
// at pixel p = (F/z_F)·X = F·Q/z + F·L·(1/z_F − 1/z) (lateral components). As L sweeps the lens,
// Q images to the aperture shape scaled by F·a·|1/z_F − 1/z| = (F a / z_F)·|1 − z_F/z| pixels.
// Matching r(z) = K·(z_F/z − 1) (coc.hpp; K = blur radius at infinity) gives
//     a = K · z_F / F        (metres),
// so r(∞) = −K exactly. Because F ∝ W and K is given at the rendered width, a is independent
// of the resolution: the same camera renders the same picture at any size.
// The far-field (z > z_F) image of a point is the aperture itself (L·(1 − z_F/z) has the sign
// of L); the near-field image is the aperture point-reflected (rotated by 180°).
#pragma once
#include <array>
#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "dofkit/aperture.hpp"
#include "dofkit/frame.hpp"
#include "dofkit/image.hpp"
#include "dofkit/light.hpp"
#include "scene/scene.hpp"

namespace dofkit::scene {

struct Vec3 {
  double x = 0, y = 0, z = 0;
};
inline Vec3 operator+(Vec3 a, Vec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline Vec3 operator-(Vec3 a, Vec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline Vec3 operator*(Vec3 a, double s) { return {a.x * s, a.y * s, a.z * s}; }
inline double dot(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }

/// Linear-light RGB radiance (emissive, so the value is what the camera records).
struct Rgb {
  float r = 0, g = 0, b = 0;
};

/// Procedural emissive texture on a surface's (u, v) coordinates (metres along the surface).
/// radiance = emission · lerp(a, b, fbm) · checker · lines, where
///  * fbm: value noise, `octaves` octaves from period `noise_scale_m` down by halves, each
///    octave's amplitude `gain` times the previous one (gain near 0.7 keeps fine octaves
///    visible: detail at every scale, down to the finest octave);
///  * checker: squares of side `checker_m` alternate brightness 1 ± checker_contrast;
///  * lines: a grid of lines every `line_spacing_m`, `line_width_m` wide, whose radiance is
///    multiplied by (1 − line_darkness).
struct Texture {
  Rgb a{0.5f, 0.5f, 0.5f};        ///< colour at noise 0
  Rgb b{0.2f, 0.2f, 0.2f};        ///< colour at noise 1
  double noise_scale_m = 0.5;     ///< period of the coarsest noise octave, metres
  int octaves = 7;                ///< noise octaves (0 = flat colour a)
  double gain = 0.7;              ///< amplitude ratio between successive octaves
  double checker_m = 0;           ///< checker square side, metres (0 = none)
  double checker_contrast = 0.2;  ///< relative brightness swing of the checker
  double line_spacing_m = 0;      ///< line grid spacing, metres (0 = none)
  double line_width_m = 0.01;     ///< line width, metres
  double line_darkness = 0.6;     ///< 0 = invisible lines, 1 = black lines
  double emission = 1;            ///< radiance multiplier (> 1 for HDR emitters)
  std::uint32_t seed = 1;         ///< noise seed (part of the scene, not of the render)
};

/// Evaluates a texture at surface coordinates (metres).
Rgb shade(const Texture& tex, double u, double v);

/// An opaque analytic primitive. Closed solids (box, oriented box, sphere, cylinder) are hit at
/// their entry point only; planes are two-sided and infinite.
struct Primitive {
  enum class Kind { plane, box, sphere, cylinder, oriented_box };
  Kind kind = Kind::sphere;
  /// plane: a point on it; box: min corner; sphere: centre; cylinder: one end of the axis;
  /// oriented box: centre.
  Vec3 p0;
  /// plane: unit normal; box: max corner; cylinder: the other end of the axis; oriented box:
  /// half extents along axis_u, axis_v, axis_u × axis_v (metres).
  Vec3 p1;
  /// plane: unit u axis of the texture coordinates (v = normal × u); oriented box: its first
  /// unit axis.
  Vec3 axis_u;
  /// oriented box: its second unit axis (orthogonal to axis_u). Unused by the other kinds.
  Vec3 axis_v;
  double radius = 0;  ///< sphere / cylinder radius, metres
  Texture tex;
  std::string name;  ///< for debugging and tests
  /// G-buffer material (render_gbuffer): specular colour and gloss in [0, 1]. The scenes'
  /// radiance does not depend on them (every surface is emissive).
  Rgb specular{0.04f, 0.04f, 0.04f};
  float gloss = 0.3f;
  /// Shadows (Scene::lights that cast them): a translucent caster filters the light that
  /// crosses it by `filter` (once per entry), any other primitive blocks it. The camera sees
  /// every primitive as an opaque surface either way.
  bool translucent = false;
  Rgb filter{1, 1, 1};
  /// Coverage the camera sees the primitive with. 1: an ordinary surface. < 1: a key
  /// transparency (StarCraft II §5.7): left out of the opaque buffers (render_gbuffer,
  /// render_lit, render_ao and the other pinhole-hit passes), drawn over what lies behind it
  /// with this coverage in the lit thin-lens render (Scene::lit), written by
  /// render_transparency; it casts no shadow.
  float camera_alpha = 1;

  static Primitive plane(Vec3 point, Vec3 normal, Vec3 u_axis, Texture t, std::string name = "plane");
  static Primitive box(Vec3 lo, Vec3 hi, Texture t, std::string name = "box");
  static Primitive sphere(Vec3 centre, double r, Texture t, std::string name = "sphere");
  /// Closed cylinder (with end caps) around the segment a → b.
  static Primitive cylinder(Vec3 a, Vec3 b, double r, Texture t, std::string name = "cylinder");
  /// Box with half extents `half` along the orthonormal axes u, v and u × v around `centre`
  /// (v is made orthogonal to u). Texture coordinates as for `box`, in the box's own frame.
  static Primitive oriented_box(Vec3 centre, Vec3 half, Vec3 u, Vec3 v, Texture t, std::string name = "box");
};

/// The background at infinite distance (depth +inf): a vertical gradient plus a texture laid
/// on the direction's tangent coordinates (d.x/d.z, d.y/d.z) (radians near the axis), so it
/// depends on the ray direction only, like a real sky.
struct Background {
  Rgb top{0.25f, 0.45f, 0.85f};     ///< colour at tan(elevation) = +0.4 (up)
  Rgb horizon{0.75f, 0.8f, 0.85f};  ///< colour at tan(elevation) = 0 and below
  Texture clouds;                   ///< multiplies the gradient; its u, v are tangent coords
};

/// A scene: primitives, background and the camera defaults the scene was composed for.
struct Scene {
  std::string name;
  std::string description;
  std::vector<Primitive> prims;
  Background background;
  double hfov_deg = 60;     ///< horizontal field of view, degrees
  double focus_m = 5;       ///< default focus distance, metres
  double k_px_at_640 = 12;  ///< default blur radius at infinity, px at width 640
  int samples = 128;        ///< default lens samples per pixel (ground truth)
  /// Ambient-occlusion radius the scene was composed for, metres (0: not an AO scene).
  double ao_radius_m = 0;
  /// How far the camera looks down, degrees (pitch_scene; informational: the primitives are
  /// already in the camera frame).
  double pitch_deg = 0;
  /// Lights for the deferred-lighting ground truth (render_lit), in the files' camera space
  /// (X right, Y up, Z towards the camera; pitch_scene turns them with the primitives). The
  /// scenes' own radiance does not depend on them.
  std::vector<Light> lights;
  /// Render the lights instead of the emissive textures: every hit's radiance is lit_at (the
  /// pinhole and thin-lens renders of a lit scene; the pipeline's ground truth).
  bool lit = false;
};

/// The thin-lens camera: resolution, field of view, focus, blur at infinity, aperture shape.
struct LensCamera {
  int width = 640, height = 360;
  double hfov_deg = 60;  ///< horizontal field of view, degrees
  double focus_m = 5;    ///< z_F, metres
  double k_px = 12;      ///< K, blur radius of a point at infinity, px at `width`
  /// The aperture (core/aperture.hpp's model): the lens-plane shape, in image axes (x right,
  /// y down), is the model's far-field footprint of radius 1 scaled by the lens radius a.
  ApertureShape aperture;

  /// Pinhole focal length in pixels, F = (W/2)/tan(hfov/2).
  double f_px() const;
  /// Lens radius in metres, a = K·z_F/F (see the derivation at the top of this file).
  double lens_radius_m() const;
  /// Signed CoC radius (px) of depth z: K·(z_F/z − 1).
  double coc_px(double z) const;
};

/// A ray hit: planar depth z (= ray parameter), primitive index (−1 = background).
struct Hit {
  double z = std::numeric_limits<double>::infinity();
  int prim = -1;
};

/// Entry distance of a ray (o, d with d.z = 1) into one primitive, +inf if missed.
double intersect(const Primitive& p, Vec3 o, Vec3 d);
/// Radiance of primitive `p` at the surface point `x`.
Rgb shade_at(const Primitive& p, Vec3 x);
/// Radiance of primitive `p` at `x` lit by scene.lights and seen from `eye` (tracer axes): an
/// HDR emitter (emission > 1) its emission; any other surface the sum of shade_light with the
/// material render_gbuffer records, the geometric normal turned towards the eye (no shadows).
Rgb lit_at(const Scene& scene, const Primitive& p, Vec3 x, Vec3 eye);
/// The transmittance of light `l` towards the surface point x (tracer axes) of primitive `own`
/// (skipped: a convex solid or a plane cannot shadow its own lit side; −1: none): along the
/// segment to a point or spot light, or the ray against a directional light's direction, the
/// product of the filters of the translucent primitives crossed, 0 at any other primitive.
/// 1 for a light that casts no shadows and for ambient light.
Rgb shadow_transmittance(const Scene& scene, const Light& l, Vec3 x, int own);
/// The §5.8 maps of a shadow-casting spot light (camera space as Scene::lights), rendered by
/// one ray per texel centre from the light's position: a square perspective map of
/// `size_px`² texels whose half angle is the outer cone + 2° (outer_deg must be <= 80), the
/// opaque depth, the nearest translucent depth and the product of the filters of the
/// translucent primitives no farther than the opaque depth. Depths are the light's planar
/// depth (light space −Z). Same for any thread count.
ShadowMaps render_shadow_maps(const Scene& scene, const Light& l, int size_px, double bias_m);
/// Pixels near a caster's silhouette as the light sees it (1 plane, 1 = in the band): the set
/// of primitives on the line from the light through the pixel's first hit differs from that
/// through a point moved by up to ±`texels` texels of `m` across the light's view (same light
/// depth), or the hit lies outside the map. 0 for the background. Scenes of at most 64
/// primitives (the others are ignored).
Image shadow_band(const Scene& scene, const LensCamera& cam, const Light& l, const ShadowMaps& m, double texels);
/// The key transparencies of the pinhole view (Primitive::camera_alpha < 1) in front of the
/// opaque surface at each pixel centre: 5 planes, premultiplied R, G, B (lit_at's radiance ×
/// alpha), A, and Z, its planar depth (+inf where none; the nearest one only).
Image render_transparency(const Scene& scene, const LensCamera& cam);
/// The index of the opaque primitive each pixel centre of the pinhole view sees (1 plane, −1: none).
Image primitive_ids(const Scene& scene, const LensCamera& cam);

/// Radiance of the background in direction d.
Rgb shade_background(const Background& bg, Vec3 d);

/// Progress callback: fraction of the work done in [0, 1]; may be called from any thread.
using Progress = std::function<void(double)>;

/// Pinhole render: point-samples every pixel centre. colour RGBA (alpha 1), depth z (+inf for
/// the background); with layers > 0 also the first `layers` surfaces along each pixel ray,
/// front to back (each primitive once, at its entry point; the background is the last surface
/// of every ray, at z = +inf; missing layers have alpha 0 and z = +inf).
Frame render_pinhole(const Scene& scene, const LensCamera& cam, int layers = 0);

/// Thin-lens render: for every pixel centre, `samples` lens points (Owen-scrambled Sobol mapped
/// to the disc or polygon aperture), each traced through the pixel's focus-plane point; the
/// first hit's radiance is averaged. RGBA, alpha 1. Deterministic for (seed, samples), any
/// thread count. Apertures without an area-preserving map (curved blades, an aperture image,
/// cat's eye) are sampled over their bounding disc or box and weighted by their transmission
/// (per colour channel for an RGB image): the ratio of the weighted radiance to the weights.
Image render_thin_lens(const Scene& scene, const LensCamera& cam, int samples, std::uint64_t seed,
                       const Progress& progress = {});

/// Geometric unit normal of primitive `p` at the surface point `x`, pointing out of a solid (a
/// plane: its stored normal). Not oriented towards any viewer.
Vec3 normal_at(const Primitive& p, Vec3 x);

/// Rotates a whole scene about the camera's x axis so that a camera that looked along +z now
/// looks down by `pitch_deg` (the scene is built in a level "world" frame, y down, and turned
/// into the camera frame). Axis-aligned boxes become oriented boxes. The background is not
/// turned (it is the sky seen along the ray directions).
void pitch_scene(Scene& scene, double pitch_deg);

/// Ambient occlusion at the surface point p with unit normal n (oriented to the side the
/// point is seen from): the cosine-weighted fraction of the hemisphere around n whose rays
/// hit no primitive within `radius_m` (+inf: no limit), estimated with `rays` Owen-scrambled
/// Sobol directions (Malley's method: concentric disc lifted to the hemisphere) seeded by
/// `seed`. `cand` lists the primitives to test (indices into scene.prims; empty = all).
double ao_at(const Scene& scene, const std::vector<int>& cand, Vec3 p, Vec3 n, double radius_m, int rays,
             std::uint32_t seed);

/// Ray-traced ambient occlusion of the pinhole view (1 plane): at each pixel centre's first hit
/// p, with the geometric normal turned towards the camera, ao_at(p, n, radius_m, rays) over all
/// the scene's primitives (geometry outside the frame included; primitives farther than
/// radius_m from every hit point of a 16×16 tile are skipped, which changes nothing). Pixels
/// that see the background (depth +inf) get 1. Deterministic for (seed, rays), any thread count.
Image render_ao(const Scene& scene, const LensCamera& cam, double radius_m, int rays, std::uint64_t seed,
                const Progress& progress = {});

/// The deferred buffers of the pinhole view (docs/gbuffer.md), one value per pixel centre.
struct GBuffer {
  Image z;         ///< planar depth, metres (+inf: background)
  Image normal;    ///< 3 planes: unit normal, camera space X right, Y up, Z towards the camera (0 on the background)
  Image albedo;    ///< 3 planes: diffuse albedo in [0, 1] (the texture at emission 1; 0 for emitters and background)
  Image specular;  ///< 3 planes: specular colour in [0, 1]
  Image gloss;     ///< 1 plane: gloss in [0, 1]
  Image emissive;  ///< 3 planes: emitted radiance of HDR emitters (texture emission > 1), and of the background
};
GBuffer render_gbuffer(const Scene& scene, const LensCamera& cam);

/// The forward-lit ground truth of Scene::lights (3 planes, linear RGB): at each pixel centre's
/// exact first hit (double-precision point and geometric normal turned towards the camera, no
/// G-buffer rounding) the sum of shade_light over the lights (no shadows) with the material
/// render_gbuffer records (albedo, specular, gloss), plus the emissive radiance render_gbuffer
/// records (HDR emitters and the background). Same for any thread count.
Image render_lit(const Scene& scene, const LensCamera& cam);

/// The view matrix of a scene's level "world" frame (X right, Y up, Z towards the viewer of a
/// level camera, camera at the origin): world → camera space, row-major 4×4 (the pitch only).
std::array<double, 16> world_to_camera(const Scene& scene);

/// Builds a built-in scene by name (throws Error(usage) for an unknown name).
Scene build_scene(const std::string& name);
/// Builds a built-in ambient-occlusion scene (scenes_ao.cpp); throws Error(usage) for an
/// unknown name.
Scene build_ao_scene(const std::string& name);
/// Names of the built-in ambient-occlusion scenes.
std::vector<std::string> ao_scene_names();
/// Builds a built-in lighting scene (scenes_light.cpp); throws Error(usage) for an unknown name.
Scene build_light_scene(const std::string& name);
/// Names of the built-in lighting scenes (their lights are Scene::lights).
std::vector<std::string> light_scene_names();

/// The camera a scene render uses for `opt` (defaults filled in, options validated).
LensCamera camera_for(const Scene& scene, const SceneOptions& opt);

/// render_scene / render_pinhole for any Scene (tests build their own).
SceneRender render_custom(const Scene& scene, const SceneOptions& opt, bool ground_truth);

}  // namespace dofkit::scene
