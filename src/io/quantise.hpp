// Float → integer sample conversion of the direct PNG and JPEG writers: OpenImageIO's rule.
#pragma once
#include <cmath>
#include <cstdint>

namespace dofkit::io {

/// round(v · max) with halves away from zero, the product rounded to float first, clamped to
/// [0, max]; NaN gives 0. This is what OpenImageIO's writers store for a large image (its
/// vector conversion; tested against it in tests/io/png_write_test.cpp). x − ⌊x⌋ is exact
/// below 2^23, so this is roundf without the libm call.
inline std::uint32_t quantise(float v, float max) {
  const float x = v * max;
  if (!(x > 0.0f)) return 0;  // also NaN
  if (x >= max) return static_cast<std::uint32_t>(max);
  const float t = std::floor(x);
  return static_cast<std::uint32_t>(t) + (x - t >= 0.5f ? 1u : 0u);
}

}  // namespace dofkit::io
