// The table of numeric ranges (see dofkit/ranges.hpp).
//
// How the bounds were chosen: wide enough for any real camera and image, narrow enough that
// no product of parameters overflows a double and no value is subnormal. The thin lens's
// K = (W / S) f² / (2 N (z_F − f)) stays finite (W ≤ 2^34 px, S ≥ 0.1 mm, f ≤ 1e5 mm, N ≥ 0.1:
// the numerator is below 1.7e24 and z_F − f cannot round to 0 above f ≥ 0.1 mm), and so do
// K · z_F / z for any float depth, radii times the reference-width scale (≤ 1e9 · 2^34) and
// every plane distance (≤ 1e30 m) in the models' ramps.
#include "dofkit/ranges.hpp"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <sstream>

#include "dofkit/error.hpp"

namespace dofkit {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// name, unit, min, max, min_open, max_open, integer, infinity_ok, note
const std::vector<NumericRange> kRanges = {
    // Camera (validate(CameraModel) uses these rows too).
    {"--f-number", "", 0.1, 1e4, false, false, false, false, ""},
    {"--focal-length", "mm", 0.1, 1e5, false, false, false, false, ""},
    {"--sensor-width", "mm", 0.1, 1e4, false, false, false, false, ""},
    {"--focus", "m", 1e-6, 1e30, false, false, false, false, "with --f-number: farther than the focal length"},
    {"--blur-at-infinity", "px", 0, 1e9, false, false, false, false, ""},
    {"--planes", "m", 1e-6, 1e30, false, false, false, true, "each of NB < NS <= FS < FB; only FB may be inf"},
    {"--near-radius", "px", 0, 1e9, false, false, false, false, ""},
    {"--far-radius", "px", 0, 1e9, false, false, false, false, ""},
    {"--starcraft", "m", 0, 1e30, false, false, false, false,
     "FOCUS > 0, FULL >= 0, NONE > FULL; AMOUNT (the fourth value) is its own row"},
    {"--starcraft AMOUNT", "", 0, 1e6, false, false, false, false, ""},
    {"--near-far", "m", 0, 1e30, false, false, false, false, "each of NB < NE <= FB < FE"},
    {"--max-radius", "px", 0, 1e9, false, false, false, false, ""},
    {"--max-coc", "px", 1e-3, 1e9, false, false, false, false, ""},
    {"--reference-width", "px", 1, 1e9, false, false, false, false, ""},
    {"--focus-at", "px", 0, 1e9, false, false, true, false, "X,Y inside the image"},
    // Depth conventions.
    {"--fov-deg", "deg", 0, 180, true, true, false, false, ""},
    {"--disparity-scale", "", 1e-9, 1e12, false, false, false, false, "scene units x disparity"},
    {"--depth-scale", "", 1e-9, 1e12, false, false, false, false, "file value x scale = metres"},
    {"--clip", "", 1e-9, 1e30, false, false, false, true, "NEAR < FAR; only FAR may be inf"},
    // Resources and files.
    {"--threads", "", 0, 1024, false, false, true, false, "0 = all hardware threads"},
    {"view --port", "", 0, 65535, false, false, true, false, "0 = a free port"},
    {"--max-pixels", "px", 1, 17179869184.0, false, false, true, false, "width x height of every input"},
    {"--max-memory", "MiB", 16, 1073741824.0, false, false, true, false,
     "default: 3/4 of the machine's memory (or of the cgroup's limit)"},
    {"--max-work", "", 1e6, 1e18, false, false, false, false,
     "pixel visits of the reference / scatter disc scatter (default 2e11)"},
    {"--max-layers", "", 1, 64, false, false, true, false, ""},
    {"--png-level", "", 0, 9, false, false, true, false, ""},
    {"--bits", "", 8, 32, false, false, true, false, "EXR 16 or 32, PNG 8 or 16, JPEG 8, TIFF 8, 16 or 32"},
    {"--size", "px", 1, 16384, false, false, true, false, "each of W and H in WxH"},
    // scene, quality, demo, bench.
    {"scene --samples", "", 0, 1e6, false, false, true, false, "0 = the scene's own"},
    {"scene --layers", "", 0, 64, false, false, true, false, ""},
    // The aperture and highlight flags (render, scene, quality); the library's validate() of
    // ApertureShape / HighlightRecovery checks the same or looser bounds.
    {"--blades", "", 0, 16, false, false, true, false, "0 = circle, else 3 to 16"},
    {"--blade-rotation", "deg", -3600, 3600, false, false, false, false, "scene: also --rotation"},
    {"--blade-curvature", "", 0, 1, false, false, false, false, ""},
    {"--anamorphic", "", 0.1, 10, false, false, false, false, ""},
    {"--cat-eye", "", 0, 1, false, false, false, false, ""},
    {"--highlight-threshold", "", 0, 1, false, true, false, false, ""},
    {"--highlight-boost", "", 0, 1e6, false, false, false, false, ""},
    {"scene --focus", "m", 0, 1e6, false, false, false, false, "0 = the scene's own"},
    {"scene --blur-at-infinity", "px", 0, 1e6, false, false, false, false, "0 = the scene's own"},
    {"quality --samples", "", 0, 1e6, false, false, true, false, "0 = the scene's own"},
    {"quality --radii", "m", 1e-6, 1e6, false, false, false, false, "AO radii (--effect ao)"},
    {"quality --layers", "", 0, 16, false, false, true, false, ""},
    {"demo --samples", "", 0, 1e6, false, false, true, false, "0 = the scene's own"},
    {"demo --layers", "", 0, 16, false, false, true, false, ""},
    {"bench --iterations", "", 1, 1000, false, false, true, false, ""},
};

// A number as the help and the messages print it: whole numbers below 1e7, or with more
// digits than an exponent saves, in full (10000, 17179869184); others in the shortest form
// that reads back as the same double, exponents without '+' or leading zeros (1e9, 1e-6,
// 1e-320 — not 9.99988867183e-321).
std::string num(double v) {
  char buf[48];
  int p = 1;
  for (; p <= 17; ++p) {
    std::snprintf(buf, sizeof buf, "%.*g", p, v);
    if (std::strtod(buf, nullptr) == v || std::isnan(v)) break;
  }
  if (std::isfinite(v) && v == std::floor(v) && std::fabs(v) < 1e15 && (std::fabs(v) < 1e7 || p > 4)) {
    std::snprintf(buf, sizeof buf, "%.0f", v);
    return buf;
  }
  std::string s = buf;
  const auto e = s.find('e');
  if (e != std::string::npos) {
    std::string exp = s.substr(e + 1);
    const bool neg = !exp.empty() && exp[0] == '-';
    if (!exp.empty() && (exp[0] == '+' || exp[0] == '-')) exp.erase(0, 1);
    while (exp.size() > 1 && exp[0] == '0') exp.erase(0, 1);
    s = s.substr(0, e + 1) + (neg ? "-" : "") + exp;
  }
  return s;
}

// The flag part of a row's name ("scene --layers" → "--layers", "--starcraft AMOUNT" →
// "--starcraft AMOUNT").
std::string flag_of(const NumericRange& r) {
  const std::string n = r.name;
  const auto dash = n.find("--");
  return dash == std::string::npos ? n : n.substr(dash);
}

}  // namespace

