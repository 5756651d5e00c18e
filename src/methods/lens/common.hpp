// Pieces of `lens` that the plain and the fast path share, so that both compute the same model.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "methods/lens/footprint.hpp"
#include "methods/lens/plan.hpp"

namespace dofkit::detail::lens {

inline float luminance(float r, float g, float b) { return 0.2126f * r + 0.7152f * g + 0.0722f * b; }

/// Per pixel: 1 where the source is scattered directly at full resolution — its radius is
/// below opt.direct_px(), or it is a highlight: luminance above opt.highlight_abs and above
/// opt.highlight_rel times the mean luminance of the aligned block of side 2^m >= 2ρ that
/// holds it (a source much brighter than the area its footprint covers: reduced resolution
/// would soften the rim of its bokeh). rho and lum: one value per pixel.
std::vector<std::uint8_t> direct_sources(const float* rho, const float* lum, int w, int h, const LensOptions& opt);

/// The radius index (footprint.hpp) of a merged source at level L whose members' mean radius
/// is rho px: the box merge and the bilinear read-back blur by a variance of 4^L / 4 px² per
/// axis, so the footprint is shrunk to keep the total (a disc of radius ρ has ρ² / 4).
inline int merged_radius_index(float rho, int level) {
  const float cell = static_cast<float>(1 << level);
  const float r = std::sqrt(std::max(rho * rho - cell * cell, 0.25f)) / cell;
  return radius_index(std::max(r, 0.5f));
}

/// clamp(lround(v), 0, hi) (the reference's, without the libm call).
inline int round_clamp(float v, int hi) {
  if (!(v >= 0.5f)) return 0;
  const float t = v + 0.5f;
  return t >= static_cast<float>(hi) ? hi : static_cast<int>(t);
}

/// Fixed sample offsets in the unit disc for the hidden-background estimate: the concentric
/// map of a g × g grid (g = 4 or 8).
class HiddenPattern {
 public:
  explicit HiddenPattern(int count);
  int count() const { return static_cast<int>(x_.size()); }
  float x(int i) const { return x_[static_cast<std::size_t>(i)]; }
  float y(int i) const { return y_[static_cast<std::size_t>(i)]; }

 private:
  std::vector<float> x_, y_;
};

/// The reference's composite of one receiver: a = F rgba, F weight, B rgba, B weight; est =
/// the hidden-background estimate as (rgba · mass, mass) (mass <= 1e-6: none); hid = hidden
/// fragments of deep input scattered onto the receiver (rgba, weight; weight 0: none), which
/// fill the uncovered share before the estimate does; src = the receiver's own colour (used
/// only when no footprint reaches it). Writes rgba into out and returns the uncovered share
/// that was filled.
inline float composite(const float* a, const float* est, const float* hid, float s0, float s1, float s2, float s3,
                       float* out) {
  const bool has_est = est[4] > 1e-6f, has_hid = hid[4] > 0.0f;
  const float fw = a[4], bw = a[9];
  const float missing = has_est || has_hid ? std::max(0.0f, 1.0f - fw - bw) : 0.0f;
  // The fill colour: the hidden fragments where they cover, the estimate for the rest.
  float fill[4] = {0, 0, 0, 0};
  if (missing > 0.0f) {
    const float rest = has_est ? std::max(0.0f, 1.0f - hid[4]) : 0.0f;
    const float inv = 1.0f / (hid[4] + rest);
    const float est_scale = has_est ? rest / est[4] : 0.0f;
    for (int ch = 0; ch < 4; ++ch) fill[ch] = (hid[ch] + est_scale * est[ch]) * inv;
  }
  const float src[4] = {s0, s1, s2, s3};
  const float fs = fw > 1.0f ? 1.0f / fw : 1.0f;
  const float keep = 1.0f - std::min(fw, 1.0f);
  for (int ch = 0; ch < 4; ++ch) {
    float v;
    if (bw + missing > 0) {
      const float back = (a[5 + ch] + missing * fill[ch]) / (bw + missing);
      v = a[ch] * fs + keep * back;
    } else if (fw > 0) {
      v = a[ch] / fw;
    } else {
      v = src[ch];
    }
    out[ch] = v;
  }
  return missing;
}

}  // namespace dofkit::detail::lens
