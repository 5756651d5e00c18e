// Helpers shared by the IO tests: scratch folders, reference sRGB curves, raw OIIO writes
// (to create inputs that dofkit itself would never write, e.g. odd channel names).
#pragma once
#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "dofkit/error.hpp"
#include "dofkit/image.hpp"

namespace dofkit::test {

namespace fs = std::filesystem;

/// A fresh, empty folder per test, removed afterwards.
class ScratchDir {
 public:
  ScratchDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    std::string name = std::string(info ? info->test_suite_name() : "t") + "_" + (info ? info->name() : "t");
    for (char& c : name)
      if (c == '/') c = '_';
    path_ = fs::temp_directory_path() / ("dofkit-test-" + std::to_string(::getpid()) + "-" + name);
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~ScratchDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  std::string operator/(const std::string& file) const { return (path_ / file).string(); }
  const fs::path& path() const { return path_; }
  /// Names of every entry in the folder (to check that no temporary file was left behind).
  std::vector<std::string> entries() const {
    std::vector<std::string> v;
    for (const auto& e : fs::directory_iterator(path_)) v.push_back(e.path().filename().string());
    std::sort(v.begin(), v.end());
    return v;
  }

 private:
  fs::path path_;
};

inline double ref_srgb_to_linear(double v) { return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4); }
inline double ref_linear_to_srgb(double v) {
  v = std::clamp(v, 0.0, 1.0);
  return v <= 0.0031308 ? v * 12.92 : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055;
}

/// Writes interleaved float data with the given channel names and pixel type through OIIO.
inline void raw_write(const std::string& path, int w, int h, const std::vector<std::string>& names,
                      const std::vector<float>& interleaved, OIIO::TypeDesc type = OIIO::TypeDesc::FLOAT,
                      bool unassociated = false) {
  OIIO::ImageSpec spec(w, h, static_cast<int>(names.size()), type);
  spec.channelnames = names;
  spec.alpha_channel = -1;
  for (int c = 0; c < static_cast<int>(names.size()); ++c)
    if (names[c] == "A") spec.alpha_channel = c;
  spec.z_channel = -1;
  if (unassociated) spec.attribute("oiio:UnassociatedAlpha", 1);
  auto out = OIIO::ImageOutput::create(path);
  ASSERT_TRUE(out) << OIIO::geterror();
  ASSERT_TRUE(out->open(path, spec)) << out->geterror();
  ASSERT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, interleaved.data())) << out->geterror();
  ASSERT_TRUE(out->close());
}

/// A test RGBA premultiplied image with smooth gradients, HDR values and varying alpha.
inline Image test_rgba(int w, int h, bool opaque = false, bool hdr = false) {
  Image img(w, h, 4);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float a = opaque ? 1.0f : 0.1f + 0.9f * static_cast<float>(x) / (w - 1);
      const float r = static_cast<float>(x) / (w - 1), g = static_cast<float>(y) / (h - 1);
      const float b = 0.5f + 0.4f * std::sin(0.3f * x + 0.2f * y);
      const float s = hdr ? 4.0f : 1.0f;
      img.at(x, y, 0) = r * s * a;
      img.at(x, y, 1) = g * a;
      img.at(x, y, 2) = b * a;
      img.at(x, y, 3) = a;
    }
  return img;
}

inline void write_bytes(const std::string& path, const std::string& bytes) {
  std::ofstream f(path, std::ios::binary);
  f.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}
inline std::string read_bytes(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), {});
}

/// The bits of a float (bit-for-bit comparisons that also tell NaNs and −0 apart).
inline std::uint32_t bits_of(float v) {
  std::uint32_t b;
  std::memcpy(&b, &v, 4);
  return b;
}

/// The message of the Error `fn` throws, which must be a one-line bad_input error; a test
/// failure (and "") if it throws none.
inline std::string bad_input_message(const std::function<void()>& fn) {
  try {
    fn();
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::bad_input) << e.what();
    const std::string m = e.what();
    EXPECT_EQ(m.find('\n'), std::string::npos) << m;
    return m;
  }
  ADD_FAILURE() << "no error thrown";
  return {};
}

/// Values of two float arrays whose bits differ (all of them if the lengths differ).
inline std::size_t bit_differences(const std::vector<float>& a, const std::vector<float>& b) {
  if (a.size() != b.size()) return std::max(a.size(), b.size()) + 1;
  std::size_t d = 0;
  for (std::size_t i = 0; i < a.size(); ++i) d += bits_of(a[i]) != bits_of(b[i]);
  return d;
}

