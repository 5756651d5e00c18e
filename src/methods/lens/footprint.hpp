// The aperture footprint of `lens`: which share of the pixel at integer offset (dx, dy) from
// a source of radius ρ px the source's image covers, and the energy normaliser (the sum of
// those shares over the pixel grid, so every footprint carries exactly its source's energy).
// Today a circle with a one-pixel anti-aliased rim (the reference's disc); everything else in
// lens reads the footprint only through this header (coverage, area, taps), so another
// aperture shape plugs in here.
#pragma once
#include <cmath>
#include <vector>

namespace dofkit::detail::lens {

/// Coverage of the pixel at offset (dx, dy) px by the footprint of radius ρ px (ρ >= 0.5).
inline float coverage(float rho, float dx, float dy) {
  const float c = rho - std::sqrt(dx * dx + dy * dy) + 0.5f;
  return c <= 0.0f ? 0.0f : (c >= 1.0f ? 1.0f : c);
}

/// Rows a footprint of radius ρ reaches above and below its centre (and columns either side).
inline int reach(float rho) { return static_cast<int>(std::ceil(rho + 0.5f)) - 1; }

/// 1 / Σ coverage over the integer grid, tabulated at 1/32 px steps of ρ and interpolated
/// linearly (the sum is piecewise linear in ρ, so this is nearly exact).
class InverseArea {
 public:
  /// Covers radii up to rho_max.
  void prepare(float rho_max);
  float operator()(float rho) const {
    const float f = rho * kSteps;
    int i = static_cast<int>(f);
    if (i >= static_cast<int>(area_.size()) - 1) i = static_cast<int>(area_.size()) - 2;
    const float t = f - static_cast<float>(i);
    return 1.0f / (area_[i] + (area_[i + 1] - area_[i]) * t);
  }

 private:
  static constexpr int kSteps = 32;
  std::vector<float> area_;
};

/// Radii of merged (reduced-resolution) sources are quantised to 1/16 px of their level, so
/// their weights come from a table of footprints.
constexpr int kRadiusSteps = 16;
inline int radius_index(float rho) { return static_cast<int>(rho * kRadiusSteps + 0.5f); }
inline float radius_of_index(int i) { return static_cast<float>(i) / kRadiusSteps; }

/// The weights coverage / area of one quantised radius, row by row: row dy (−n … n) covers
/// columns x0[dy + n] … x0 + len − 1 (relative to the centre), weights at w + off[dy + n].
struct Taps {
  int n = 0;
  std::vector<int> x0, len, off;
  std::vector<float> w;
};

/// The taps of radius index i (built on first use; not thread-safe: prepare() first).
class TapTable {
 public:
  /// Builds the taps of every index up to radius_index(rho_max).
  void prepare(float rho_max);
  const Taps& operator[](int i) const { return taps_[static_cast<std::size_t>(i)]; }
  int size() const { return static_cast<int>(taps_.size()); }

 private:
  std::vector<Taps> taps_;
};

}  // namespace dofkit::detail::lens
