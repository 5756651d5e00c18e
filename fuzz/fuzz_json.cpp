// libFuzzer target for the JSON files the commands read (issue 37): one control byte selects
// the reader, the rest is the file, written to a private .json file.
//   c % 1 == 0: camera.json (`dofkit ssao --camera`, cli::read_camera_fov) for a 64x36 depth.
// Bugs besides sanitizer reports: an error that is not a one-line usage / bad-input
// dofkit::Error, a field of view outside (0, 180) degrees accepted.
#include <string>

#include "fuzz_common.hpp"
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
  double fov = 0;
  if (fuzz::expect_ok_or_refused("read_camera_fov", [&] { fov = cli::read_camera_fov(path, 64, 36); }) &&
      !(fov > 0 && fov < 180))
    fuzz::bug("read_camera_fov accepted a field of view of " + std::to_string(fov) + " degrees");
  return 0;
}
