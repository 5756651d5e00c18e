// The built-in scenes. Each one stresses a known failure of post-process depth of field
// (each method page in docs/methods/ lists its own); docs/scenes.md shows what each contains and why.
//
// All scenes use the camera convention of raytracer.hpp (x right, y down, z forward, metres).
// Radiances are emissive and mostly within [0.03, 0.9] so that the sRGB-encoded, clipped
// metric sees every texture; only the `highlights` emitters go far above 1.
// Textures carry detail from metres down to about a pixel at the depth they are seen at
// (finest noise octave, texture lines), so any wrong blur shows.
#include <cmath>

#include "dofkit/error.hpp"
#include "scene/raytracer.hpp"

namespace dofkit::scene {

namespace {

Texture tex(Rgb a, Rgb b, double scale_m, int octaves, std::uint32_t seed) {
  Texture t;
  t.a = a;
  t.b = b;
  t.noise_scale_m = scale_m;
  t.octaves = octaves;
  t.seed = seed;
  return t;
}

Texture with_checker(Texture t, double side_m, double contrast) {
  t.checker_m = side_m;
  t.checker_contrast = contrast;
  return t;
}

Texture with_lines(Texture t, double spacing_m, double width_m, double darkness) {
  t.line_spacing_m = spacing_m;
  t.line_width_m = width_m;
  t.line_darkness = darkness;
  return t;
}

Texture emitter(Rgb c, double radiance) {
  Texture t;
  t.a = c;
  t.octaves = 0;
  t.emission = radiance;
  return t;
}

// A background that no ray of the scene reaches visibly but that keeps every ray defined.
Background dim_background() {
  Background bg;
  bg.top = {0.05f, 0.05f, 0.06f};
  bg.horizon = {0.05f, 0.05f, 0.06f};
  bg.clouds = tex({1, 1, 1}, {0.8f, 0.8f, 0.8f}, 0.2, 4, 99);
  return bg;
}

// Sky: gradient with multi-octave clouds on the direction's tangent coordinates (1 unit ≈ 1
// radian near the axis; the finest octave, 0.4/2^7 ≈ 0.003 rad, is about 2 px at 640 wide).
Background sky_background() {
  Background bg;
  bg.top = {0.22f, 0.42f, 0.85f};
  bg.horizon = {0.78f, 0.82f, 0.88f};
  bg.clouds = tex({1.1f, 1.1f, 1.1f}, {0.55f, 0.6f, 0.7f}, 0.4, 8, 4242);
  return bg;
}

Scene occluder() {
  Scene s;
  s.name = "occluder";
  s.description =
      "near pillar and ball with sharp silhouettes in front of an in-focus box and a textured far "
      "wall (near-field spreading, partial occlusion)";
  s.hfov_deg = 60;
  s.focus_m = 3.0;
  s.k_px_at_640 = 12;
  s.samples = 128;
  s.background = dim_background();
  // Far wall at 8 m (r = −7.5 px): bricks (checker + mortar lines) over noise.
  s.prims.push_back(Primitive::plane(
      {0, 0, 8}, {0, 0, -1}, {1, 0, 0},
      with_lines(with_checker(tex({0.75f, 0.42f, 0.25f}, {0.35f, 0.18f, 0.12f}, 1.2, 8, 11), 0.3, 0.25), 0.3, 0.02,
                 0.7),
      "far wall"));
  // Floor 1.2 m below the camera, visible from 3.7 m on.
  s.prims.push_back(Primitive::plane(
      {0, 1.2, 0}, {0, -1, 0}, {1, 0, 0},
      with_lines(tex({0.55f, 0.55f, 0.5f}, {0.15f, 0.17f, 0.2f}, 0.8, 8, 12), 0.5, 0.015, 0.8), "floor"));
  // In-focus box (front face exactly at the focus distance) and a ball beside it.
  s.prims.push_back(Primitive::box(
      {-0.7, -0.55, 3.0}, {0.35, 1.2, 3.6},
      with_lines(tex({0.2f, 0.55f, 0.75f}, {0.9f, 0.85f, 0.6f}, 0.4, 8, 13), 0.12, 0.006, 0.75), "focus box"));
  s.prims.push_back(Primitive::sphere(
      {0.75, 0.7, 3.3}, 0.32, with_checker(tex({0.85f, 0.3f, 0.3f}, {0.95f, 0.9f, 0.4f}, 0.2, 7, 14), 0.08, 0.35),
      "focus ball"));
  // Near pillar at 1.2 m (r = +18 px) covering the box's right edge, and a near ball.
  s.prims.push_back(Primitive::box(
      {0.02, -2.0, 1.2}, {0.16, 2.0, 1.35},
      with_lines(tex({0.9f, 0.9f, 0.85f}, {0.1f, 0.35f, 0.15f}, 0.15, 7, 15), 0.05, 0.005, 0.8), "near pillar"));
  s.prims.push_back(Primitive::sphere(
      {-0.42, -0.2, 1.45}, 0.1, with_checker(tex({0.95f, 0.75f, 0.2f}, {0.3f, 0.1f, 0.5f}, 0.08, 6, 16), 0.03, 0.4),
      "near ball"));
  return s;
}

Scene fence() {
  Scene s;
  s.name = "fence";
  s.description =
      "dark fence bars 2 m from the camera (r = +18 px, wider than the 11 px bars) over an "
      "in-focus poster wall, a far building and sky";
  s.hfov_deg = 60;
  s.focus_m = 5.0;
  s.k_px_at_640 = 12;
  s.samples = 128;
  s.background = sky_background();
  s.prims.push_back(
      Primitive::plane({0, 1.4, 0}, {0, -1, 0}, {1, 0, 0},
                       with_checker(tex({0.35f, 0.5f, 0.2f}, {0.12f, 0.2f, 0.08f}, 0.6, 8, 21), 0.5, 0.15), "lawn"));
  // In-focus wall (left) at 5 m with poster-like boxes; far building (right) at 14 m.
  s.prims.push_back(
      Primitive::box({-6, -3, 5.0}, {0.3, 1.4, 5.3},
                     with_lines(tex({0.8f, 0.8f, 0.75f}, {0.25f, 0.3f, 0.35f}, 0.9, 9, 22), 0.25, 0.01, 0.6), "wall"));
  s.prims.push_back(Primitive::box({-1.6, -0.9, 4.95}, {-0.7, 0.2, 5.0},
                                   with_checker(tex({0.9f, 0.2f, 0.15f}, {0.95f, 0.85f, 0.3f}, 0.2, 7, 23), 0.05, 0.3),
                                   "poster"));
  s.prims.push_back(Primitive::box(
      {1.5, -6, 14}, {9, 1.4, 20},
      with_lines(with_checker(tex({0.5f, 0.55f, 0.65f}, {0.15f, 0.15f, 0.2f}, 2.0, 9, 24), 1.0, 0.3), 0.5, 0.04, 0.7),
      "building"));
  // Bars: radius 2 cm (11 px wide) every 22 cm (61 px) at 2 m, blurred to r = +18 px, so each
  // bar is a translucent dark veil through which the background must show (McGuire's hardest
  // case: the CoC is larger than the bar).
  const Texture bar = tex({0.04f, 0.035f, 0.03f}, {0.3f, 0.22f, 0.12f}, 0.1, 6, 25);
  for (int i = -6; i <= 6; ++i)
    s.prims.push_back(Primitive::cylinder({0.22 * i + 0.07, -2.0, 2.0}, {0.22 * i + 0.07, 2.0, 2.0}, 0.02, bar, "bar"));
  s.prims.push_back(Primitive::cylinder({-3, 0.35, 2.03}, {3, 0.35, 2.03}, 0.02, bar, "rail"));
  return s;
}

Scene ground() {
  Scene s;
  s.name = "ground";
  s.description =
      "textured ground plane receding from r = +11 px through the focus (6 m) to the horizon, "
      "posts and balls at several depths, sky at +inf";
  s.hfov_deg = 60;
  s.focus_m = 6.0;
  s.k_px_at_640 = 12;
  s.samples = 128;
  s.background = sky_background();
  // Camera 1 m above the ground: the bottom row sees it at 3.1 m (r = +11.4 px).
  s.prims.push_back(Primitive::plane(
      {0, 1.0, 0}, {0, -1, 0}, {1, 0, 0},
      with_lines(with_checker(tex({0.7f, 0.6f, 0.45f}, {0.2f, 0.25f, 0.15f}, 1.5, 10, 31), 0.5, 0.25), 1.0, 0.02, 0.7),
      "ground"));
  const double post_z[] = {3.5, 6.0, 9.0, 16.0};
  const double post_x[] = {-1.6, 1.3, -2.2, 3.0};
  for (int i = 0; i < 4; ++i)
    s.prims.push_back(Primitive::cylinder(
        {post_x[i], 1.0, post_z[i]}, {post_x[i], -0.6, post_z[i]}, 0.06,
        with_lines(tex({0.9f, 0.9f, 0.9f}, {0.6f, 0.1f, 0.1f}, 0.1, 6, 32 + i), 0.2, 0.04, 0.8), "post"));
  s.prims.push_back(Primitive::sphere({0.4, 0.75, 4.5}, 0.25,
                                      with_checker(tex({0.2f, 0.4f, 0.9f}, {0.9f, 0.9f, 0.9f}, 0.15, 6, 37), 0.07, 0.3),
                                      "ball"));
  s.prims.push_back(Primitive::sphere({-0.3, 0.6, 11.0}, 0.4,
                                      with_checker(tex({0.9f, 0.5f, 0.1f}, {0.3f, 0.1f, 0.1f}, 0.2, 6, 38), 0.1, 0.3),
                                      "far ball"));
  return s;
}

Scene highlights() {
  Scene s;
  s.name = "highlights";
  s.description =
      "small HDR emitters (radiance 20 to ~300) at 1.7 to 17 m in a dim room: bokeh discs, "
      "fireflies, energy conservation";
  s.hfov_deg = 60;
  s.focus_m = 4.0;
  s.k_px_at_640 = 10;
  s.samples = 256;
  s.background = dim_background();
  s.prims.push_back(Primitive::plane(
      {0, 0, 18}, {0, 0, -1}, {1, 0, 0},
      with_lines(tex({0.12f, 0.1f, 0.14f}, {0.03f, 0.03f, 0.05f}, 1.5, 9, 41), 0.6, 0.03, 0.6), "back wall"));
  s.prims.push_back(
      Primitive::plane({0, 1.3, 0}, {0, -1, 0}, {1, 0, 0},
                       with_checker(tex({0.1f, 0.08f, 0.06f}, {0.03f, 0.03f, 0.03f}, 0.7, 8, 42), 0.4, 0.3), "floor"));
  s.prims.push_back(Primitive::box(
      {-0.9, 0.3, 4.0}, {-0.2, 1.3, 4.6},
      with_lines(tex({0.35f, 0.3f, 0.25f}, {0.08f, 0.08f, 0.1f}, 0.3, 7, 43), 0.1, 0.005, 0.7), "table"));
  // Emitters: a sphere whose pinhole image has radius s px, blurred to a disc of radius |r|,
  // has disc brightness ≈ L·(s/r)². L is chosen so that every disc is ~3 (clearly HDR after
  // clipping) and in-focus ones ≥ 20.
  const double f640 = 320.0 / std::tan(30.0 * 3.14159265358979 / 180.0);
  struct E {
    double x, y, z, s_px;
    Rgb c;
  };
  const E es[] = {
      {-0.55, -0.15, 1.7, 2.0, {1.0f, 0.85f, 0.6f}}, {0.45, 0.1, 1.9, 1.5, {0.6f, 0.8f, 1.0f}},
      {-0.2, -0.45, 2.6, 1.5, {1.0f, 0.5f, 0.4f}},   {0.9, -0.5, 3.2, 1.5, {0.7f, 1.0f, 0.6f}},
      {-0.45, 0.2, 4.0, 1.5, {1.0f, 1.0f, 0.9f}},    {0.3, -0.35, 4.0, 1.0, {1.0f, 0.6f, 0.9f}},
      {1.6, 0.0, 6.5, 2.0, {1.0f, 0.8f, 0.5f}},      {-2.3, -1.0, 8.0, 2.0, {0.5f, 0.7f, 1.0f}},
      {-1.0, -0.6, 12.0, 2.5, {1.0f, 0.9f, 0.7f}},   {3.0, -1.3, 12.0, 2.5, {0.9f, 0.5f, 0.3f}},
      {0.1, -2.5, 17.0, 2.5, {0.8f, 0.9f, 1.0f}},    {-4.5, 0.4, 16.0, 2.5, {1.0f, 0.7f, 0.7f}},
  };
  for (const E& e : es) {
    const double radius_m = e.s_px * e.z / f640;
    const double r = std::abs(s.k_px_at_640 * (s.focus_m / e.z - 1));
    const double L = std::max(20.0, 3.0 * (r / e.s_px) * (r / e.s_px));
    s.prims.push_back(Primitive::sphere({e.x, e.y, e.z}, radius_m, emitter(e.c, L), "emitter"));
  }
  // A string of fairy lights receding from 1.8 m to 9 m (a continuous range of bokeh sizes).
  for (int i = 0; i < 14; ++i) {
    const double z = 1.8 * std::pow(5.0, i / 13.0);
    const double radius_m = 1.2 * z / f640;
    const double r = std::abs(s.k_px_at_640 * (s.focus_m / z - 1));
    const double L = std::max(20.0, 3.0 * (r / 1.2) * (r / 1.2));
    s.prims.push_back(Primitive::sphere({1.2 - 0.06 * i, 0.45 - 0.05 * i, z}, radius_m,
                                        emitter({1.0f, 0.75f, 0.45f}, L), "fairy light"));
  }
  return s;
}

Scene portrait() {
  Scene s;
  s.name = "portrait";
  s.description =
      "sharp subject at 1.5 m (head, hair strands, shoulders) with a strongly blurred background "
      "close behind (2.4 m: r = −6 px, 4.5 m: r = −11 px)";
  s.hfov_deg = 40;
  s.focus_m = 1.5;
  s.k_px_at_640 = 16;
  s.samples = 128;
  s.background = dim_background();
  // Background: a bright, busy wall at 4.5 m and two columns at 2.4 m.
  s.prims.push_back(
      Primitive::plane({0, 0, 4.5}, {0, 0, -1}, {1, 0, 0},
                       with_lines(with_checker(tex({0.9f, 0.85f, 0.55f}, {0.15f, 0.35f, 0.2f}, 0.8, 9, 51), 0.25, 0.35),
                                  0.25, 0.012, 0.8),
                       "wall"));
  const Texture column = with_lines(tex({0.8f, 0.3f, 0.2f}, {0.95f, 0.9f, 0.85f}, 0.3, 8, 52), 0.1, 0.008, 0.7);
  s.prims.push_back(Primitive::cylinder({-0.55, -2, 2.4}, {-0.55, 2, 2.4}, 0.09, column, "column"));
  s.prims.push_back(Primitive::cylinder({0.6, -2, 2.6}, {0.6, 2, 2.6}, 0.12, column, "column"));
  // Subject: head (front at the focus distance), neck, shoulders.
  const Texture skin = tex({0.85f, 0.6f, 0.45f}, {0.55f, 0.35f, 0.25f}, 0.06, 6, 53);
  const Texture cloth = with_lines(tex({0.15f, 0.2f, 0.45f}, {0.5f, 0.6f, 0.8f}, 0.2, 8, 54), 0.03, 0.003, 0.7);
  s.prims.push_back(Primitive::sphere({0.0, -0.08, 1.6}, 0.1, skin, "head"));
  s.prims.push_back(Primitive::cylinder({0.0, 0.0, 1.62}, {0.0, 0.16, 1.62}, 0.045, skin, "neck"));
  s.prims.push_back(Primitive::box({-0.23, 0.13, 1.55}, {0.23, 0.8, 1.75}, cloth, "shoulders"));
  // Hair: thin dark strands (2 mm, ~1.2 px radius) fanning out of the top of the head.
  const Texture hair = tex({0.12f, 0.07f, 0.04f}, {0.3f, 0.2f, 0.1f}, 0.05, 4, 55);
  for (int i = 0; i < 13; ++i) {
    const double ang = (-60.0 + 10.0 * i) * 3.14159265358979 / 180.0;
    const double sx = std::sin(ang), sy = -std::cos(ang);
    const Vec3 base{0.09 * sx, -0.08 + 0.09 * sy, 1.58};
    const Vec3 tip{0.2 * sx, -0.08 + 0.19 * sy, 1.56 + 0.01 * (i % 3)};
    s.prims.push_back(Primitive::cylinder(base, tip, 0.002, hair, "hair"));
  }
  return s;
}

Scene sky() {
  Scene s;
  s.name = "sky";
  s.description =
      "trees, wires, a lamp post and a house as silhouettes against a cloudy sky at infinite "
      "depth (+inf), focus 10 m";
  s.hfov_deg = 60;
  s.focus_m = 10.0;
  s.k_px_at_640 = 12;
  s.samples = 128;
  s.background = sky_background();
  s.prims.push_back(
      Primitive::plane({0, 2.0, 0}, {0, -1, 0}, {1, 0, 0},
                       with_checker(tex({0.3f, 0.45f, 0.15f}, {0.1f, 0.15f, 0.05f}, 2.0, 10, 61), 1.0, 0.15), "field"));
  const Texture bark = with_lines(tex({0.3f, 0.2f, 0.12f}, {0.08f, 0.06f, 0.05f}, 0.3, 7, 62), 0.08, 0.01, 0.5);
  const Texture leaves = with_checker(tex({0.1f, 0.35f, 0.08f}, {0.5f, 0.7f, 0.2f}, 0.5, 9, 63), 0.15, 0.35);
  struct T {
    double x, z, h, r;
  };
  const T trees[] = {{-1.6, 5.0, 3.5, 1.0}, {2.5, 10.0, 4.5, 1.6}, {-6.0, 22.0, 6.0, 2.5}, {9.0, 35.0, 7.0, 3.0}};
  for (const T& t : trees) {
    s.prims.push_back(Primitive::cylinder({t.x, 2.0, t.z}, {t.x, 2.0 - t.h, t.z}, 0.08 + 0.02 * t.r, bark, "trunk"));
    s.prims.push_back(Primitive::sphere({t.x, 2.0 - t.h - 0.6 * t.r, t.z}, t.r, leaves, "canopy"));
  }
  // Lamp post at 4 m (r = +18 px) and two wires at 7 m (1 cm thick: ~0.8 px, blurred to 5 px).
  const Texture metal = with_lines(tex({0.2f, 0.2f, 0.22f}, {0.45f, 0.45f, 0.5f}, 0.2, 6, 64), 0.15, 0.02, 0.6);
  s.prims.push_back(Primitive::cylinder({0.9, 2.0, 4.0}, {0.9, -2.5, 4.0}, 0.05, metal, "lamp post"));
  s.prims.push_back(Primitive::sphere({0.9, -2.6, 4.0}, 0.18, with_checker(metal, 0.05, 0.3), "lamp"));
  s.prims.push_back(Primitive::cylinder({-8, -1.6, 7.0}, {8, -1.9, 7.0}, 0.005, metal, "wire"));
  s.prims.push_back(Primitive::cylinder({-8, -1.3, 7.5}, {8, -1.4, 7.5}, 0.005, metal, "wire"));
  // House at 30 m (r = −8 px).
  s.prims.push_back(Primitive::box(
      {4.0, -4.0, 30.0}, {12.0, 2.0, 36.0},
      with_lines(with_checker(tex({0.85f, 0.8f, 0.7f}, {0.4f, 0.3f, 0.25f}, 3.0, 10, 65), 1.2, 0.3), 0.6, 0.05, 0.6),
      "house"));
  return s;
}

}  // namespace

Scene build_scene(const std::string& name) {
  if (name == "occluder") return occluder();
  if (name == "fence") return fence();
  if (name == "ground") return ground();
  if (name == "highlights") return highlights();
  if (name == "portrait") return portrait();
  if (name == "sky") return sky();
  for (const std::string& ao : ao_scene_names())
    if (name == ao) return build_ao_scene(name);
  for (const std::string& l : light_scene_names())
    if (name == l) return build_light_scene(name);
  throw_usage(
      "unknown scene '" + name +
      "' (known: occluder, fence, ground, highlights, portrait, sky, ao_corner, ao_shelf, lights, shadows; see dofkit "
      "scene --list)");
}

}  // namespace dofkit::scene
