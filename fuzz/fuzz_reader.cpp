// libFuzzer targets for one reader each (issue 37): the input is one control byte and then
// the file's bytes, written to a private file with the format's extension (FUZZ_EXTENSION)
// and read every way a command reads it: io::probe_image (the header walk), read_color,
// read_depth (the kind from the control byte), read_mask, load_frame with the file's own
// depth; with FUZZ_LAYERS instead io::read_layers (deep EXR and dofkit's layered EXR).
//   c & 7: depth kind (z, distance, disparity, ndc, ndc-reversed); c & 8: --invalid-depth far;
//   c >> 4: --max-layers - 1 (layers target).
// Bugs besides sanitizer reports: an error that is not a one-line usage / bad-input
// dofkit::Error, an image whose size differs from what probe_image announced or exceeds the
// pixel budget, a colour image without 4 planes.
#include <string>

#include "dofkit/frame.hpp"
#include "fuzz_common.hpp"
#include "io/layers_io.hpp"

using namespace dofkit;

namespace {

void check_size(const char* what, const Image& img, const io::ImageInfo* probed) {
  if (img.empty()) return;
  if (static_cast<long long>(img.width()) * img.height() > fuzz::kFuzzMaxPixels)
    fuzz::bug(std::string(what) + ": an image beyond the pixel budget was read");
  if (probed && (img.width() != probed->width || img.height() != probed->height))
    fuzz::bug(std::string(what) + ": the image read is " + std::to_string(img.width()) + "x" +
              std::to_string(img.height()) + " but its header was probed as " + std::to_string(probed->width) + "x" +
              std::to_string(probed->height));
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  fuzz::setup();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 2) return 0;
  const std::uint8_t c = data[0];
  const std::string path = fuzz::temp_path(FUZZ_EXTENSION);
  if (!fuzz::write_file(path, data + 1, size - 1)) return 0;
  io::ImageInfo info;
  const bool probed = fuzz::expect_ok_or_refused("probe_image", [&] { info = io::probe_image(path, "colour"); });
#ifdef FUZZ_LAYERS
  Frame frame;
  if (fuzz::expect_ok_or_refused("read_layers", [&] { io::read_layers(path, frame, 1 + (c >> 4)); })) {
    check_size("read_layers colour", frame.color, probed ? &info : nullptr);
    check_size("read_layers depth", frame.depth, probed ? &info : nullptr);
    if (frame.layer_color.empty() || frame.layer_color.size() != frame.layer_depth.size() ||
        static_cast<int>(frame.layer_color.size()) > 1 + (c >> 4))
      fuzz::bug("read_layers returned " + std::to_string(frame.layer_color.size()) + " layers");
    for (const Image& l : frame.layer_color) check_size("read_layers layer", l, probed ? &info : nullptr);
  }
#else
  io::DepthOptions opt;
  opt.kind = static_cast<io::DepthKind>((c & 7) % 5);
  opt.invalid_as_far = (c & 8) != 0;
  opt.fov_deg = 60;
  opt.disparity_scale = 2;
  Image img;
  if (fuzz::expect_ok_or_refused("read_color", [&] { img = io::read_color(path); })) {
    if (img.channels() != 4) fuzz::bug("read_color returned " + std::to_string(img.channels()) + " planes");
    check_size("read_color", img, probed ? &info : nullptr);
  }
  if (fuzz::expect_ok_or_refused("read_depth", [&] { img = io::read_depth(path, opt); }))
    check_size("read_depth", img, probed ? &info : nullptr);
  if (fuzz::expect_ok_or_refused("read_mask", [&] { img = io::read_mask(path); }))
    check_size("read_mask", img, probed ? &info : nullptr);
  Frame frame;
  if (fuzz::expect_ok_or_refused("load_frame", [&] { frame = io::load_frame(path, "", opt); }))
    check_size("load_frame", frame.color, probed ? &info : nullptr);
#endif
  std::remove(path.c_str());
  return 0;
}
