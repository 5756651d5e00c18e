// EXR passthrough (see exr_passthrough.hpp), through OpenEXR's C++ library: it reads every
// EXR layout (tiled, any compression) and copies attributes of any type, which the direct
// reader and writer (exr_direct.hpp) do not. Only files that carry something use it; a plain
// RGBA EXR input is written by write_image as before.
#include "io/exr_passthrough.hpp"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfCompression.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputPart.h>
#include <OpenEXR/ImfMultiPartInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfPartType.h>
#include <OpenEXR/ImfStandardAttributes.h>

#include <Imath/half.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <exception>
#include <set>

#include "dofkit/error.hpp"

namespace dofkit::io {

namespace {

// Attributes that describe the stored layout: the writer sets its own.
bool layout_attribute(const std::string& name) {
  static const std::set<std::string> kLayout = {
      "channels", "compression", "dataWindow", "displayWindow", "lineOrder",          "tiles",
      "type",     "name",        "version",    "chunkCount",    "maxSamplesPerPixel", "dwaCompressionLevel"};
  return kLayout.count(name) > 0;
}

std::size_t sample_bytes(Imf::PixelType t) { return t == Imf::HALF ? 2 : 4; }

std::string one_line(std::string m) {
  std::replace(m.begin(), m.end(), '\n', ' ');
  return m;
}

}  // namespace

struct ExrPassthrough::Impl {
  struct Channel {
    std::string name;
    Imf::Channel info;
    std::vector<std::uint8_t> data;  // W·H samples of sample_bytes(info.type), row-major
  };
  std::vector<Channel> channels;  // file (sorted) order
  Imf::Header attributes;         // only the kept attributes are copied from it
  std::vector<std::string> kept;  // names of the attributes to copy
  bool worth = false;             // a kept attribute that a plain write would not have
};

ExrPassthrough::ExrPassthrough() : impl_(std::make_unique<Impl>()) {}
ExrPassthrough::~ExrPassthrough() = default;

bool ExrPassthrough::empty() const { return impl_->channels.empty() && !impl_->worth; }

std::vector<std::string> ExrPassthrough::channel_names() const {
  std::vector<std::string> names;
  for (const auto& c : impl_->channels) names.push_back(c.name);
  return names;
}

std::shared_ptr<const ExrPassthrough> ExrPassthrough::read(const std::string& color_path,
                                                           const std::vector<std::string>& color_channels, int width,
                                                           int height, std::vector<std::string>& notes) {
  std::shared_ptr<ExrPassthrough> out(new ExrPassthrough());
  Impl& im = *out->impl_;
  try {
    Imf::MultiPartInputFile file(color_path.c_str());
    const Imf::Header& h = file.header(0);
    if (h.hasType() && Imf::isDeepData(h.type())) {
      notes.push_back(color_path + " is a deep EXR: its channels are not passed through (the output is flat RGBA)");
      return out;
    }
    if (file.parts() > 1)
      notes.push_back(color_path + " has " + std::to_string(file.parts()) +
                      " parts: only the first part's channels are passed through");
    const Imath::Box2i dw = h.dataWindow();
    if (dw.max.x - dw.min.x + 1 != width || dw.max.y - dw.min.y + 1 != height) {
      notes.push_back(color_path + ": data window is not the colour's size; nothing passed through");
      return out;
    }
    // The colour channels, chosen as read_color chose them (the same rule on the same names).
    std::vector<std::string> names;
    int alpha = -1;
    for (auto it = h.channels().begin(); it != h.channels().end(); ++it) {
      if (alpha < 0 && std::string(it.name()) == "Alpha") alpha = static_cast<int>(names.size());
      names.emplace_back(it.name());
    }
    const ColorChannelChoice choice = choose_color_channels(names, color_channels, alpha);
    if (!choice.problem.empty()) throw_bad_input(color_path + ": " + choice.problem);
    if (choice.r < 0) {
      notes.push_back(color_path + ": no channels named R, G, B: nothing passed through (--rgba-only silences this)");
      return out;
    }
    const std::set<int> colour = {choice.r, choice.g, choice.b, choice.a};
    static const std::set<std::string> kOutputNames = {"R", "G", "B", "A"};
    std::vector<std::string> clashed, subsampled;
    Imf::FrameBuffer fb;
    const std::size_t W = static_cast<std::size_t>(width);
    int index = 0;
    for (auto it = h.channels().begin(); it != h.channels().end(); ++it, ++index) {
      if (colour.count(index)) continue;
      const std::string name = it.name();
      if (kOutputNames.count(name)) {
        clashed.push_back(name);
        continue;
      }
      if (it.channel().xSampling != 1 || it.channel().ySampling != 1) {
        subsampled.push_back(name);
        continue;
      }
      Impl::Channel c{name, it.channel(), {}};
      const std::size_t bytes = sample_bytes(c.info.type);
      c.data.resize(W * static_cast<std::size_t>(height) * bytes);
      im.channels.push_back(std::move(c));
    }
    // (Pointers into the channels' buffers are taken once the vector no longer grows.)
    for (Impl::Channel& c : im.channels) {
      const std::size_t bytes = sample_bytes(c.info.type);
      fb.insert(c.name, Imf::Slice::Make(c.info.type, c.data.data(), dw, bytes, bytes * W));
    }
    const auto list = [](const std::vector<std::string>& v) {
      std::string s;
      for (const auto& n : v) s += (s.empty() ? "" : ", ") + n;
      return s;
    };
    if (!clashed.empty())
      notes.push_back(color_path + ": channel(s) " + list(clashed) +
                      " not passed through: the output's own colour channels have those names");
    if (!subsampled.empty())
      notes.push_back(color_path + ": subsampled channel(s) " + list(subsampled) + " not passed through");
    if (!im.channels.empty()) {
      Imf::InputPart part(file, 0);
      part.setFrameBuffer(fb);
      part.readPixels(dw.min.y, dw.max.y);
    }
    for (auto it = h.begin(); it != h.end(); ++it) {
      const std::string name = it.name();
      if (layout_attribute(name)) continue;
      im.kept.push_back(name);
      im.attributes.insert(name, it.attribute());
      // The attributes every EXR has are worth a passthrough write only when not the default.
      if (name == "pixelAspectRatio")
        im.worth = im.worth || h.pixelAspectRatio() != 1.0f;
      else if (name == "screenWindowCenter")
        im.worth = im.worth || h.screenWindowCenter() != Imath::V2f(0, 0);
      else if (name == "screenWindowWidth")
        im.worth = im.worth || h.screenWindowWidth() != 1.0f;
      else
        im.worth = true;
    }
  } catch (const Error&) {
    throw;
  } catch (const std::bad_alloc&) {
    throw;
  } catch (const std::exception& e) {
    throw_bad_input(color_path + ": cannot read its other channels for the EXR output: " + one_line(e.what()) +
                    " (--rgba-only writes RGBA alone)");
  }
  return out;
}

void encode_exr_passthrough(const std::string& file, const std::string& format_path, const Image& rgba,
                            const WriteOptions& opt, const ExrPassthrough& extra) {
  const ExrPassthrough::Impl& im = *extra.impl_;
  const int W = rgba.width(), H = rgba.height(), C = rgba.channels();
  if (W <= 0 || H <= 0 || (C != 3 && C != 4)) throw_internal(format_path + ": passthrough needs a colour image");
  static const std::pair<const char*, Imf::Compression> kCompressions[] = {
      {"", Imf::ZIP_COMPRESSION},        {"none", Imf::NO_COMPRESSION},  {"rle", Imf::RLE_COMPRESSION},
      {"zips", Imf::ZIPS_COMPRESSION},   {"zip", Imf::ZIP_COMPRESSION},  {"piz", Imf::PIZ_COMPRESSION},
      {"pxr24", Imf::PXR24_COMPRESSION}, {"b44", Imf::B44_COMPRESSION},  {"b44a", Imf::B44A_COMPRESSION},
      {"dwaa", Imf::DWAA_COMPRESSION},   {"dwab", Imf::DWAB_COMPRESSION}};
  Imf::Compression compression = Imf::NUM_COMPRESSION_METHODS;
  for (const auto& [name, c] : kCompressions)
    if (opt.compression == name) compression = c;
  if (compression == Imf::NUM_COMPRESSION_METHODS)
    throw_internal(format_path + ": EXR compression " + opt.compression + " not known");
  const bool half = opt.bits == 16;
  const bool alpha = C == 4 && opt.keep_alpha;
  try {
    Imf::Header h(W, H);
    for (const std::string& name : im.kept) h.insert(name, im.attributes[name.c_str()]);
    h.compression() = compression;
    const Imf::PixelType rgba_type = half ? Imf::HALF : Imf::FLOAT;
    Imf::FrameBuffer fb;
    const char* kNames[] = {"R", "G", "B", "A"};
    const std::size_t n = rgba.plane_size();
    std::vector<Imath::half> halves(half ? n * (alpha ? 4 : 3) : 0);
    for (int c = 0; c < (alpha ? 4 : 3); ++c) {
      h.channels().insert(kNames[c], Imf::Channel(rgba_type));
      if (half) {
        // OpenEXR writes a slice in its channel's type: converted here with Imath's rounding,
        // as the direct writer converts.
        Imath::half* dst = halves.data() + n * static_cast<std::size_t>(c);
        const float* src = rgba.plane(c);
        for (std::size_t i = 0; i < n; ++i) dst[i] = Imath::half(src[i]);
        fb.insert(kNames[c], Imf::Slice(Imf::HALF, reinterpret_cast<char*>(dst), 2, 2 * static_cast<std::size_t>(W)));
      } else {
        fb.insert(kNames[c], Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(const_cast<float*>(rgba.plane(c))), 4,
                                        4 * static_cast<std::size_t>(W)));
      }
    }
    for (const auto& ch : im.channels) {
      h.channels().insert(ch.name, ch.info);
      const std::size_t bytes = sample_bytes(ch.info.type);
      fb.insert(ch.name, Imf::Slice(ch.info.type, reinterpret_cast<char*>(const_cast<std::uint8_t*>(ch.data.data())),
                                    bytes, bytes * static_cast<std::size_t>(W)));
    }
    Imf::OutputFile out(file.c_str(), h);
    out.setFrameBuffer(fb);
    out.writePixels(H);
  } catch (const Error&) {
    throw;
  } catch (const std::bad_alloc&) {
    throw;
  } catch (const std::exception& e) {
    throw_bad_input(format_path + ": cannot write: " + one_line(e.what()));
  }
}

}  // namespace dofkit::io
