// The built-in lighting scene `lights` (docs/lighting.md): a room lit by coloured point and
// spot lights, one of them a key light beside the camera whose sphere of influence holds the
// camera and crosses the near plane, one small light that covers about 1 % of the frame, a
// dim directional moon light and an ambient term. Composed in a level "world" frame (the
// tracer's axes: x right, y down, z forward, camera at the origin) and turned by the camera's
// pitch like the AO scenes.
#include <cmath>
#include <numbers>

#include "dofkit/error.hpp"
#include "scene/raytracer.hpp"

namespace dofkit::scene {

namespace {

Texture matte(Rgb a, Rgb b, double noise_m, std::uint32_t seed, double checker_m = 0) {
  Texture t;
  t.a = a;
  t.b = b;
  t.noise_scale_m = noise_m;
  t.octaves = 5;
  t.seed = seed;
  t.checker_m = checker_m;
  t.checker_contrast = 0.2;
  return t;
}

// A light's position or direction given in the tracer's level frame, in the files' camera
// space (X right, Y up, Z towards the camera).
std::array<double, 3> file_axes(Vec3 v) { return {v.x, -v.y, -v.z}; }

Light point(const char* name, Vec3 at, std::array<double, 3> colour, double intensity, double radius_m) {
  Light l;
  l.kind = Light::Kind::point;
  l.name = name;
  l.position_m = file_axes(at);
  l.color = colour;
  l.intensity = intensity;
  l.radius_m = radius_m;
  return l;
}

Light spot(const char* name, Vec3 at, Vec3 towards, std::array<double, 3> colour, double intensity, double radius_m,
           double inner_deg, double outer_deg) {
  Light l = point(name, at, colour, intensity, radius_m);
  l.kind = Light::Kind::spot;
  const Vec3 d = towards - at;
  l.direction = file_axes(d * (1 / std::sqrt(dot(d, d))));
  l.inner_deg = inner_deg;
  l.outer_deg = outer_deg;
  return l;
}

// A cool ambient term, the light AO modulates.
Light ambient_light(double intensity) {
  Light l;
  l.kind = Light::Kind::ambient;
  l.name = "ambient";
  l.color = {0.7, 0.75, 0.9};
  l.intensity = intensity;
  l.ao = true;
  return l;
}

Scene lights_scene() {
  Scene s;
  s.name = "lights";
  s.description =
      "lighting: a room with coloured point and spot lights, a key light whose radius holds the camera, a "
      "small light, a moon and ambient light (lights.json + lit.exr with --gbuffer)";
  s.hfov_deg = 60;
  s.focus_m = 3.5;
  s.k_px_at_640 = 10;
  s.samples = 128;
  const double fy = 1.6;  // floor, metres below the camera
  const Texture walls = matte({0.75f, 0.74f, 0.7f}, {0.55f, 0.55f, 0.58f}, 1.5, 901);
  const Texture floor = matte({0.6f, 0.55f, 0.48f}, {0.4f, 0.37f, 0.33f}, 0.8, 902, 0.6);
  const Texture objects = matte({0.8f, 0.78f, 0.75f}, {0.55f, 0.6f, 0.7f}, 0.3, 903, 0.2);
  Texture lamp = matte({1, 0.9f, 0.7f}, {1, 0.9f, 0.7f}, 1, 904);
  lamp.octaves = 0;
  lamp.emission = 4;  // an HDR emitter: it is emissive in the G-buffer, not lit
  s.prims.push_back(Primitive::plane({0, fy, 0}, {0, -1, 0}, {1, 0, 0}, floor, "floor"));
  s.prims.push_back(Primitive::plane({0, 0, 6.0}, {0, 0, -1}, {1, 0, 0}, walls, "back wall"));
  s.prims.push_back(Primitive::plane({-2.2, 0, 0}, {1, 0, 0}, {0, 0, 1}, walls, "left wall"));
  s.prims.push_back(Primitive::plane({2.4, 0, 0}, {-1, 0, 0}, {0, 0, 1}, walls, "right wall"));
  s.prims.push_back(Primitive::box({-1.5, fy - 0.8, 3.6}, {-0.7, fy, 4.4}, objects, "box"));
  Primitive ball = Primitive::sphere({0.3, fy - 0.45, 3.2}, 0.45, objects, "shiny ball");
  ball.specular = {0.5f, 0.5f, 0.5f};
  ball.gloss = 0.7f;
  s.prims.push_back(ball);
  Primitive small = Primitive::sphere({1.3, fy - 0.2, 2.6}, 0.2, objects, "small ball");
  small.specular = {0.2f, 0.2f, 0.2f};
  small.gloss = 0.5f;
  s.prims.push_back(small);
  s.prims.push_back(Primitive::cylinder({1.6, fy, 4.8}, {1.6, fy - 1.4, 4.8}, 0.18, objects, "column"));
  s.prims.push_back(Primitive::sphere({-1.8, fy - 1.9, 5.6}, 0.08, lamp, "lamp"));

  s.lights.push_back(point("key (holds the camera)", {-0.3, 0.2, 0.3}, {1.0, 0.85, 0.7}, 5, 4.5));
  s.lights.push_back(point("red", {-1.6, 1.0, 3.0}, {1.0, 0.25, 0.2}, 2, 1.6));
  s.lights.push_back(point("blue", {1.3, 1.1, 4.3}, {0.25, 0.45, 1.0}, 3, 2.0));
  s.lights.push_back(point("small", {1.35, 1.15, 2.45}, {1.0, 0.3, 1.0}, 0.15, 0.24));
  s.lights.push_back(spot("green spot", {0.9, -0.6, 2.2}, {0.2, fy, 3.4}, {0.4, 1.0, 0.45}, 8, 4.0, 12, 24));
  s.lights.push_back(spot("white spot", {-2.0, -0.4, 4.0}, {-0.2, 0.3, 6.0}, {1.0, 0.95, 0.9}, 10, 4.5, 8, 20));
  Light moon;
  moon.kind = Light::Kind::directional;
  moon.name = "moon";
  moon.direction = file_axes({0.3, 1.0, 0.5});
  moon.color = {0.6, 0.7, 1.0};
  moon.intensity = 0.4;
  s.lights.push_back(moon);
  s.lights.push_back(ambient_light(0.05));
  for (Light& l : s.lights) validate_light(l, "scene lights");
  pitch_scene(s, 15);
  return s;
}

// A thin translucent slab (level frame) that filters light by `filter`; its albedo is a paler
// version of the same colour.
Primitive slab(const char* name, Vec3 lo, Vec3 hi, Rgb filter, std::uint32_t seed) {
  const Rgb pale{0.5f + 0.5f * filter.r, 0.5f + 0.5f * filter.g, 0.5f + 0.5f * filter.b};
  Primitive p = Primitive::box(lo, hi, matte(pale, {pale.r * 0.85f, pale.g * 0.85f, pale.b * 0.85f}, 0.4, seed), name);
  p.translucent = true;
  p.filter = filter;
  return p;
}

Scene shadows_scene() {
  Scene s;
  s.name = "shadows";
  s.description =
      "translucent shadows: a spot light over a floor, a red slab, a blue and a yellow slab that overlap, an opaque "
      "block over the red slab, a glass pane in front (a key transparency) (lights.json + shadow maps + "
      "transparency.exr + lit.exr with --gbuffer)";
  s.hfov_deg = 60;
  s.focus_m = 3.5;
  s.k_px_at_640 = 10;
  s.samples = 64;
  const double fy = 1.6;  // floor, metres below the camera
  const Texture floor = matte({0.75f, 0.74f, 0.7f}, {0.6f, 0.6f, 0.62f}, 0.8, 911, 0.5);
  const Texture block = matte({0.55f, 0.55f, 0.5f}, {0.4f, 0.42f, 0.45f}, 0.3, 912);
  s.prims.push_back(Primitive::plane({0, fy, 0}, {0, -1, 0}, {1, 0, 0}, floor, "floor"));
  s.prims.push_back(slab("red slab", {-1.55, fy - 0.75, 3.0}, {-0.45, fy - 0.71, 4.0}, {1.0f, 0.3f, 0.25f}, 913));
  s.prims.push_back(slab("blue slab", {0.1, fy - 0.95, 3.0}, {1.1, fy - 0.91, 4.0}, {0.3f, 0.55f, 1.0f}, 914));
  s.prims.push_back(slab("yellow slab", {0.55, fy - 0.55, 3.45}, {1.55, fy - 0.51, 4.45}, {1.0f, 0.85f, 0.3f}, 915));
  // The opaque caster, over the red slab's near half.
  s.prims.push_back(Primitive::box({-1.2, fy - 1.12, 3.0}, {-0.85, fy - 0.97, 3.3}, block, "block"));

  // A key transparency (§5.7): a half-covering glass pane in the near field, left out of the
  // opaque G-buffer and written as transparency.exr.
  Texture glass = matte({0.55f, 0.8f, 0.9f}, {0.5f, 0.75f, 0.85f}, 0.5, 916);
  Primitive pane = Primitive::box({-0.9, fy - 1.05, 2.0}, {-0.2, fy - 0.55, 2.02}, glass, "glass pane");
  pane.camera_alpha = 0.5f;
  s.prims.push_back(pane);

  Light key = spot("key spot", {-0.1, fy - 4.2, 2.2}, {0.0, fy, 4.0}, {1.0, 0.97, 0.92}, 40, 9.0, 30, 42);
  key.casts_shadows = true;
  s.lights.push_back(key);
  s.lights.push_back(ambient_light(0.08));
  for (Light& l : s.lights) validate_light(l, "scene shadows");
  pitch_scene(s, 25);
  return s;
}

}  // namespace

std::vector<std::string> light_scene_names() { return {"lights", "shadows"}; }

Scene build_light_scene(const std::string& name) {
  if (name == "lights") return lights_scene();
  if (name == "shadows") return shadows_scene();
  throw_usage("unknown lighting scene '" + name + "' (known: lights, shadows)");
}

}  // namespace dofkit::scene
