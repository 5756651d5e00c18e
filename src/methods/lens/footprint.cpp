#include "methods/lens/footprint.hpp"

#include <algorithm>

#include "dofkit/error.hpp"

namespace dofkit::detail::lens {

namespace {
double area_of(double rho) {
  const int n = reach(static_cast<float>(rho));
  double sum = 0;
  for (int dy = -n; dy <= n; ++dy)
    for (int dx = -n; dx <= n; ++dx)
      sum += coverage(static_cast<float>(rho), static_cast<float>(dx), static_cast<float>(dy));
  return sum;
}
}  // namespace

Shape::Shape(const core::ApertureModel* model) {
  if (!model) return;
  // (The model's circle may carry a cat's eye: refused too.)
  if (model->has_image())
    throw_usage(
        "lens: draws blades, rotation, curvature and anamorphic apertures, not an aperture image (use "
        "--method reference)");
  if (model->position_dependent())
    throw_usage(
        "lens: draws blades, rotation, curvature and anamorphic apertures, not the cat's eye (use --method "
        "reference)");
  if (model->is_circle()) return;
  model_ = model;
  key_ = model->shape();
}

double Shape::area(float rho) const {
  if (!model_) return area_of(rho);
  return model_->weight_sum(rho, core::Field::far);
}

bool Shape::same(const Shape& o) const {
  if (circle() || o.circle()) return circle() == o.circle();
  return key_.blades == o.key_.blades && key_.rotation_deg == o.key_.rotation_deg &&
         key_.curvature == o.key_.curvature && key_.anamorphic == o.key_.anamorphic;
}

void InverseArea::prepare(float rho_max, const Shape& shape) {
  if (!shape_.same(shape)) area_.clear();
  shape_ = shape;
  const int n = static_cast<int>(std::ceil(std::max(rho_max, 0.5f) * kSteps)) + 2;
  if (static_cast<int>(area_.size()) >= n) return;
  const int from = static_cast<int>(area_.size());
  area_.resize(n);
  for (int i = from; i < n; ++i)
    area_[i] = static_cast<float>(shape.area(static_cast<float>(std::max(0.5, double(i) / kSteps))));
}

void TapTable::prepare(float rho_max, const Shape& shape) {
  if (!shape_.same(shape)) {
    taps_[0].clear();
    taps_[1].clear();
  }
  shape_ = shape;
  const int n = radius_index(rho_max) + 1;
  const int from = size();
  if (n <= from) return;
  for (int field = 0; field < (shape.circle() ? 1 : 2); ++field) {
    const bool near = field == 1;
    taps_[field].resize(n);
    for (int i = from; i < n; ++i) {
      const float rho = std::max(radius_of_index(i), 0.5f);
      Taps& t = taps_[field][i];
      t.n = shape.reach(rho);
      // The circle's area as it always was (area_of); a shape's: its exact grid sum.
      const double area = shape.circle() ? area_of(rho) : shape.area(rho);
      for (int dy = -t.n; dy <= t.n; ++dy) {
        int lo = 1, hi = 0;
        for (int dx = -t.n; dx <= t.n; ++dx)
          if (shape.coverage(rho, dx, dy, near) > 0.0f) {
            if (lo > hi) lo = dx;
            hi = dx;
          }
        t.x0.push_back(lo);
        t.len.push_back(hi - lo + 1 > 0 ? hi - lo + 1 : 0);
        t.off.push_back(static_cast<int>(t.w.size()));
        for (int dx = lo; dx <= hi; ++dx) t.w.push_back(static_cast<float>(shape.coverage(rho, dx, dy, near) / area));
      }
    }
  }
}

void GaugeTable::prepare(const Shape& shape, int reach) {
  if (shape_.same(shape) && reach_ == reach && !shape.circle()) return;
  shape_ = shape;
  reach_ = reach;
  const int side = 2 * reach + 1;
  pitch_ = static_cast<std::size_t>(side) + kTail;
  // Past the footprint: a gauge no radius covers (coverage sat(lim − T) = 0).
  data_.assign(2 * static_cast<std::size_t>(side) * pitch_, 1e30f);
  for (int field = 0; field < 2; ++field)
    for (int dy = -reach; dy <= reach; ++dy) {
      float* r = data_.data() + (static_cast<std::size_t>(field) * side + (dy + reach)) * pitch_ + reach;
      for (int dx = -reach; dx <= reach; ++dx)
        r[dx] = shape.model()->gauge(dx, dy, field ? core::Field::near : core::Field::far);
    }
}

}  // namespace dofkit::detail::lens
