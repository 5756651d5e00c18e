#include "methods/lens/footprint.hpp"

#include <algorithm>

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

void InverseArea::prepare(float rho_max) {
  const int n = static_cast<int>(std::ceil(std::max(rho_max, 0.5f) * kSteps)) + 2;
  if (static_cast<int>(area_.size()) >= n) return;
  const int from = static_cast<int>(area_.size());
  area_.resize(n);
  for (int i = from; i < n; ++i) area_[i] = static_cast<float>(area_of(std::max(0.5, double(i) / kSteps)));
}

void TapTable::prepare(float rho_max) {
  const int n = radius_index(rho_max) + 1;
  const int from = size();
  if (n <= from) return;
  taps_.resize(n);
  for (int i = from; i < n; ++i) {
    const float rho = std::max(radius_of_index(i), 0.5f);
    Taps& t = taps_[i];
    t.n = reach(rho);
    const double area = area_of(rho);
    for (int dy = -t.n; dy <= t.n; ++dy) {
      int lo = 1, hi = 0;
      for (int dx = -t.n; dx <= t.n; ++dx)
        if (coverage(rho, static_cast<float>(dx), static_cast<float>(dy)) > 0.0f) {
          if (lo > hi) lo = dx;
          hi = dx;
        }
      t.x0.push_back(lo);
      t.len.push_back(hi - lo + 1 > 0 ? hi - lo + 1 : 0);
      t.off.push_back(static_cast<int>(t.w.size()));
      for (int dx = lo; dx <= hi; ++dx)
        t.w.push_back(static_cast<float>(coverage(rho, static_cast<float>(dx), static_cast<float>(dy)) / area));
    }
  }
}

}  // namespace dofkit::detail::lens
