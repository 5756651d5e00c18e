// libdofkit_oiio.so: the OpenImageIO calls of dofkit_io (see io/oiio_module.hpp). Nothing
// here throws: OpenImageIO's exceptions and errors come back as strings.
#include <OpenImageIO/deepdata.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <exception>

#include "io/oiio_module.hpp"

namespace dofkit::io::oiio {

namespace {

std::string one_line(std::string e) {
  std::replace(e.begin(), e.end(), '\n', ' ');
  while (!e.empty() && e.back() == ' ') e.pop_back();
  return e;
}

std::string global_error() {
  std::string e = one_line(OIIO::geterror());
  return e.empty() ? "unknown error" : e;
}

class OiioInput final : public Input {
 public:
  explicit OiioInput(std::unique_ptr<OIIO::ImageInput> in) : in_(std::move(in)) {
    const OIIO::ImageSpec& s = in_->spec();
    spec_.width = s.width;
    spec_.height = s.height;
    spec_.depth = s.depth;
    spec_.nchannels = s.nchannels;
    spec_.channelnames = s.channelnames;
    spec_.alpha_channel = s.alpha_channel;
    spec_.z_channel = s.z_channel;
    spec_.full_x = s.full_x;
    spec_.full_y = s.full_y;
    spec_.full_width = s.full_width;
    spec_.full_height = s.full_height;
    spec_.x = s.x;
    spec_.y = s.y;
    spec_.deep = s.deep;
    const auto b = s.format.basetype;
    spec_.integer = b != OIIO::TypeDesc::FLOAT && b != OIIO::TypeDesc::HALF && b != OIIO::TypeDesc::DOUBLE;
    spec_.unassociated = s.get_int_attribute("oiio:UnassociatedAlpha", 0) != 0;
  }

  bool read(int cb, int ce, float* out) override {
    try {
      if (in_->read_image(0, 0, cb, ce, OIIO::TypeDesc::FLOAT, out)) return true;
      error_ = one_line(in_->geterror());
    } catch (const std::exception& e) {
      error_ = one_line(e.what());
    }
    return false;
  }

  bool read_deep(DeepSamples& out) override {
    try {
      OIIO::DeepData dd;
      if (!in_->read_native_deep_image(0, 0, dd)) {
        error_ = one_line(in_->geterror());
        return false;
      }
      const int nc = dd.channels();
      out.channelnames.clear();
      for (int c = 0; c < nc; ++c) out.channelnames.emplace_back(dd.channelname(c));
      const std::int64_t npix = dd.pixels();
      out.counts.resize(npix);
      out.first.resize(npix);
      std::size_t total = 0;
      for (std::int64_t p = 0; p < npix; ++p) {
        out.counts[p] = dd.samples(p);
        out.first[p] = total;
        total += static_cast<std::size_t>(std::max(0, out.counts[p]));
      }
      out.values.resize(total * nc);
      for (std::int64_t p = 0; p < npix; ++p)
        for (int s = 0; s < out.counts[p]; ++s)
          for (int c = 0; c < nc; ++c) out.values[(out.first[p] + s) * nc + c] = dd.deep_value(p, c, s);
      return true;
    } catch (const std::exception& e) {
      error_ = one_line(e.what());
      return false;
    }
  }

  std::string error() override {
    std::string e = error_.empty() ? one_line(in_->geterror()) : error_;
    error_.clear();
    return e.empty() ? global_error() : e;
  }

 private:
  std::unique_ptr<OIIO::ImageInput> in_;
  std::string error_;
};

class OiioModule final : public Module {
 public:
  std::unique_ptr<Input> open(const std::string& path, bool straight_alpha, std::string& error) override {
    try {
      OIIO::ImageSpec config;
      if (straight_alpha) config.attribute("oiio:UnassociatedAlpha", 1);
      auto in = OIIO::ImageInput::open(path, &config);
      if (!in) {
        error = global_error();
        return nullptr;
      }
      return std::make_unique<OiioInput>(std::move(in));
    } catch (const std::exception& e) {
      error = one_line(e.what());
      return nullptr;
    }
  }

  WriteResult write(const std::string& file, const std::string& format_path, const OutSpec& o, const float* pixels,
                    std::string& error) override {
    const OIIO::TypeDesc type = o.type == PixelType::uint8    ? OIIO::TypeDesc::UINT8
                                : o.type == PixelType::uint16 ? OIIO::TypeDesc::UINT16
                                : o.type == PixelType::half   ? OIIO::TypeDesc::HALF
                                                              : OIIO::TypeDesc::FLOAT;
    OIIO::ImageSpec spec(o.width, o.height, o.nchannels, type);
    if (!o.channelnames.empty()) spec.channelnames = o.channelnames;
    spec.alpha_channel = o.alpha_channel;
    for (const auto& [k, v] : o.string_attributes) spec.attribute(k, v);
    for (const auto& [k, v] : o.int_attributes) spec.attribute(k, v);
    std::unique_ptr<OIIO::ImageOutput> out;
    try {
      out = OIIO::ImageOutput::create(format_path);
    } catch (const std::exception& e) {
      error = one_line(e.what());
      return WriteResult::no_writer;
    }
    if (!out) {
      error = global_error();
      return WriteResult::no_writer;
    }
    try {
      if (out->open(file, spec) && out->write_image(OIIO::TypeDesc::FLOAT, pixels) && out->close())
        return WriteResult::ok;
      error = one_line(out->geterror());
    } catch (const std::exception& e) {
      error = one_line(e.what());
    }
    if (error.empty()) error = global_error();
    return WriteResult::failed;
  }
};

}  // namespace

}  // namespace dofkit::io::oiio

extern "C" __attribute__((visibility("default"))) dofkit::io::oiio::Module* dofkit_oiio_module_v1() {
  static dofkit::io::oiio::OiioModule module;
  return &module;
}
