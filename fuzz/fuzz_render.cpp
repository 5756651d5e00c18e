// libFuzzer target for render() with random parameters on small frames (issue 37).
//
// The input is read as a stream of choices: the frame's size (1..12 px each), the method, the
// CoC model and each of its parameters, the clamp, the reference width, the thread count, a
// debug view, --set values for the method's own parameters, then the pixels (colour and
// depth samples). Numbers come from a table of hostile values (0, -0, subnormals, 1e-320,
// FLT_MAX, 1e300, ±inf, NaN, ordinary ones) or straight from the bytes, so every range
// check of the camera models and the parameters is crossed from both sides.
// Bugs: an exception that is not dofkit::Error, an internal error, a message of more than
// one line, an image of the wrong size or with a non-finite sample, a CoC map with a NaN.
#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "dofkit/render.hpp"
#include "fuzz_common.hpp"

using namespace dofkit;

namespace {

class Stream {
 public:
  Stream(const std::uint8_t* d, std::size_t n) : d_(d), n_(n) {}
  std::uint8_t byte() { return i_ < n_ ? d_[i_++] : 0; }
  double raw_double() {
    std::uint64_t bits = 0;
    for (int k = 0; k < 8; ++k) bits = bits << 8 | byte();
    double v;
    std::memcpy(&v, &bits, 8);
    return v;
  }
  // A value from the hostile table, an ordinary scaled one, or 8 raw bytes.
  double number(double typical) {
    static const double kTable[] = {0.0,
                                    -0.0,
                                    1e-320,
                                    -1e-320,
                                    std::numeric_limits<double>::denorm_min(),
                                    std::numeric_limits<double>::min(),
                                    1e-30,
                                    1e-6,
                                    0.001,
                                    0.1,
                                    0.5,
                                    1,
                                    2,
                                    4,
                                    50,
                                    1e6,
                                    1e9,
                                    1e30,
                                    1e300,
                                    std::numeric_limits<float>::max(),
                                    std::numeric_limits<double>::max(),
                                    std::numeric_limits<double>::infinity(),
                                    -std::numeric_limits<double>::infinity(),
                                    std::numeric_limits<double>::quiet_NaN(),
                                    -1,
                                    -1e9};
    const std::uint8_t b = byte();
    if (b < 128) return kTable[b % (sizeof kTable / sizeof kTable[0])];
    if (b < 240) return typical * (b - 127) / 32.0;
    return raw_double();
  }
  float sample() {
    const std::uint8_t b = byte();
    static const float kTable[] = {0.0f,
                                   -0.0f,
                                   std::numeric_limits<float>::denorm_min(),
                                   std::numeric_limits<float>::max(),
                                   -std::numeric_limits<float>::max(),
                                   std::numeric_limits<float>::infinity(),
                                   -std::numeric_limits<float>::infinity(),
                                   std::numeric_limits<float>::quiet_NaN(),
                                   1e-30f,
                                   1e30f};
    if (b >= 246) return kTable[b - 246];
    return b / 64.0f;
  }
  bool done() const { return i_ >= n_; }

 private:
  const std::uint8_t* d_;
  std::size_t n_, i_ = 0;
};

CameraModel camera(Stream& s) {
  CameraModel cam;
  switch (s.byte() % 5) {
    case 0:
      cam.model = BlurAtInfinity{s.number(4), s.number(8)};
      break;
    case 1:
      cam.model = ThinLens{s.number(50), s.number(2.8), s.number(5), s.number(36)};
      break;
    case 2:
      cam.model = FourPlane{s.number(0.5), s.number(2), s.number(4),        s.number(20),
                            s.number(16),  s.number(8), (s.byte() & 1) != 0};
      break;
    case 3:
      cam.model = StarCraft{s.number(5), s.number(0.5), s.number(5), s.number(1), s.number(16)};
      break;
    default:
      cam.model = NearFarBlend{s.number(1), s.number(5), s.number(5), s.number(10), s.number(12)};
  }
  const std::uint8_t flags = s.byte();
  if (flags & 1) cam.max_coc_px = s.number(10);
  if (flags & 2) cam.reference_width_px = s.number(640);
  return cam;
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  fuzz::setup();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 4) return 0;
  Stream s(data, size);
  const int w = 1 + s.byte() % 12, h = 1 + s.byte() % 12;
  const std::vector<MethodInfo> all = methods();
  const MethodInfo& m = all[s.byte() % all.size()];
  RenderSettings settings;
  settings.method = m.name;
  settings.camera = camera(s);
  settings.threads = s.byte() % 4;
  const std::uint8_t extras = s.byte();
  if ((extras & 1) && !m.debug_views.empty()) settings.debug_view = m.debug_views[s.byte() % m.debug_views.size()].name;
  if (extras & 2) settings.max_work = s.number(1e7);
  for (const ParamInfo& p : m.params) {
    const std::uint8_t b = s.byte();
    if (b < 128) continue;
    static const char* kValues[] = {"0",   "1",    "-1", "0.5", "2",   "8", "64", "1e9",   "1e-320", "nan",
                                    "inf", "-inf", "on", "off", "yes", "x", "",   "1e400", "0x10",   "3.5"};
    // A default that depends on another key: one of its cases' values (the text lists them all).
    const std::string def =
        p.default_cases.empty() ? p.default_value : p.default_cases[b % p.default_cases.size()].second;
    settings.params[p.name] = b < 200 ? def : kValues[b % (sizeof kValues / sizeof kValues[0])];
  }
  Frame frame;
  frame.color = Image(w, h, 4);
  frame.depth = Image(w, h, 1);
  for (float& v : frame.color.data()) v = s.sample();
  for (float& v : frame.depth.data()) {
    v = s.sample() * 4;
    if (!(v > 0) && !(s.byte() & 1)) v = 1.0f;  // mostly valid depth, some invalid (a bad-input error)
  }
  RenderResult r;
  if (!fuzz::expect_ok_or_refused("render", [&] { r = render(frame, settings); })) return 0;
  fuzz::check_result(m.name, r, w, h);
  for (float v : r.coc.data())
    if (std::isnan(v)) fuzz::bug("method " + m.name + ": NaN in the CoC map");
  return 0;
}
