// libFuzzer target over dofkit's load + render path (issue 9).
//
// Input layout: 8 control bytes, then the bytes of an image file (EXR, PNG, TIFF or JPEG).
//   c[0]  depth kind (c[0] % 5: z, distance, disparity, ndc, ndc-reversed); bit 7: invalid
//         depth → far (--invalid-depth far)
//   c[1]  camera model (c[1] % 5: blur-at-infinity, thin lens, four planes, StarCraft II,
//         Sterna near/far)
//   c[2], c[3]  model parameters (focus, K / f-number / plane spacing …)
//   c[4]  --max-coc: 1 + c[4]/8 px, 255 = none
//   c[5]  threads: 1 + (c[5] & 1)
//   c[6]  file extension when the magic number is not recognised (c[6] % 4)
//   c[7]  reserved (varies the crop)
// The file is written to a private temporary file and read with io::read_color,
// io::read_depth, io::read_mask and io::load_frame (its own Z channel). Whatever loads is
// cropped to at most 24x24 px and rendered with every registered method.
//
// Crash conditions besides sanitizer reports: an exception that is not dofkit::Error, an
// Error of kind `internal`, output of the wrong size, or a non-finite output sample.
//
// The pixel budget (io::set_pixel_budget) is 64x64 px here, so every header that declares
// more is refused by dofkit itself, before it allocates: loading a legitimate large file
// would only measure the machine. The budget is checked against the size dofkit's own reader
// sees. (An earlier version skipped files whose size OpenImageIO reported as large; a PNG
// that OpenImageIO refuses but the direct reader takes went through and allocated 1.3 GB.)
#include <OpenImageIO/imageio.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include "dofkit/render.hpp"
#include "fuzz_common.hpp"
#include "io/image_io.hpp"

using namespace dofkit;

namespace {

constexpr std::size_t kControl = 8;
constexpr int kCrop = 24;

const char* extension_for(const std::uint8_t* d, std::size_t n, std::uint8_t pick) {
  if (n >= 4 && d[0] == 0x76 && d[1] == 0x2f && d[2] == 0x31 && d[3] == 0x01) return ".exr";
  if (n >= 4 && d[0] == 0x89 && d[1] == 'P' && d[2] == 'N' && d[3] == 'G') return ".png";
  if (n >= 2 && d[0] == 0xff && d[1] == 0xd8) return ".jpg";
  if (n >= 4 && ((d[0] == 'I' && d[1] == 'I') || (d[0] == 'M' && d[1] == 'M'))) return ".tif";
  static const char* exts[] = {".exr", ".png", ".tif", ".jpg"};
  return exts[pick % 4];
}

CameraModel camera_from(const std::uint8_t* c) {
  CameraModel cam;
  const double a = c[2], b = c[3];
  switch (c[1] % 5) {
    case 0:
      cam.model = BlurAtInfinity{0.05 + a * 0.1, b / 4.0};
      break;
    case 1:
      cam.model = ThinLens{10.0 + (c[3] & 0x3f) * 4.0, 0.25 + (b / 16.0), 0.02 + a * 0.05, 36.0};
      break;
    case 2: {
      const double nb = 0.1 + a * 0.02, ns = nb + (c[3] & 15) * 0.3, fs = ns + (c[3] >> 4) * 0.5;
      cam.model = FourPlane{nb,
                            ns,
                            fs,
                            (c[7] & 1) ? std::numeric_limits<double>::infinity() : fs + 1 + a * 0.1,
                            b / 8.0,
                            a / 8.0,
                            (c[7] & 2) != 0};
      break;
    }
    case 3:
      cam.model =
          StarCraft{0.1 + a * 0.1, (c[3] & 15) * 0.25, (c[3] & 15) * 0.25 + 0.01 + (c[3] >> 4), a / 64.0, b / 8.0};
      break;
    default:
      cam.model = NearFarBlend{a * 0.01, a * 0.01 + 0.1 + (c[3] & 15) * 0.2, a * 0.01 + 0.1 + (c[3] & 15) * 0.2,
                               a * 0.01 + 0.2 + (c[3] & 15) * 0.2 + (c[3] >> 4), b / 8.0};
  }
  cam.max_coc_px = c[4] == 255 ? std::numeric_limits<double>::infinity() : 1.0 + c[4] / 8.0;
  return cam;
}

Image crop(const Image& img, int w, int h) {
  Image out(w, h, img.channels());
  for (int c = 0; c < img.channels(); ++c)
    for (int y = 0; y < h; ++y) std::memcpy(out.row(c, y), img.row(c, y), sizeof(float) * w);
  return out;
}

void check_render(const Frame& f, const RenderSettings& s) {
  RenderResult r;
  if (fuzz::expect_ok_or_refused(s.method.c_str(), [&] { r = render(f, s); }))
    fuzz::check_result(s.method, r, f.width(), f.height());
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  fuzz::setup();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < kControl + 1) return 0;
  const std::uint8_t* c = data;
  const std::uint8_t* file = data + kControl;
  const std::size_t n = size - kControl;
  const std::string path = fuzz::temp_path(extension_for(file, n, c[6]));
  {
    std::FILE* fp = std::fopen(path.c_str(), "wb");
    if (!fp) return 0;
    std::fwrite(file, 1, n, fp);
    std::fclose(fp);
  }
  io::DepthOptions opt;
  opt.kind = static_cast<io::DepthKind>(c[0] % 5);
  opt.invalid_as_far = (c[0] & 0x80) != 0;
  opt.fov_deg = 60;
  opt.disparity_scale = 2;
  opt.clip_near = 0.1;
  opt.clip_far = (c[0] & 0x40) ? std::numeric_limits<double>::infinity() : 100.0;

  Image colour, depth;
  try {
    colour = io::read_color(path);
  } catch (const Error&) {
  }
  try {
    depth = io::read_depth(path, opt);
  } catch (const Error&) {
  }
  try {
    io::read_mask(path);
  } catch (const Error&) {
  }
  try {
    io::load_frame(path, "", opt);
  } catch (const Error&) {
  }
  std::remove(path.c_str());
  if (colour.empty()) return 0;
  if (colour.channels() != 4) fuzz::bug("read_color returned " + std::to_string(colour.channels()) + " planes");

  const int w = std::min(colour.width(), kCrop - (c[7] & 7)), h = std::min(colour.height(), kCrop - (c[7] >> 5));
  Frame frame;
  frame.color = crop(colour, w, h);
  if (!depth.empty() && depth.width() >= w && depth.height() >= h) {
    frame.depth = crop(depth, w, h);
  } else {
    // No usable depth in the file: derive one from the colour, so the render still runs.
    frame.depth = Image(w, h, 1);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const float g = frame.color.at(x, y, 1);
        frame.depth.at(x, y) = g > 0.95f ? std::numeric_limits<float>::infinity() : 0.2f + 20.0f * std::fabs(g);
        if (!(frame.depth.at(x, y) > 0)) frame.depth.at(x, y) = 1.0f;  // NaN colour
      }
  }
  for (const auto& m : methods()) {
    RenderSettings s;
    s.method = m.name;
    s.camera = camera_from(c);
    s.threads = 1 + (c[5] & 1);
    check_render(frame, s);
  }
  return 0;
}
