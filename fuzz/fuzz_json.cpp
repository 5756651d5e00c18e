// libFuzzer target for the JSON files the commands read (issue 37): one control byte selects
// the reader, the rest is the file, written to a private .json file.
//   c % 2 == 0: camera.json (`dofkit ssao --camera`, cli::read_camera_fov) for a 64x36 depth;
//   c % 2 == 1: a lights file (`dofkit light --lights`, cli::read_lights_file) with a camera
//               whose view matrix turns world-space lights.
// Bugs besides sanitizer reports: an error that is not a one-line usage / bad-input
// dofkit::Error, a field of view outside (0, 180) degrees accepted, a light accepted with a
// value out of its range or more lights than kMaxLights.
#include <cmath>
#include <string>
#include <vector>

#include "fuzz_common.hpp"
#include "light_common.hpp"
#include "ssao_common.hpp"

using namespace dofkit;

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  fuzz::setup();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const std::string path = fuzz::temp_path(".json");
  if (!fuzz::write_file(path, data + 1, size - 1)) return 0;
  if (data[0] % 2 == 1) {
    cli::CameraFile cam;
    cam.hfov_deg = 60;
    cam.has_view = true;
    cam.view = {1, 0, 0, 0.5, 0, 0, -1, 1, 0, 1, 0, -2, 0, 0, 0, 1};
    std::vector<Light> lights;
    if (!fuzz::expect_ok_or_refused("read_lights_file", [&] { lights = cli::read_lights_file(path, &cam); })) return 0;
    if (static_cast<int>(lights.size()) > kMaxLights) fuzz::bug("read_lights_file accepted more than kMaxLights");
    for (const Light& l : lights) {
      for (int k = 0; k < 3; ++k)
        if (!std::isfinite(l.position_m[k]) || !std::isfinite(l.direction[k]) || !(l.color[k] >= 0) ||
            !std::isfinite(l.color[k]))
          fuzz::bug("read_lights_file accepted a non-finite position, direction or colour");
      if (!(l.intensity >= 0) || !std::isfinite(l.intensity)) fuzz::bug("read_lights_file accepted a bad intensity");
      const bool local = l.kind == Light::Kind::point || l.kind == Light::Kind::spot;
      if (local && !(l.radius_m > 0 && std::isfinite(l.radius_m))) fuzz::bug("read_lights_file accepted a bad radius");
      if (l.kind == Light::Kind::spot && !(l.inner_deg >= 0 && l.inner_deg < l.outer_deg && l.outer_deg <= 90))
        fuzz::bug("read_lights_file accepted cone angles out of order");
    }
    return 0;
  }
  double fov = 0;
  if (fuzz::expect_ok_or_refused("read_camera_fov", [&] { fov = cli::read_camera_fov(path, 64, 36); }) &&
      !(fov > 0 && fov < 180))
    fuzz::bug("read_camera_fov accepted a field of view of " + std::to_string(fov) + " degrees");
  return 0;
}
