// srgb8_code (io/srgb.hpp) against what it replaces: quantise(encode_srgb(v), 255), bit for
// bit — on every float within 4096 ulps of each of the 255 points where the code steps up (the
// only places where a rounding could differ), on a sweep of every 61st float in [0, 1], and
// on the special values. (Run once over all 1,065,353,217 floats in [0, 1] on 2026-11-23: no
// difference, 6.4 s of CPU; too slow for the sanitizer builds, so the suite keeps the sweep.)
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

#include "io/quantise.hpp"
#include "io/srgb.hpp"

using namespace dofkit;

namespace {

float float_of(std::uint32_t b) {
  float v;
  std::memcpy(&v, &b, 4);
  return v;
}

std::uint32_t bits_of(float v) {
  std::uint32_t b;
  std::memcpy(&b, &v, 4);
  return b;
}

std::uint32_t reference(float v) { return io::quantise(io::encode_srgb(v), 255.0f); }

}  // namespace

TEST(Srgb8, EqualsQuantisedEncodeAroundEveryStep) {
  long checked = 0, mismatches = 0;
  for (int k = 0; k < 255; ++k) {
    // linear value whose encoding is (k + ½) / 255: the code steps from k to k + 1 near it
    const double e = (k + 0.5) / 255.0;
    const double lin = e <= 0.04045 ? e / 12.92 : std::pow((e + 0.055) / 1.055, 2.4);
    const std::uint32_t centre = bits_of(static_cast<float>(lin));
    for (std::uint32_t b = centre - 4096; b <= centre + 4096; ++b) {
      const float v = float_of(b);
      ++checked;
      if (io::srgb8_code(v) != reference(v) && ++mismatches <= 5)
        ADD_FAILURE() << "v = " << v << " (bits " << b << "): " << int(io::srgb8_code(v)) << " vs " << reference(v);
    }
  }
  EXPECT_EQ(mismatches, 0);
  EXPECT_EQ(checked, 255L * 8193);
}

TEST(Srgb8, EqualsQuantisedEncodeOnASweepOfAllFloatsInZeroOne) {
  long mismatches = 0;
  int codes_seen[256] = {};
  for (std::uint32_t b = 0; b <= 0x3F800000u; b += 61) {
    const float v = float_of(b);
    const std::uint8_t c = io::srgb8_code(v);
    codes_seen[c] = 1;
    if (c != reference(v) && ++mismatches <= 5)
      ADD_FAILURE() << "v = " << v << ": " << int(c) << " vs " << reference(v);
  }
  EXPECT_EQ(mismatches, 0);
  int distinct = 0;
  for (int s : codes_seen) distinct += s;
  EXPECT_EQ(distinct, 256);
}

TEST(Srgb8, SpecialValues) {
  const float inf = std::numeric_limits<float>::infinity();
  for (float v : {0.0f, -0.0f, -1.0f, -inf, std::numeric_limits<float>::quiet_NaN(), 1e-45f, 1e-38f, 0.5f,
                  std::nextafter(1.0f, 0.0f), 1.0f, 1.5f, inf})
    EXPECT_EQ(io::srgb8_code(v), reference(v)) << v;
  EXPECT_EQ(io::srgb8_code(std::numeric_limits<float>::quiet_NaN()), 0);
  EXPECT_EQ(io::srgb8_code(inf), 255);
}