const std::vector<NumericRange>& numeric_ranges() { return kRanges; }

const NumericRange& numeric_range(const std::string& name) {
  for (const NumericRange& r : kRanges)
    if (name == r.name) return r;
  throw_internal("no numeric range for " + name);
}

std::string range_text(const NumericRange& r) {
  std::string s;
  if (r.min_open && r.max_open)
    s = "more than " + num(r.min) + " and less than " + num(r.max);
  else if (r.min_open)
    s = "more than " + num(r.min) + " up to " + num(r.max);
  else if (r.max_open)
    s = num(r.min) + " up to less than " + num(r.max);
  else
    s = num(r.min) + " to " + num(r.max);
  if (*r.unit) s += std::string(" ") + r.unit;
  if (r.integer) s += " (whole number)";
  if (r.infinity_ok) s += ", or inf";
  return s;
}

double check_number(const std::string& name, double v, const std::string& shown) {
  const NumericRange& r = numeric_range(name);
  const bool inside =
      std::isfinite(v) && (r.min_open ? v > r.min : v >= r.min) && (r.max_open ? v < r.max : v <= r.max);
  // A subnormal is inside a range that starts at 0, and still refused (it carries nothing a
  // user can mean, and its arithmetic runs 10-100x slower).
  const bool subnormal = std::fpclassify(v) == FP_SUBNORMAL;
  const bool ok = (inside && !subnormal && (!r.integer || v == std::floor(v))) || (r.infinity_ok && v == kInf);
  if (!ok)
    throw_usage(flag_of(r) + " " + (shown.empty() ? num(v) : shown) + ": must be " + range_text(r) +
                (subnormal ? " (a subnormal number is not a value)" : ""));
  return v;
}

double parse_number(const std::string& name, const std::string& text) {
  const NumericRange& r = numeric_range(name);
  // Decimal only: digits, one point, an exponent; a sign; "inf" spelled out. strtod alone
  // would also take hexadecimal, "nan" and "infinity" in any case.
  std::string t = text;
  while (!t.empty() && (t.front() == ' ' || t.front() == '\t')) t.erase(t.begin());
  while (!t.empty() && (t.back() == ' ' || t.back() == '\t')) t.pop_back();
  const auto fail = [&]() -> double {
    throw_usage(flag_of(r) + " " + text + ": not a number (expected " + range_text(r) + ")");
  };
  if (t == "inf" || t == "+inf") return check_number(name, kInf, text);
  if (t == "-inf") return check_number(name, -kInf, text);
  bool digit = false;
  for (std::size_t i = 0; i < t.size(); ++i) {
    const char c = t[i];
    if (c >= '0' && c <= '9')
      digit = true;
    else if (!(c == '.' || c == 'e' || c == 'E' || c == '+' || c == '-'))
      return fail();
  }
  if (!digit) return fail();
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(t.c_str(), &end);
  if (end != t.c_str() + t.size()) return fail();
  // Overflow (±HUGE_VAL) and underflow (0 or a subnormal) are outside every range: the range
  // check says so with the bounds.
  return check_number(name, v, text);
}

std::string numeric_ranges_markdown() {
  std::string s = "| parameter | range | notes |\n|---|---|---|\n";
  for (const NumericRange& r : kRanges)
    s += std::string("| `") + r.name + "` | " + range_text(r) + " | " + r.note + " |\n";
  return s;
}

}  // namespace dofkit