/// Samples of two images whose bits differ, over every plane (all of them if the sizes or
/// channel counts differ).
inline std::size_t bit_differences(const Image& a, const Image& b) {
  if (!a.same_size(b) || a.channels() != b.channels()) return std::max(a.data().size(), b.data().size()) + 1;
  std::size_t d = 0;
  for (int c = 0; c < a.channels(); ++c)
    for (std::size_t i = 0; i < a.plane_size(); ++i) d += bits_of(a.plane(c)[i]) != bits_of(b.plane(c)[i]);
  return d;
}

/// A whole file's bytes.
inline std::string slurp(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), {});
}

/// Samples for the writers' tests: smooth ramps (what filters and deflate are for), noise, and values a few ulps
/// either side of every rounding boundary k + ½ of the 8-bit and 16-bit scales, plus
/// out-of-range values and ±∞.
inline std::vector<float> boundary_samples(int w, int h, int c, int seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<float> v(static_cast<std::size_t>(w) * h * c);
  for (std::size_t i = 0; i < v.size(); ++i) {
    const std::size_t px = i / c;
    const int x = static_cast<int>(px % w), y = static_cast<int>(px / w);
    v[i] = (y % 3 == 2) ? u(rng) : 0.5f + 0.5f * std::sin(0.013f * x + 0.029f * y + static_cast<float>(i % c));
  }
  std::vector<float> edges;
  for (int scale : {255, 65535})
    for (int k = 0; k < scale; k += scale == 255 ? 1 : 257) {
      const float centre = (k + 0.5f) / scale;
      float lo = centre, hi = centre;
      for (int d = 0; d < 3; ++d) {
        lo = std::nextafter(lo, 0.0f);
        hi = std::nextafter(hi, 1.0f);
        edges.push_back(lo);
        edges.push_back(hi);
      }
      edges.push_back(centre);
    }
  for (float s : {-1.0f, -1e-9f, -0.0f, 0.0f, 1.0f, 1.0000001f, 2.0f, 1e30f, std::numeric_limits<float>::infinity(),
                  -std::numeric_limits<float>::infinity()})
    edges.push_back(s);
  for (std::size_t i = 0; i < edges.size() && i * 5 < v.size(); ++i) v[i * 5] = edges[i];
  return v;
}

/// OpenImageIO's float → integer rule (io/quantise.hpp) written out, independently of the writer: round half away from
/// zero of v·max in float (0.49999997 stores 0), clamped to [0, max]; NaN stores 0.
inline std::vector<long> quantise_rule(const std::vector<float>& v, int bits) {
  const float max = bits == 8 ? 255.0f : 65535.0f;
  std::vector<long> q;
  q.reserve(v.size());
  for (float f : v) {
    const float x = f * max;
    q.push_back(std::isnan(x) ? 0 : static_cast<long>(std::clamp(std::round(x), 0.0f, max)));
  }
  return q;
}

/// A file's samples as OpenImageIO reads them into T (uint8 or uint16), straight alpha.
template <typename T>
std::vector<T> read_oiio(const std::string& path, int* w = nullptr, int* h = nullptr, int* c = nullptr) {
  OIIO::ImageSpec config;
  config.attribute("oiio:UnassociatedAlpha", 1);  // the stored values, not premultiplied
  auto in = OIIO::ImageInput::open(path, &config);
  if (!in) ADD_FAILURE() << path << ": " << OIIO::geterror();
  if (!in) return {};
  const OIIO::ImageSpec& s = in->spec();
  if (w) *w = s.width;
  if (h) *h = s.height;
  if (c) *c = s.nchannels;
  std::vector<T> px(static_cast<std::size_t>(s.width) * s.height * s.nchannels);
  const OIIO::TypeDesc t = sizeof(T) == 1 ? OIIO::TypeDesc::UINT8 : OIIO::TypeDesc::UINT16;
  EXPECT_TRUE(in->read_image(0, 0, 0, s.nchannels, t, px.data())) << in->geterror();
  return px;
}

/// The same, 8 or 16 bits, as long.
inline std::vector<long> read_as_long(const std::string& path, int bits, int* w = nullptr, int* h = nullptr,
                                      int* c = nullptr) {
  std::vector<long> out;
  if (bits == 8) {
    for (auto q : read_oiio<std::uint8_t>(path, w, h, c)) out.push_back(q);
  } else {
    for (auto q : read_oiio<std::uint16_t>(path, w, h, c)) out.push_back(q);
  }
  return out;
}

}  // namespace dofkit::test
