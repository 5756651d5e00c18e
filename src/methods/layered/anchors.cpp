#include "methods/layered/anchors.hpp"

#include <cmath>
#include <limits>

namespace dofkit::detail::layered {

double stacked_sigma(int n) {
  const double m = n;
  return std::sqrt(m * (m + 1) * (2 * m + 1) / 6.0);
}

namespace {
// Fewest steps n >= 1 whose unit-scale anchor σ̂_n / c reaches `extreme_px`; 0 in focus.
int steps_needed(double extreme_px, double c, double unit) {
  if (!(extreme_px > 0.5)) return 0;
  int n = 1;
  while (unit * stacked_sigma(n) / c < extreme_px && n < 64) ++n;
  return n;
}
}  // namespace

LayerPlan plan_layers(double near_px, double far_px, int max_layers, double c, double unit) {
  int nf = steps_needed(near_px, c, unit), nb = steps_needed(far_px, c, unit);
  if (max_layers < 3) max_layers = 3;
  auto scale_if = [&](double extreme, int n) {
    return n > 0 ? extreme * c / stacked_sigma(n) : std::numeric_limits<double>::infinity();
  };
  while (nf + nb + 1 > max_layers) {
    // Remove a layer from the side whose per-step σ would grow least.
    const double sf = nf > 1 ? scale_if(near_px, nf - 1) : std::numeric_limits<double>::infinity();
    const double sb = nb > 1 ? scale_if(far_px, nb - 1) : std::numeric_limits<double>::infinity();
    if (sf < sb) --nf; else --nb;
  }
  LayerPlan p;
  p.count = nf + nb + 1;
  p.focus = nf;
  p.scale_front = nf > 0 ? scale_if(near_px, nf) : 0.0;
  p.scale_back = nb > 0 ? scale_if(far_px, nb) : 0.0;
  p.anchor.resize(p.count);
  p.step_sigma.resize(p.count);
  p.total_sigma.resize(p.count);
  for (int k = 0; k < p.count; ++k) {
    const int n = k < p.focus ? p.focus - k : k - p.focus;
    const double s = k < p.focus ? p.scale_front : p.scale_back;
    p.step_sigma[k] = s * n;
    p.total_sigma[k] = s * stacked_sigma(n);
    const double r = p.total_sigma[k] / c;
    p.anchor[k] = k < p.focus ? r : -r;
  }
  return p;
}

// Matte (our resolution of S4's ω / ω̂, algorithms.md §5.3 [uncertain]): a fragment between
// two neighbouring anchors a_{k+1} < r < a_k is put *fully* into the farther layer k + 1 and
// with weight u = (r − a_{k+1}) / (a_k − a_{k+1}) into the nearer layer k. Composited
// front to back with "over", the copies cover u + (1 − u)·1 = 1, so an unblurred stack
// reproduces the input exactly, and after blurring the result is the u-weighted mix of the
// two layers' blurs — linear interpolation of the blur between anchors. Thus layer k holds
// [a_k, a_{k−1}] at weight 1 (its plateau, hard cut at the near end a_{k−1}: nothing nearer
// ever leaks into a farther layer) and a ramp 0 → 1 over (a_{k+1}, a_k). Boundary layers take
// everything beyond the outermost anchors.
//
// The catch (found against the ground truth): "over" is exact only where the blurred copies
// stay opaque. Where a fragment's neighbourhood is transparent once blurred — a thin bar, an
// object's silhouette — the blurred alphas are small, "over" is nearly a sum, and the fragment
// is counted 1 + u times: thin near objects come out too dark / too strong. Matte::nearest
// puts every fragment wholly into the layer of the nearest anchor, so each fragment is counted
// once whatever the blur; the price is a radius quantised to the anchors and seams where one
// continuous surface crosses from one layer into the next (each half's blurred edge is
// half-transparent, and 1/2 over 1/2 covers 3/4) — the fill under nearer content
// (inpaint.hpp, `under`) closes those.
float LayerPlan::weight(int k, float r) const {
  constexpr double inf = std::numeric_limits<double>::infinity();
  if (matte == Matte::nearest) {
    // Layer k holds [mid(a_{k+1}, a_k), mid(a_k, a_{k−1})).
    const double hi = k == 0 ? inf : 0.5 * (anchor[k - 1] + anchor[k]);
    const double lo = k == count - 1 ? -inf : 0.5 * (anchor[k] + anchor[k + 1]);
    return r >= lo && r < hi ? 1.0f : 0.0f;
  }
  const double near_end = k == 0 ? inf : anchor[k - 1];
  if (r > near_end) return 0.0f;
  if (r >= anchor[k] || k == count - 1) return 1.0f;
  const double far_end = anchor[k + 1];
  if (r <= far_end) return 0.0f;
  return static_cast<float>((r - far_end) / (anchor[k] - far_end));
}

double LayerPlan::near_limit(int k) const {
  if (k == 0) return std::numeric_limits<double>::infinity();
  return matte == Matte::nearest ? 0.5 * (anchor[k - 1] + anchor[k]) : anchor[k - 1];
}

}  // namespace dofkit::detail::layered
