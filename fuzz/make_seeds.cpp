// Writes the fuzz targets' seed corpora: small valid files of each format and flavour dofkit
// reads, into CORPUS_DIR/<target>/ — for load_render each prefixed with the 8 control bytes
// of fuzz_load_render.cpp (varied so the seeds start from different depth kinds and camera
// models), for the reader targets (exr, png, jpeg, tiff, layers) with the one control byte of
// fuzz_reader.cpp — plus hand-made streams for render and cli.
// Usage: make_seeds CORPUS_DIR
#include <OpenImageIO/deepdata.h>
#include <OpenImageIO/imageio.h>
#include <zlib.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <fstream>
#include <string>
#include <vector>

#include "dofkit/image.hpp"
#include "dofkit/frame.hpp"
#include "io/image_io.hpp"
#include "io/layers_io.hpp"
#include "io/phone_depth.hpp"

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
         const std::function<float(int x, int y, int c)>& v,
         const std::vector<std::pair<std::string, std::string>>& attributes = {}, int tile = 0) {
  OIIO::ImageSpec spec(w, h, static_cast<int>(names.size()), type);
  spec.channelnames = names;
  spec.alpha_channel = -1;
  spec.z_channel = -1;
  for (std::size_t c = 0; c < names.size(); ++c) {
    if (names[c] == "A") spec.alpha_channel = static_cast<int>(c);
    if (names[c] == "Z") spec.z_channel = static_cast<int>(c);
  }
  for (const auto& [k, a] : attributes) {
    if (k == "tiff:bigtiff" || k == "jpeg:progressive")
      spec.attribute(k, std::stoi(a));
    else
      spec.attribute(k, a);
  }
  if (tile) spec.tile_width = spec.tile_height = tile;
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

// A PNG written byte by byte (palette, transparency, low bit depths and interlacing, which
// neither dofkit's writer nor OpenImageIO's writes): IHDR, the extra chunks, one IDAT of the
// rows (each already with its filter byte), IEND.
void put32(std::string& s, std::uint32_t v) {
  for (int k = 3; k >= 0; --k) s.push_back(static_cast<char>((v >> (8 * k)) & 0xff));
}
void chunk(std::string& png, const std::string& type, const std::string& data) {
  put32(png, static_cast<std::uint32_t>(data.size()));
  const std::string td = type + data;
  png += td;
  put32(png,
        static_cast<std::uint32_t>(crc32(0, reinterpret_cast<const Bytef*>(td.data()), static_cast<uInt>(td.size()))));
}
void hand_png(const std::string& path, int w, int h, int depth, int ctype, int interlace, const std::string& rows,
              const std::vector<std::pair<std::string, std::string>>& extra) {
  std::string png("\x89PNG\r\n\x1a\n", 8), ihdr;
  put32(ihdr, static_cast<std::uint32_t>(w));
  put32(ihdr, static_cast<std::uint32_t>(h));
  ihdr += static_cast<char>(depth);
  ihdr += static_cast<char>(ctype);
  ihdr += std::string(2, '\0');
  ihdr += static_cast<char>(interlace);
  chunk(png, "IHDR", ihdr);
  for (const auto& [t, d] : extra) chunk(png, t, d);
  std::vector<Bytef> z(compressBound(static_cast<uLong>(rows.size())));
  uLongf n = z.size();
  compress2(z.data(), &n, reinterpret_cast<const Bytef*>(rows.data()), static_cast<uLong>(rows.size()), 9);
  chunk(png, "IDAT", std::string(reinterpret_cast<const char*>(z.data()), n));
  chunk(png, "IEND", "");
  std::ofstream(path, std::ios::binary) << png;
}
// Rows of `bytes_per_row` bytes each (pattern by row and column), each after filter type 0.
std::string rows_of(int rows, int bytes_per_row) {
  std::string s;
  for (int y = 0; y < rows; ++y) {
    s += '\0';
    for (int x = 0; x < bytes_per_row; ++x) s += static_cast<char>((x * 37 + y * 11) & 0xff);
  }
  return s;
}
// Adam7 rows of a w x h image with `bits` bits per pixel.
std::string adam7_rows(int w, int h, int bits) {
  static const int pass[7][4] = {{0, 0, 8, 8}, {4, 0, 8, 8}, {0, 4, 4, 8}, {2, 0, 4, 4},
                                 {0, 2, 2, 4}, {1, 0, 2, 2}, {0, 1, 1, 2}};
  std::string s;
  for (const auto& p : pass) {
    const int pw = w > p[0] ? (w - p[0] + p[2] - 1) / p[2] : 0, ph = h > p[1] ? (h - p[1] + p[3] - 1) / p[3] : 0;
    if (pw && ph) s += rows_of(ph, (pw * bits + 7) / 8);
  }
  return s;
}

void seed(const fs::path& dir, const std::string& name, const std::string& file, std::vector<unsigned char> control) {
  std::ifstream in(file, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), {});
  fs::create_directories(dir);
  std::ofstream out(dir / name, std::ios::binary);
  out.write(reinterpret_cast<const char*>(control.data()), static_cast<std::streamsize>(control.size()));
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

void bytes_seed(const fs::path& dir, const std::string& name, const std::vector<unsigned char>& bytes) {
  fs::create_directories(dir);
  std::ofstream out(dir / name, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: make_seeds CORPUS_DIR\n");
    return 2;
  }
  const fs::path root = argv[1];
  fs::create_directories(root);
  const fs::path lr = root / "load_render", exr = root / "exr", png = root / "png", jpg = root / "jpeg",
                 tif = root / "tiff", layers = root / "layers";
  const std::string tmp = (root / ".tmp").string();
  auto depth = [](int x, int y) { return (x + y) % 5 == 0 ? INFINITY : 0.5f + 0.7f * ((x * 3 + y) % 7); };
  // Each file as a load_render seed (8 control bytes) and a reader seed (1 control byte).
  auto both = [&](const fs::path& reader, const std::string& name, const std::string& file,
                  std::vector<unsigned char> control) {
    seed(lr, name, file, control);
    seed(reader, name, file, {control[0]});
    fs::remove(file);
  };
  auto one = [&](const fs::path& reader, const std::string& name, const std::string& file, unsigned char control) {
    seed(reader, name, file, {control});
    fs::remove(file);
  };

  // EXR: RGBA + Z float (the colour file's own depth), half RGB, single-channel depth named Y.
  raw(tmp + ".exr", 9, 7, {"R", "G", "B", "A", "Z"}, OIIO::TypeDesc::FLOAT, [&](int x, int y, int c) {
    return c < 3 ? 0.1f * (x + c) : c == 3 ? 1.0f : depth(x, y);
  });
  both(exr, "exr_rgbaz_float", tmp + ".exr", {0, 0, 20, 24, 40, 0, 0, 0});
  io::WriteOptions half;
  half.bits = 16;
  io::write_image(tmp + ".exr", colour(6, 5, false), half);
  both(exr, "exr_rgba_half", tmp + ".exr", {1, 1, 40, 30, 80, 1, 0, 0});
  raw(tmp + ".exr", 5, 4, {"Y"}, OIIO::TypeDesc::HALF, [&](int x, int y, int) { return depth(x, y); });
  both(exr, "exr_depth_y_half", tmp + ".exr", {0x80, 2, 10, 0x35, 255, 0, 0, 0});
  raw(tmp + ".exr", 4, 4, {"depth.Z", "R", "G", "B"}, OIIO::TypeDesc::FLOAT,
      [&](int x, int y, int c) { return c == 0 ? depth(x, y) : 0.2f * c; });
  both(exr, "exr_layer_depth_z", tmp + ".exr", {0, 3, 30, 0x42, 16, 0, 0, 1});
  // Every other compression, tiles (EXR reader only).
  for (const char* c : {"piz", "rle", "zips", "pxr24", "b44", "b44a", "dwaa", "dwab"}) {
    raw(tmp + ".exr", 8, 6, {"R", "G", "B", "A"}, OIIO::TypeDesc::HALF,
        [&](int x, int y, int k) { return k == 3 ? 1.0f : 0.05f * (x + 2 * y + k); }, {{"compression", c}});
    one(exr, std::string("exr_") + c, tmp + ".exr", 0);
  }
  raw(
      tmp + ".exr", 9, 7, {"R", "G", "B", "Z"}, OIIO::TypeDesc::HALF,
      [&](int x, int y, int k) { return k == 3 ? depth(x, y) : 0.1f * k; }, {{"compression", "zip"}}, 4);
  one(exr, "exr_tiled_zip", tmp + ".exr", 0);

  // PNG: 8-bit RGBA, 16-bit RGB, 8-bit grey (a normalised disparity map).
  io::write_image(tmp + ".png", colour(7, 5, true));
  both(png, "png_rgba8", tmp + ".png", {2, 4, 50, 0x21, 30, 1, 1, 0});
  io::WriteOptions b16;
  b16.bits = 16;
  io::write_image(tmp + ".png", colour(5, 6, false), b16);
  both(png, "png_rgb16", tmp + ".png", {0, 0, 30, 60, 24, 0, 1, 0});
  Image grey(6, 4, 1);
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 6; ++x) grey.at(x, y) = (x + y) / 8.0f;
  io::write_image(tmp + ".png", grey);
  both(png, "png_grey_disparity", tmp + ".png", {2, 1, 40, 40, 40, 0, 1, 0});
  // Hand-made: palette (with tRNS), 1/2/4-bit grey, interlaced RGB and grey + alpha, grey key.
  const std::string plte("\x10\x20\x30\x80\x90\xa0\xff\x00\x40\x00\xff\x00", 12);
  hand_png(tmp + ".png", 5, 4, 2, 3, 0, rows_of(4, 2), {{"PLTE", plte}, {"tRNS", std::string("\xff\x80\x00", 3)}});
  one(png, "png_palette2_trns", tmp + ".png", 0);
  hand_png(tmp + ".png", 6, 3, 8, 3, 0,
           std::string(1, '\0') + std::string("\0\1\2\3\0\1", 6) + std::string(1, '\0') + std::string(6, '\2') +
               std::string(1, '\0') + std::string(6, '\1'),
           {{"PLTE", plte}});
  one(png, "png_palette8", tmp + ".png", 0);
  for (int bits : {1, 2, 4}) {
    hand_png(tmp + ".png", 11, 3, bits, 0, 0, rows_of(3, (11 * bits + 7) / 8), {});
    one(png, "png_grey" + std::to_string(bits), tmp + ".png", 2);
  }
  hand_png(tmp + ".png", 9, 9, 8, 2, 1, adam7_rows(9, 9, 24), {});
  one(png, "png_interlaced_rgb", tmp + ".png", 0);
  hand_png(tmp + ".png", 7, 5, 16, 4, 1, adam7_rows(7, 5, 32), {});
  one(png, "png_interlaced_grey_alpha16", tmp + ".png", 0);
  hand_png(tmp + ".png", 4, 3, 16, 0, 0, rows_of(3, 8), {{"tRNS", std::string("\x25\x0b", 2)}});
  one(png, "png_grey16_key", tmp + ".png", 0);

  // JPEG: RGB, grey, progressive.
  io::write_image(tmp + ".jpg", colour(8, 8, false));
  both(jpg, "jpeg_rgb", tmp + ".jpg", {0, 0, 25, 32, 32, 0, 3, 0});
  io::write_image(tmp + ".jpg", grey);
  one(jpg, "jpeg_grey", tmp + ".jpg", 2);
  raw(tmp + ".jpg", 17, 9, {"R", "G", "B"}, OIIO::TypeDesc::UINT8,
      [&](int x, int y, int c) { return 0.05f * ((x + y + c) % 20); }, {{"jpeg:progressive", "1"}});
  one(jpg, "jpeg_progressive", tmp + ".jpg", 0);

  // TIFF: 8-bit RGBA, 16-bit RGB, 32-bit float single channel (depth, ndc).
  io::write_image(tmp + ".tif", colour(5, 5, true));
  both(tif, "tiff_rgba8", tmp + ".tif", {0, 2, 15, 0x11, 255, 1, 2, 0});
  io::write_image(tmp + ".tif", colour(4, 6, false), b16);
  both(tif, "tiff_rgb16", tmp + ".tif", {1, 3, 20, 0x33, 20, 0, 2, 0});
  Image ndc(5, 3, 1);
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 5; ++x) ndc.at(x, y) = (x + 5 * y) / 15.0f;
  io::WriteOptions f32;
  f32.bits = 32;
  io::write_image(tmp + ".tif", ndc, f32);
  both(tif, "tiff_float_ndc", tmp + ".tif", {3, 0, 20, 40, 40, 0, 2, 0});
  // Other codecs and layouts (TIFF reader only).
  for (const char* c : {"lzw", "packbits", "jpeg", "none"}) {
    raw(tmp + ".tif", 10, 7, {"R", "G", "B"}, OIIO::TypeDesc::UINT8,
        [&](int x, int y, int k) { return 0.07f * ((x * y + k) % 14); }, {{"compression", c}});
    one(tif, std::string("tiff_") + c, tmp + ".tif", 0);
  }
  raw(
      tmp + ".tif", 9, 7, {"R", "G", "B", "A"}, OIIO::TypeDesc::UINT16,
      [&](int x, int y, int k) { return k == 3 ? 1.0f : 0.1f * ((x + y) % 10); }, {{"compression", "zip"}}, 16);
  one(tif, "tiff_tiled", tmp + ".tif", 0);
  raw(tmp + ".tif", 6, 5, {"Y"}, OIIO::TypeDesc::FLOAT, [&](int x, int y, int) { return depth(x, y); },
      {{"tiff:bigtiff", "1"}});
  one(tif, "tiff_bigtiff_depth", tmp + ".tif", 0);

  // Layers: dofkit's layered EXR and a deep EXR.
  {
    Frame f;
    for (int l = 0; l < 3; ++l) {
      f.layer_color.push_back(colour(6, 4, l > 0));
      Image z(6, 4, 1);
      for (int y = 0; y < 4; ++y)
        for (int x = 0; x < 6; ++x) z.at(x, y) = 1.0f + l + 0.1f * x;
      f.layer_depth.push_back(z);
    }
    io::write_layers_exr(tmp + ".exr", f);
    one(layers, "layered_3", tmp + ".exr", 0x20);
    OIIO::ImageSpec spec(5, 4, 5, OIIO::TypeDesc::FLOAT);
    spec.channelnames = {"R", "G", "B", "A", "Z"};
    spec.alpha_channel = 3;
    spec.z_channel = 4;
    spec.deep = true;
    OIIO::DeepData dd;
    dd.init(spec);
    for (int p = 0; p < 20; ++p) dd.set_samples(p, p % 3);
    for (int p = 0; p < 20; ++p)
      for (int s = 0; s < p % 3; ++s)
        for (int c = 0; c < 5; ++c) dd.set_deep_value(p, c, s, c == 4 ? 2.0f + s + 0.1f * p : 0.3f + 0.1f * c);
    auto out = OIIO::ImageOutput::create(tmp + ".exr");
    if (!out || !out->open(tmp + ".exr", spec) || !out->write_deep_image(dd) || !out->close()) {
      std::fprintf(stderr, "make_seeds: cannot write the deep EXR\n");
      return 1;
    }
    out.reset();
    one(layers, "deep_rgbaz", tmp + ".exr", 0x70);
  }

  // render(): size, method, model, parameters, pixels (fuzz_render.cpp reads them in order).
  for (int m = 0; m < 6; ++m) {
    std::vector<unsigned char> b = {7, 5, static_cast<unsigned char>(m), static_cast<unsigned char>(m % 5)};
    for (int k = 0; k < 8; ++k) b.push_back(static_cast<unsigned char>(130 + 11 * k + m));
    b.insert(b.end(), {3, 140, 200, 1, 0, 0});
    for (int k = 0; k < 7 * 5 * 5; ++k) b.push_back(static_cast<unsigned char>((k * 29 + m) % 240));
    bytes_seed(root / "render", "render_" + std::to_string(m), b);
  }
  // The command line: subcommand byte, then (flag, value) pairs (fuzz_cli.cpp's tables).
  bytes_seed(root / "cli", "render_base", {0x80});
  bytes_seed(root / "cli", "render_reference", {0x80, 9, 0, 25, 1});
  bytes_seed(root / "cli", "render_frames", {0x80, 0, 8, 5, 4, 39, 18});
  bytes_seed(root / "cli", "compare", {0x81});
  bytes_seed(root / "cli", "methods", {2});
  // Phone photos (fuzz_phone.cpp): an XMP packet, base64 text, a GDepth JPEG (a 4x3 8-bit PNG
  // depth in the standard XMP), and the start of a HEIF file.
  {
    const fs::path phone = root / "phone";
    const auto text_seed = [&](const std::string& name, unsigned char control, const std::string& text) {
      std::vector<unsigned char> b = {control};
      b.insert(b.end(), text.begin(), text.end());
      bytes_seed(phone, name, b);
    };
    const auto packet = [](const std::string& attrs) {
      return "<?xpacket begin=\"\" id=\"W5M0MpCehiHzreSzNTczkc9d\"?><x:xmpmeta xmlns:x=\"adobe:ns:meta/\"><rdf:RDF "
             "xmlns:rdf=\"http://www.w3.org/1999/02/22-rdf-syntax-ns#\"><rdf:Description rdf:about=\"\" "
             "xmlns:GDepth=\"http://ns.google.com/photos/1.0/depthmap/\" " +
             attrs + "/></rdf:RDF></x:xmpmeta><?xpacket end=\"w\"?>";
    };
    Image d(4, 3, 1);
    for (int i = 0; i < 12; ++i) d.data()[i] = static_cast<float>(20 * i) / 255.0f;
    io::write_image(tmp + ".png", d);
    std::ifstream pin(tmp + ".png", std::ios::binary);
    const std::string png((std::istreambuf_iterator<char>(pin)), {});
    fs::remove(tmp + ".png");
    const std::string xmp = packet(
        "GDepth:Format=\"RangeInverse\" GDepth:Near=\"0.5\" GDepth:Far=\"8\" GDepth:Mime=\"image/png\" GDepth:Data=\"" +
        io::encode_base64(png) + "\"");
    text_seed("xmp", 0, xmp);
    text_seed("base64", 1, io::encode_base64("a depth image"));
    io::write_image(tmp + ".jpg", colour(8, 6, false));
    std::ifstream jin(tmp + ".jpg", std::ios::binary);
    const std::string jpg((std::istreambuf_iterator<char>(jin)), {});
    fs::remove(tmp + ".jpg");
    const std::string payload = std::string("http://ns.adobe.com/xap/1.0/\0", 29) + xmp;
    const std::string segment = std::string("\xFF\xE1", 2) + static_cast<char>((payload.size() + 2) >> 8) +
                                static_cast<char>((payload.size() + 2) & 255) + payload;
    text_seed("gdepth_jpeg", 2, jpg.substr(0, 2) + segment + jpg.substr(2));
    text_seed("gdepth_jpeg_far", 6, jpg.substr(0, 2) + segment + jpg.substr(2));
    // A container photo: GDepth's fields in the XMP, the PNG appended as the Depth item.
    const std::string cxmp =
        "<?xpacket begin=\"\" id=\"W5M0MpCehiHzreSzNTczkc9d\"?><x:xmpmeta xmlns:x=\"adobe:ns:meta/\"><rdf:RDF "
        "xmlns:rdf=\"http://www.w3.org/1999/02/22-rdf-syntax-ns#\"><rdf:Description rdf:about=\"\" "
        "xmlns:GDepth=\"http://ns.google.com/photos/1.0/depthmap/\" "
        "xmlns:Container=\"http://ns.google.com/photos/1.0/container/\" "
        "xmlns:Item=\"http://ns.google.com/photos/1.0/container/item/\" GDepth:Format=\"RangeInverse\" "
        "GDepth:Near=\"0.5\" GDepth:Far=\"8\" GDepth:Mime=\"image/png\"><Container:Directory><rdf:Seq><rdf:li "
        "rdf:parseType=\"Resource\"><Container:Item Item:Semantic=\"Primary\" Item:Mime=\"image/jpeg\"/></rdf:li>"
        "<rdf:li rdf:parseType=\"Resource\"><Container:Item Item:Semantic=\"Depth\" Item:Mime=\"image/png\" "
        "Item:Length=\"" +
        std::to_string(png.size()) +
        "\" Item:Padding=\"1\"/></rdf:li></rdf:Seq></Container:Directory></rdf:Description></rdf:RDF></x:xmpmeta>"
        "<?xpacket end=\"w\"?>";
    const std::string cpayload = std::string("http://ns.adobe.com/xap/1.0/\0", 29) + cxmp;
    const std::string csegment = std::string("\xFF\xE1", 2) + static_cast<char>((cpayload.size() + 2) >> 8) +
                                 static_cast<char>((cpayload.size() + 2) & 255) + cpayload;
    text_seed("container_jpeg", 2, jpg.substr(0, 2) + csegment + jpg.substr(2) + png + "P");
    text_seed("heif_start", 3,
              std::string("\0\0\0\x18"
                          "ftypheic\0\0\0\0mif1heic",
                          24));
  }
  // The JSON files: control byte 0 (camera.json), then the file.
  const auto json_seed = [&](const std::string& name, const std::string& text) {
    std::vector<unsigned char> b{0};
    b.insert(b.end(), text.begin(), text.end());
    bytes_seed(root / "json", name, b);
  };
  json_seed("camera", R"({"hfov_deg": 55, "width": 64, "height": 36, "near_m": 0.1, "far_m": 100})");
  json_seed("camera_no_size", R"({"hfov_deg": 90.5})");
  json_seed("camera_wrong_size", R"({"hfov_deg": 40, "width": 65})");
  json_seed("camera_bad_fov", R"({"hfov_deg": 180})");
  std::printf("make_seeds: wrote the seed corpora to %s\n", root.c_str());
  return 0;
}
