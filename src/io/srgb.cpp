// sRGB transfer curve (see srgb.hpp).
#include "io/srgb.hpp"

#include <array>
#include <cmath>
#include <cstring>
#include <vector>

#include "io/quantise.hpp"

namespace dofkit::io {

namespace {

double srgb_to_linear(double v) { return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4); }
double linear_to_srgb(double v) { return v <= 0.0031308 ? v * 12.92 : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055; }

// Every 8- and 16-bit code is k/65535 for an integer k (8-bit: k = 257·v), so one 65536-entry
// table decodes both exactly.
const std::vector<float>& srgb_decode_table() {
  static const std::vector<float> table = [] {
    std::vector<float> t(65536);
    for (int k = 0; k < 65536; ++k) t[k] = static_cast<float>(srgb_to_linear(k / 65535.0));
    return t;
  }();
  return table;
}

std::uint32_t bits_of(float v) {
  std::uint32_t b;
  std::memcpy(&b, &v, 4);
  return b;
}

float float_of(std::uint32_t b) {
  float v;
  std::memcpy(&v, &b, 4);
  return v;
}

std::uint32_t reference_code(float v) { return quantise(encode_srgb(v), 255.0f); }

// The positive floats below 1.0 have bit patterns below 0x3F800000; a table entry covers the
// 2^16 patterns with the same top 16 bits.
constexpr std::uint32_t kOne = 0x3F800000u;
constexpr int kShift = 16;

struct Steps {
  std::array<float, 256> step{};    // step[k]: least float whose code is ≥ k (k = 1…255)
  std::vector<std::uint8_t> start;  // start[b >> 16]: the code of the least float there
  Steps() : start((kOne >> kShift) + 1) {
    for (int k = 1; k < 256; ++k) {
      std::uint32_t lo = 0, hi = kOne;  // code(lo) < k ≤ code(hi) (code(1.0) = 255)
      while (hi - lo > 1) {
        const std::uint32_t mid = lo + (hi - lo) / 2;
        (reference_code(float_of(mid)) >= static_cast<std::uint32_t>(k) ? hi : lo) = mid;
      }
      step[k] = float_of(hi);
    }
    for (std::uint32_t key = 0; key < start.size(); ++key)
      start[key] = static_cast<std::uint8_t>(reference_code(float_of(key << kShift)));
  }
};

const Steps& steps() {
  static const Steps s;
  return s;
}

}  // namespace

float encode_srgb(float v) {
  if (!(v > 0)) return 0.0f;
  if (v >= 1) return 1.0f;
  return static_cast<float>(linear_to_srgb(v));
}

float decode_srgb(float v) {
  if (!(v > 0)) return 0.0f;
  if (v >= 1) return 1.0f;
  return srgb_decode_table()[static_cast<std::size_t>(std::lround(v * 65535.0f))];
}

std::uint8_t srgb8_code(float v) {
  if (!(v > 0)) return 0;
  if (v >= 1) return 255;
  const Steps& s = steps();
  unsigned c = s.start[bits_of(v) >> kShift];
  while (c < 255 && v >= s.step[c + 1]) ++c;
  return static_cast<std::uint8_t>(c);
}

}  // namespace dofkit::io
