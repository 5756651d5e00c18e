// Colour sanitation before rendering (rules in sanitize.hpp).
#include "render/sanitize.hpp"

#include <atomic>
#include <cmath>
#include <limits>

#include "core/clones.hpp"
#include "core/parallel.hpp"

namespace dofkit::detail {

namespace {

constexpr float kMinNormal = std::numeric_limits<float>::min();

// One colour sample → its sanitary value. Written as comparisons only (no fpclassify) so the
// clean-check loop below vectorises; NaN fails every comparison and lands on 0.
inline float clean_rgb(float v) {
  if (v > kMaxColorValue) return kMaxColorValue;    // also +inf
  if (v < -kMaxColorValue) return -kMaxColorValue;  // also −inf
  if (v >= kMinNormal || v <= -kMinNormal) return v;
  return 0.0f;  // NaN, ±0, subnormal
}

inline float clean_alpha(float a) {
  if (a >= 1.0f) return 1.0f;  // also +inf
  if (a >= kMinNormal) return a;
  return 0.0f;  // NaN, negative, zero, subnormal
}

inline bool same_bits(float a, float b) { return a == b && std::signbit(a) == std::signbit(b); }

// Rows are checked/copied in parallel; each chunk writes only its own rows and the change
// count is an integer sum, so the result does not depend on the partition.
constexpr int kGrainRows = 32;

}  // namespace

// One loop over the four streams, the planes read side by side, with bitwise & accumulation
// and no early exit so that it vectorises; compiled for AVX-512F / AVX2 / baseline.
DOFKIT_CLONES
bool rgba_row_is_sanitary(const float* __restrict r, const float* __restrict g, const float* __restrict b,
                          const float* __restrict a, int n) {
  int ok = 1;
  for (int x = 0; x < n; ++x)
    ok &= static_cast<int>(sample_is_sanitary(r[x], false)) & static_cast<int>(sample_is_sanitary(g[x], false)) &
          static_cast<int>(sample_is_sanitary(b[x], false)) & static_cast<int>(sample_is_sanitary(a[x], true));
  return ok != 0;
}

bool color_is_sanitary(const Image& rgba) {
  if (rgba.channels() != 4) return true;  // validate_frame reports the shape error
  return rect_is_sanitary(rgba, 0, 0, rgba.width(), rgba.height());
}

bool rect_is_sanitary(const Image& rgba, int x0, int y0, int w, int h) {
  std::atomic<bool> dirty{false};
  core::parallel_for(
      h,
      [&](int r0, int r1) {
        for (int y = y0 + r0; y < y0 + r1 && !dirty.load(std::memory_order_relaxed); ++y) {
          if (!rgba_row_is_sanitary(rgba.row(0, y) + x0, rgba.row(1, y) + x0, rgba.row(2, y) + x0, rgba.row(3, y) + x0,
                                    w))
            dirty.store(true, std::memory_order_relaxed);
        }
      },
      kGrainRows);
  return !dirty.load();
}

std::size_t sanitize_color(const Image& rgba, Image& out) {
  out.resize(rgba.width(), rgba.height(), rgba.channels());
  std::atomic<std::size_t> changed{0};
  const int w = rgba.width();
  core::parallel_for(
      rgba.height(),
      [&](int y0, int y1) {
        std::size_t n = 0;
        for (int y = y0; y < y1; ++y)
          for (int c = 0; c < rgba.channels(); ++c) {
            const float* in = rgba.row(c, y);
            float* o = out.row(c, y);
            for (int x = 0; x < w; ++x) {
              const float v = c == 3 ? clean_alpha(in[x]) : clean_rgb(in[x]);
              n += !same_bits(v, in[x]);
              o[x] = v;
            }
          }
        changed.fetch_add(n, std::memory_order_relaxed);
      },
      kGrainRows);
  return changed.load();
}

const Frame& sanitized_frame(const Frame& frame, Frame& scratch) {
  bool clean = color_is_sanitary(frame.color);
  for (const Image& l : frame.layer_color) clean = clean && color_is_sanitary(l);
  if (clean) return frame;
  sanitize_color(frame.color, scratch.color);
  scratch.depth = frame.depth;  // copy-assign reuses scratch's allocation when it fits
  scratch.layer_color.resize(frame.layer_color.size());
  for (std::size_t l = 0; l < frame.layer_color.size(); ++l)
    sanitize_color(frame.layer_color[l], scratch.layer_color[l]);
  scratch.layer_depth = frame.layer_depth;
  return scratch;
}

}  // namespace dofkit::detail
