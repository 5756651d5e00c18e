// The aperture footprint of `lens`: which share of the pixel at integer offset (dx, dy) from
// a source of radius ρ px the source's image covers, and the energy normaliser (the sum of
// those shares over the pixel grid, so every footprint carries exactly its source's energy).
// The circle with a one-pixel anti-aliased rim (the reference's disc), or an analytic aperture
// of the shared model (core/aperture.hpp: blades, rotation, curvature, anamorphic; not the
// cat's eye, which depends on the source's position, nor an aperture image). Everything else
// in lens reads the footprint only through this header (Shape, areas, taps).
#pragma once
#include <cmath>
#include <cstddef>
#include <vector>

#include "core/aperture.hpp"

namespace dofkit::detail::lens {

/// Coverage of the pixel at offset (dx, dy) px by the footprint of radius ρ px (ρ >= 0.5).
inline float coverage(float rho, float dx, float dy) {
  const float c = rho - std::sqrt(dx * dx + dy * dy) + 0.5f;
  return c <= 0.0f ? 0.0f : (c >= 1.0f ? 1.0f : c);
}

/// Rows a footprint of radius ρ reaches above and below its centre (and columns either side).
inline int reach(float rho) { return static_cast<int>(std::ceil(rho + 0.5f)) - 1; }

/// The footprint's shape: the circle above (no model, or the model's circle), or an analytic
/// aperture of the model, whose coverage is sat(lim(ρ) − T(dx, dy)) with the model's gauge T of
/// the source's field (near: the aperture turned by 180°). The model must outlive the Shape.
class Shape {
 public:
  Shape() = default;
  /// Throws Error(usage) for a model lens cannot draw (cat's eye, aperture image).
  explicit Shape(const core::ApertureModel* model);
  bool circle() const { return model_ == nullptr; }
  const core::ApertureModel* model() const { return model_; }
  float coverage(float rho, int dx, int dy, bool near) const {
    if (!model_) return lens::coverage(rho, static_cast<float>(dx), static_cast<float>(dy));
    return model_->shape_coverage(dx, dy, rho, near ? core::Field::near : core::Field::far);
  }
  int reach(float rho) const { return model_ ? model_->reach(rho) : lens::reach(rho); }
  /// Σ coverage over the integer grid (equal for both fields).
  double area(float rho) const;
  /// Whether two shapes draw the same footprints (tables made for one serve the other).
  bool same(const Shape& o) const;

 private:
  const core::ApertureModel* model_ = nullptr;
  ApertureShape key_;  // the model's shape, for same()
};

/// 1 / Σ coverage over the integer grid, tabulated at 1/32 px steps of ρ and interpolated
/// linearly (the sum is piecewise linear in ρ, so this is nearly exact).
class InverseArea {
 public:
  /// Covers radii up to rho_max (a new shape starts the table afresh).
  void prepare(float rho_max, const Shape& shape = Shape());
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
  Shape shape_;
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

/// The taps of radius index i per field (built on first use; not thread-safe: prepare() first).
class TapTable {
 public:
  /// Builds the taps of every index up to radius_index(rho_max) (a new shape starts afresh).
  void prepare(float rho_max, const Shape& shape = Shape());
  /// Far field (near = false) or near field; the circle's are the same.
  const Taps& at(int i, bool near) const {
    return taps_[near && !shape_.circle() ? 1 : 0][static_cast<std::size_t>(i)];
  }
  int size() const { return static_cast<int>(taps_[0].size()); }

 private:
  std::vector<Taps> taps_[2];
  Shape shape_;
};

/// The gauge T(dx, dy) of an analytic shape for |dx|, |dy| <= reach, per field, as rows of
/// `pitch` floats (column dx at row(dy) + dx); each row runs on past dx = reach for kTail
/// floats of a value whose coverage is 0 (SIMD kernels read whole vectors past a span).
class GaugeTable {
 public:
  static constexpr int kTail = 32;
  /// Fills the table for `shape` (not the circle) up to `reach` (kept when it already is).
  void prepare(const Shape& shape, int reach);
  int reach() const { return reach_; }
  std::ptrdiff_t pitch() const { return static_cast<std::ptrdiff_t>(pitch_); }
  const float* row(int dy, bool near) const {
    return data_.data() + (static_cast<std::size_t>(near) * (2 * reach_ + 1) + (dy + reach_)) * pitch_ + reach_;
  }

 private:
  int reach_ = -1;
  std::size_t pitch_ = 0;
  std::vector<float> data_;
  Shape shape_;
};

}  // namespace dofkit::detail::lens
