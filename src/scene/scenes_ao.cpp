// The built-in ambient-occlusion scenes: closed interiors (no sky in the frame) whose contact
// shadows span every scale an AO radius of 0.25–1 m sees — corners, steps, objects resting on
// the floor, thin pillars and legs, a narrow slot and a wedge. docs/scenes.md shows them.
//
// Each scene is composed in a level "world" frame (the tracer's axes: x right, y down, z
// forward, camera at the origin, floor at y = camera height) and then turned by the camera's
// pitch (pitch_scene), so that the floor, the walls and the boxes are seen at oblique angles,
// as from a game camera looking down.
#include <cmath>
#include <numbers>

#include "dofkit/error.hpp"
#include "scene/raytracer.hpp"

namespace dofkit::scene {

namespace {

// Noise between two colours, with an optional checker (side_m > 0) for the objects.
Texture surface(Rgb a, Rgb b, double noise_m, std::uint32_t seed, double checker_m = 0) {
  Texture t;
  t.a = a;
  t.b = b;
  t.noise_scale_m = noise_m;
  t.octaves = 6;
  t.seed = seed;
  t.checker_m = checker_m;
  t.checker_contrast = 0.25;
  return t;
}

// Unit vector at `deg` degrees from +x towards +z (a turn about the vertical axis).
Vec3 heading(double deg) {
  const double a = deg * std::numbers::pi / 180.0;
  return {std::cos(a), 0, std::sin(a)};
}

// A box standing on the floor (y = floor_y, y down) with its footprint [x0, x1] × [z0, z1].
Primitive floor_box(double floor_y, double x0, double x1, double z0, double z1, double height_m, Texture t,
                    std::string name) {
  return Primitive::box({x0, floor_y - height_m, z0}, {x1, floor_y, z1}, t, std::move(name));
}

Scene ao_corner() {
  Scene s;
  s.name = "ao_corner";
  s.description =
      "AO: a room corner seen from 1.5 m, 16 deg down: steps against the left wall, a turned box, balls "
      "on the floor, a log, three thin pillars in front of the back wall (AO radius 0.5 m)";
  s.hfov_deg = 55;
  s.focus_m = 3.5;
  s.k_px_at_640 = 12;
  s.samples = 128;
  s.ao_radius_m = 0.5;
  const double fy = 1.5;  // floor, metres below the camera
  const Texture walls = surface({0.72f, 0.7f, 0.66f}, {0.45f, 0.46f, 0.5f}, 1.2, 701);
  const Texture floor = surface({0.55f, 0.5f, 0.42f}, {0.3f, 0.28f, 0.25f}, 0.8, 702, 0.5);
  const Texture objects = surface({0.75f, 0.55f, 0.35f}, {0.3f, 0.4f, 0.6f}, 0.3, 703, 0.15);
  const Texture pillars = surface({0.85f, 0.85f, 0.8f}, {0.5f, 0.3f, 0.25f}, 0.2, 704);
  s.prims.push_back(Primitive::plane({0, fy, 0}, {0, -1, 0}, {1, 0, 0}, floor, "floor"));
  s.prims.push_back(Primitive::plane({0, 0, 5.0}, {0, 0, -1}, {1, 0, 0}, walls, "back wall"));
  s.prims.push_back(Primitive::plane({-1.7, 0, 0}, {1, 0, 0}, {0, 0, 1}, walls, "left wall"));
  // Four steps against the left wall, rising towards the back wall (nested boxes: step k
  // starts 0.35 m further back and is 0.2 m higher than step k − 1).
  for (int k = 0; k < 4; ++k)
    s.prims.push_back(floor_box(fy, -1.7, -0.9, 3.55 + 0.35 * k, 5.0, 0.2 * (k + 1), objects, "step"));
  s.prims.push_back(
      Primitive::oriented_box({0.95, fy - 0.3, 3.9}, {0.3, 0.3, 0.3}, heading(35), {0, 1, 0}, objects, "turned box"));
  s.prims.push_back(Primitive::sphere({-0.1, fy - 0.3, 3.1}, 0.3, objects, "ball"));
  s.prims.push_back(Primitive::sphere({0.45, fy - 0.12, 3.35}, 0.12, objects, "small ball"));
  s.prims.push_back(Primitive::sphere({1.55, fy - 0.2, 4.78}, 0.2, objects, "corner ball"));
  s.prims.push_back(Primitive::cylinder({0.25, fy - 0.1, 2.7}, {1.25, fy - 0.1, 2.95}, 0.1, objects, "log"));
  for (int k = 0; k < 3; ++k)
    s.prims.push_back(
        Primitive::cylinder({-0.55 + 0.33 * k, fy, 4.5}, {-0.55 + 0.33 * k, fy - 3.2, 4.5}, 0.045, pillars, "pillar"));
  pitch_scene(s, 16);
  return s;
}

Scene ao_shelf() {
  Scene s;
  s.name = "ao_shelf";
  s.description =
      "AO: a shelf with books against the back wall, a chair on thin legs, a 4 cm slot between two "
      "blocks and a plank leaning on the right wall, seen from 1.3 m, 22 deg down (AO radius 0.3 m)";
  s.hfov_deg = 60;
  s.focus_m = 2.5;
  s.k_px_at_640 = 12;
  s.samples = 128;
  s.ao_radius_m = 0.3;
  const double fy = 1.3;
  const double back = 3.4, right = 1.6;
  const Texture walls = surface({0.68f, 0.7f, 0.72f}, {0.42f, 0.45f, 0.43f}, 1.0, 801);
  const Texture floor = surface({0.5f, 0.42f, 0.32f}, {0.28f, 0.22f, 0.18f}, 0.6, 802, 0.4);
  const Texture wood = surface({0.62f, 0.45f, 0.3f}, {0.4f, 0.28f, 0.18f}, 0.15, 803);
  const Texture books = surface({0.7f, 0.25f, 0.2f}, {0.2f, 0.35f, 0.6f}, 0.05, 804, 0.06);
  const Texture blocks = surface({0.6f, 0.6f, 0.58f}, {0.35f, 0.38f, 0.42f}, 0.25, 805, 0.2);
  s.prims.push_back(Primitive::plane({0, fy, 0}, {0, -1, 0}, {1, 0, 0}, floor, "floor"));
  s.prims.push_back(Primitive::plane({0, 0, back}, {0, 0, -1}, {1, 0, 0}, walls, "back wall"));
  s.prims.push_back(Primitive::plane({right, 0, 0}, {-1, 0, 0}, {0, 0, 1}, walls, "right wall"));
  // Shelf: two sides, a plinth and three boards, 0.32 m deep, against the back wall.
  const double sx0 = -1.5, sx1 = -0.3, sz0 = back - 0.32;
  s.prims.push_back(floor_box(fy, sx0, sx0 + 0.03, sz0, back, 1.6, wood, "shelf side"));
  s.prims.push_back(floor_box(fy, sx1 - 0.03, sx1, sz0, back, 1.6, wood, "shelf side"));
  s.prims.push_back(floor_box(fy, sx0 + 0.03, sx1 - 0.03, sz0 + 0.02, back, 0.08, wood, "plinth"));
  for (double h : {0.45, 0.85, 1.25})
    s.prims.push_back(Primitive::box({sx0 + 0.03, fy - h - 0.025, sz0}, {sx1 - 0.03, fy - h, back}, wood, "board"));
  // Books on the lowest board: a row with a gap, then one leaning on the row.
  double bx = sx0 + 0.06;
  for (int k = 0; k < 9; ++k) {
    const double wk = 0.035 + 0.01 * (k % 3), hk = 0.2 + 0.03 * ((k * 7) % 4);
    s.prims.push_back(floor_box(fy - 0.45, bx, bx + wk, sz0 + 0.06, sz0 + 0.28, hk, books, "book"));
    bx += wk + (k == 5 ? 0.12 : 0.002);
  }
  const double lean = 20 * std::numbers::pi / 180;
  s.prims.push_back(Primitive::oriented_box({bx + 0.06, fy - 0.45 - 0.12, sz0 + 0.17}, {0.02, 0.125, 0.11},
                                            {std::cos(lean), std::sin(lean), 0}, {-std::sin(lean), std::cos(lean), 0},
                                            books, "leaning book"));
  // Middle board: a vase (ball) and a box.
  s.prims.push_back(Primitive::sphere({-1.2, fy - 0.85 - 0.09, back - 0.16}, 0.09, blocks, "vase"));
  s.prims.push_back(floor_box(fy - 0.85, -0.8, -0.5, back - 0.28, back - 0.04, 0.18, blocks, "box on shelf"));
  // Chair: seat top 0.47 m high on four legs (radius 2 cm), a back rest with two posts and a slat.
  const double cx0 = 0.05, cx1 = 0.5, cz0 = 1.95, cz1 = 2.4, seat = 0.47;
  s.prims.push_back(Primitive::box({cx0, fy - seat, cz0}, {cx1, fy - seat + 0.035, cz1}, wood, "seat"));
  for (double lx : {cx0 + 0.03, cx1 - 0.03})
    for (double lz : {cz0 + 0.03, cz1 - 0.03})
      s.prims.push_back(Primitive::cylinder({lx, fy, lz}, {lx, fy - seat + 0.035, lz}, 0.02, wood, "chair leg"));
  for (double lx : {cx0 + 0.03, cx1 - 0.03})
    s.prims.push_back(
        Primitive::cylinder({lx, fy - seat, cz1 - 0.03}, {lx, fy - 0.95, cz1 - 0.03}, 0.02, wood, "post"));
  s.prims.push_back(
      Primitive::box({cx0 + 0.01, fy - 0.9, cz1 - 0.05}, {cx1 - 0.01, fy - 0.78, cz1 - 0.01}, wood, "slat"));
  // A 4 cm slot between two blocks, the second one against the right wall.
  s.prims.push_back(floor_box(fy, 0.85, 1.2, 2.65, 3.05, 0.5, blocks, "block"));
  s.prims.push_back(floor_box(fy, 1.24, right, 2.55, 3.1, 0.7, blocks, "block"));
  // A plank leaning on the right wall at 25 degrees from it (a closing wedge).
  const double tilt = 25 * std::numbers::pi / 180;
  const double len = 1.1, foot = len * std::sin(tilt);
  s.prims.push_back(Primitive::oriented_box({right - 0.5 * foot - 0.012, fy - 0.5 * len * std::cos(tilt), 1.9},
                                            {0.012, 0.5 * len, 0.14}, {std::cos(tilt), std::sin(tilt), 0},
                                            {-std::sin(tilt), std::cos(tilt), 0}, wood, "plank"));
  s.prims.push_back(Primitive::sphere({-0.35, fy - 0.15, 2.2}, 0.15, blocks, "ball"));
  pitch_scene(s, 22);
  return s;
}

}  // namespace

std::vector<std::string> ao_scene_names() { return {"ao_corner", "ao_shelf"}; }

Scene build_ao_scene(const std::string& name) {
  if (name == "ao_corner") return ao_corner();
  if (name == "ao_shelf") return ao_shelf();
  throw_usage("unknown AO scene '" + name + "' (known: ao_corner, ao_shelf)");
}

}  // namespace dofkit::scene
