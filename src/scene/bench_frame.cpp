#include "scene/bench_frame.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace dofkit::scene {

Frame bench_frame(int w, int h) {
  Frame f;
  f.color = Image(w, h, 4, 1.0f);
  f.depth = Image(w, h, 1);
  for (int y = 0; y < h; ++y) {
    const float v = (y + 0.5f) / h;
    for (int x = 0; x < w; ++x) {
      const float u = (x + 0.5f) / w;
      float z;
      if (u > 0.08f && u < 0.16f)
        z = 1.2f;  // near bar
      else if (std::hypot(u - 0.55f, v - 0.5f) < 0.18f)
        z = 4.0f;  // subject in focus
      else if (v > 0.65f)
        z = 1.5f / std::max(0.02f, (v - 0.6f) * 2.6f);  // ground
      else
        z = v < 0.1f ? std::numeric_limits<float>::infinity() : 8.0f + 60.0f * (0.65f - v);  // far wall / sky
      f.depth.at(x, y) = z;
      const float t = std::sin(0.11f * x) * std::sin(0.07f * y) + 0.3f * std::sin(1.7f * x + 0.9f * y);
      f.color.at(x, y, 0) = 0.45f + 0.35f * t;
      f.color.at(x, y, 1) = 0.40f + 0.30f * std::sin(0.05f * x + 0.5f * t);
      f.color.at(x, y, 2) = 0.50f + 0.30f * std::cos(0.03f * y + t);
      if ((x * 7 + y * 13) % 997 == 0) f.color.at(x, y, 0) = f.color.at(x, y, 1) = f.color.at(x, y, 2) = 40.0f;
    }
  }
  return f;
}

CameraModel bench_camera(int w) {
  CameraModel cam;
  cam.model = BlurAtInfinity{4.0, 0.015 * w};
  cam.max_coc_px = 0.03 * w;
  return cam;
}

}  // namespace dofkit::scene
