// Writes the fuzzer's seed corpus: one small valid file of each format and flavour dofkit
// reads, each prefixed with the 8 control bytes of fuzz_load_render.cpp (varied so the seeds
// start from different depth kinds and camera models).
// Usage: make_seeds OUT_DIR
#include <OpenImageIO/imageio.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <fstream>
#include <string>
#include <vector>

#include "dofkit/image.hpp"
#include "io/image_io.hpp"

namespace fs = std::filesystem;
using namespace dofkit;

namespace {

Image colour(int w, int h, bool alpha) {
  Image img(w, h, 4, 1.0f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float a = alpha ? 0.25f + 0.75f * x / std::max(1, w - 1) : 1.0f;
      img.at(x, y, 0) = a * x / std::max(1, w - 1);
      img.at(x, y, 1) = a * y / std::max(1, h - 1);
      img.at(x, y, 2) = a * (0.5f + 0.4f * std::sin(0.9f * x + 0.5f * y));
      img.at(x, y, 3) = a;
    }
  return img;
}

// Writes interleaved channels through OIIO directly (for channel layouts dofkit never writes).
void raw(const std::string& path, int w, int h, const std::vector<std::string>& names, OIIO::TypeDesc type,
         const std::function<float(int x, int y, int c)>& v) {
  OIIO::ImageSpec spec(w, h, static_cast<int>(names.size()), type);
  spec.channelnames = names;
  spec.alpha_channel = -1;
  spec.z_channel = -1;
  for (std::size_t c = 0; c < names.size(); ++c) {
    if (names[c] == "A") spec.alpha_channel = static_cast<int>(c);
    if (names[c] == "Z") spec.z_channel = static_cast<int>(c);
  }
  std::vector<float> buf;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (std::size_t c = 0; c < names.size(); ++c) buf.push_back(v(x, y, static_cast<int>(c)));
  auto out = OIIO::ImageOutput::create(path);
  if (!out || !out->open(path, spec) || !out->write_image(OIIO::TypeDesc::FLOAT, buf.data()) || !out->close()) {
    std::fprintf(stderr, "make_seeds: cannot write %s\n", path.c_str());
    std::exit(1);
  }
}

void seed(const fs::path& dir, const std::string& name, const std::string& file, std::vector<unsigned char> control) {
  std::ifstream in(file, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), {});
  std::ofstream out(dir / name, std::ios::binary);
  out.write(reinterpret_cast<const char*>(control.data()), static_cast<std::streamsize>(control.size()));
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  fs::remove(file);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: make_seeds OUT_DIR\n");
    return 2;
  }
  const fs::path dir = argv[1];
  fs::create_directories(dir);
  const std::string tmp = (dir / ".tmp").string();
  auto depth = [](int x, int y) { return (x + y) % 5 == 0 ? INFINITY : 0.5f + 0.7f * ((x * 3 + y) % 7); };

  // EXR: RGBA + Z float (the colour file's own depth), half RGB, single-channel depth named Y.
  raw(tmp + ".exr", 9, 7, {"R", "G", "B", "A", "Z"}, OIIO::TypeDesc::FLOAT, [&](int x, int y, int c) {
    return c < 3 ? 0.1f * (x + c) : c == 3 ? 1.0f : depth(x, y);
  });
  seed(dir, "exr_rgbaz_float", tmp + ".exr", {0, 0, 20, 24, 40, 0, 0, 0});
  io::WriteOptions half;
  half.bits = 16;
  io::write_image(tmp + ".exr", colour(6, 5, false), half);
  seed(dir, "exr_rgba_half", tmp + ".exr", {1, 1, 40, 30, 80, 1, 0, 0});
  raw(tmp + ".exr", 5, 4, {"Y"}, OIIO::TypeDesc::HALF, [&](int x, int y, int) { return depth(x, y); });
  seed(dir, "exr_depth_y_half", tmp + ".exr", {0x80, 2, 10, 0x35, 255, 0, 0, 0});
  raw(tmp + ".exr", 4, 4, {"depth.Z", "R", "G", "B"}, OIIO::TypeDesc::FLOAT,
      [&](int x, int y, int c) { return c == 0 ? depth(x, y) : 0.2f * c; });
  seed(dir, "exr_layer_depth_z", tmp + ".exr", {0, 3, 30, 0x42, 16, 0, 0, 1});
  // PNG: 8-bit RGBA, 16-bit RGB, 8-bit grey (a normalised disparity map).
  io::write_image(tmp + ".png", colour(7, 5, true));
  seed(dir, "png_rgba8", tmp + ".png", {2, 4, 50, 0x21, 30, 1, 1, 0});
  io::WriteOptions b16;
  b16.bits = 16;
  io::write_image(tmp + ".png", colour(5, 6, false), b16);
  seed(dir, "png_rgb16", tmp + ".png", {0, 0, 30, 60, 24, 0, 1, 0});
  Image grey(6, 4, 1);
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 6; ++x) grey.at(x, y) = (x + y) / 8.0f;
  io::write_image(tmp + ".png", grey);
  seed(dir, "png_grey_disparity", tmp + ".png", {2, 1, 40, 40, 40, 0, 1, 0});
  // JPEG.
  io::write_image(tmp + ".jpg", colour(8, 8, false));
  seed(dir, "jpeg_rgb", tmp + ".jpg", {0, 0, 25, 32, 32, 0, 3, 0});
  // TIFF: 8-bit RGBA, 16-bit RGB, 32-bit float single channel (depth, ndc).
  io::write_image(tmp + ".tif", colour(5, 5, true));
  seed(dir, "tiff_rgba8", tmp + ".tif", {0, 2, 15, 0x11, 255, 1, 2, 0});
  io::write_image(tmp + ".tif", colour(4, 6, false), b16);
  seed(dir, "tiff_rgb16", tmp + ".tif", {1, 3, 20, 0x33, 20, 0, 2, 0});
  Image ndc(5, 3, 1);
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 5; ++x) ndc.at(x, y) = (x + 5 * y) / 15.0f;
  io::WriteOptions f32;
  f32.bits = 32;
  io::write_image(tmp + ".tif", ndc, f32);
  seed(dir, "tiff_float_ndc", tmp + ".tif", {3, 0, 20, 40, 40, 0, 2, 0});
  std::printf("make_seeds: wrote 11 seeds to %s\n", dir.c_str());
  return 0;
}
