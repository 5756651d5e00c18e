// Library-level input sanitation: what render() does to colour samples before any method
// sees them, so that no technique has to defend itself against non-finite numbers.
//
// Rules (docs/robustness.md explains the choices):
//   colour R, G, B:  NaN → 0;  ±inf → ±kMaxColorValue;  |v| > kMaxColorValue → ±kMaxColorValue;
//                    subnormal (0 < |v| < FLT_MIN) → 0.
//   alpha:           NaN → 0;  clamped to [0, 1];  subnormal → 0.
// Depth is *not* sanitised: NaN, zero or negative depth is an Error(bad_input) from
// validate_frame (the IO layer can turn them into +inf on request, `--invalid-depth far`);
// +inf depth is valid (infinitely far) and tiny positive depth simply reaches the CoC clamp.
#pragma once
#include <limits>

#include "dofkit/frame.hpp"
#include "dofkit/image.hpp"

namespace dofkit::detail {

/// Largest colour magnitude a method receives. Far above any physical radiance in any unit
/// a renderer writes (the sun's disc is ~1.6e9 cd/m²), yet small enough that a method may
/// sum ~1e8 such samples (a 4096 px disc) or square one without overflowing float (3.4e38).
inline constexpr float kMaxColorValue = 1e18f;

/// Whether one sample already satisfies the rules above (sanitising would leave it as it is):
/// ±0, or a normal number of magnitude <= kMaxColorValue (colour) / in [FLT_MIN, 1] (alpha).
/// Comparisons only, so loops over it vectorise; NaN fails every comparison.
inline bool sample_is_sanitary(float v, bool alpha) {
  constexpr float kMinNormal = std::numeric_limits<float>::min();
  if (alpha) return (v == 0.0f) | ((v >= kMinNormal) & (v <= 1.0f));
  const float m = v < 0.0f ? -v : v;
  return (v == 0.0f) | ((m >= kMinNormal) & (m <= kMaxColorValue));
}

/// sample_is_sanitary for n consecutive pixels given as their four plane rows r, g, b and
/// alpha a (vectorised; the one row check of render()'s scan and of the methods that check
/// the colour in their own passes).
bool rgba_row_is_sanitary(const float* r, const float* g, const float* b, const float* a, int n);

/// color_is_sanitary for the w × h rectangle at (x0, y0) of a 4-plane image.
bool rect_is_sanitary(const Image& rgba, int x0, int y0, int w, int h);

/// True if every sample of a 4-plane RGBA image already satisfies the rules above (then
/// render() passes the caller's frame through untouched, with no copy).
bool color_is_sanitary(const Image& rgba);

/// Writes the sanitised copy of `rgba` into `out` (resized to match; its allocation is
/// reused when large enough). Returns the number of samples that were changed.
std::size_t sanitize_color(const Image& rgba, Image& out);

/// If `frame`'s colour (or any layer colour) breaks the rules, fills `scratch` with a copy
/// of the frame whose colour planes are sanitised and returns it; otherwise returns `frame`
/// itself. `scratch` keeps its buffers between calls (Renderer steady state).
const Frame& sanitized_frame(const Frame& frame, Frame& scratch);

}  // namespace dofkit::detail
