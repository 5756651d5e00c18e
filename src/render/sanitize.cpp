// Colour sanitation before rendering (rules in sanitize.hpp).
#include "render/sanitize.hpp"

#include <atomic>
#include <cmath>
#include <limits>

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

// True if a row holds a value that sanitising would change (sample_is_sanitary fails). The
// bitwise | accumulation (no early exit) lets the loop vectorise; compiled for AVX-512F /
// AVX2 / baseline.
__attribute__((target_clones("avx512f", "avx2", "default")))
bool row_has_unsanitary(const float* row, int w, bool alpha) {
  int bad = 0;
  for (int x = 0; x < w; ++x) bad |= !sample_is_sanitary(row[x], alpha);
  return bad != 0;
}

// Rows are checked/copied in parallel; each chunk writes only its own rows and the change
// count is an integer sum, so the result does not depend on the partition.
constexpr int kGrainRows = 32;

}  // namespace

bool row_is_sanitary(const float* row, int n, bool alpha) { return !row_has_unsanitary(row, n, alpha); }

bool color_is_sanitary(const Image& rgba) {
  if (rgba.channels() != 4) return true;  // validate_frame reports the shape error
  return rect_is_sanitary(rgba, 0, 0, rgba.width(), rgba.height());
}

bool rect_is_sanitary(const Image& rgba, int x0, int y0, int w, int h) {
  std::atomic<bool> dirty{false};
  core::parallel_for(h, [&](int r0, int r1) {
    for (int y = y0 + r0; y < y0 + r1 && !dirty.load(std::memory_order_relaxed); ++y) {
      // Bitwise & and | (no short-circuit branches) so the loops vectorise.
      bool bad = false;
      for (int c = 0; c < 3; ++c) bad |= row_has_unsanitary(rgba.row(c, y) + x0, w, false);
      bad |= row_has_unsanitary(rgba.row(3, y) + x0, w, true);
      if (bad) dirty.store(true, std::memory_order_relaxed);
    }
  }, kGrainRows);
  return !dirty.load();
}

std::size_t sanitize_color(const Image& rgba, Image& out) {
  out.resize(rgba.width(), rgba.height(), rgba.channels());
  std::atomic<std::size_t> changed{0};
  const int w = rgba.width();
  core::parallel_for(rgba.height(), [&](int y0, int y1) {
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
  }, kGrainRows);
  return changed.load();
}

const Frame& sanitized_frame(const Frame& frame, Frame& scratch) {
  bool clean = color_is_sanitary(frame.color);
  for (const Image& l : frame.layer_color) clean = clean && color_is_sanitary(l);
  if (clean) return frame;
  sanitize_color(frame.color, scratch.color);
  scratch.depth = frame.depth;  // copy-assign reuses scratch's allocation when it fits
  scratch.layer_color.resize(frame.layer_color.size());
  for (std::size_t l = 0; l < frame.layer_color.size(); ++l) sanitize_color(frame.layer_color[l], scratch.layer_color[l]);
  scratch.layer_depth = frame.layer_depth;
  return scratch;
}

}  // namespace dofkit::detail
