#include "methods/layered/anchors.hpp"

#include <algorithm>
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
    if (sf < sb)
      --nf;
    else
      --nb;
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

// Matte (our resolution of S4's ω / ω̂, docs/methods/layered.md): a fragment between
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
// is counted 1 + u times: thin near objects come out too strong. `band` < 1 squeezes the ramp
// into the middle band·gap of the gap (u' = saturate((u − 1/2)/band + 1/2); the farther copy
// is dropped once u' = 1), so outside that band each fragment is counted once. band = 0 puts
// every fragment wholly into the layer of its nearest anchor; the price is seams where a
// continuous surface crosses from one layer into the next (each half's blurred edge is
// half-transparent and 1/2 over 1/2 covers 3/4), which the narrow ramp of band = 1/4 closes.
//
// At r = a_{k−1} exactly (notably r = 0, the focus anchor, common for in-focus surfaces) the
// fragment belongs to layer k − 1 only: the farther layer's weight 1 stops *before* u' = 1.
// (Until this was written the boundary was inclusive, which put every exactly-in-focus
// fragment into the first back layer as well and blurred it into halos: −1.2 dB edge PSNR on
// occluder.)
namespace {
// The ramp u ∈ [0, 1] across a gap squeezed into a band of relative width `band` around the
// gap's middle (band 0: a step at u = 1/2).
double banded(double u, double band) {
  if (band <= 0) return u >= 0.5 ? 1.0 : 0.0;
  const double v = (u - 0.5) / band + 0.5;
  return v <= 0 ? 0.0 : (v >= 1 ? 1.0 : v);
}
}  // namespace

float LayerPlan::weight(int k, float r) const {
  if (k > 0 && r > anchor[k]) {
    // Farther layer of the gap (a_k, a_{k−1}): weight 1 until the nearer layer holds it whole.
    const double u = (r - anchor[k]) / (anchor[k - 1] - anchor[k]);
    if (u > 1) return 0.0f;
    return banded(u, band) < 1.0 ? 1.0f : 0.0f;
  }
  if (r >= anchor[k] || k == count - 1) return 1.0f;
  // Nearer layer of the gap (a_{k+1}, a_k).
  const double u = (r - anchor[k + 1]) / (anchor[k] - anchor[k + 1]);
  if (u <= 0) return 0.0f;
  return static_cast<float>(banded(u, band));
}

double LayerPlan::near_limit(int k) const {
  if (k == 0) return std::numeric_limits<double>::infinity();
  // Smallest u at which the nearer layer k − 1 holds the fragment whole.
  const double u = band <= 0 ? 0.5 : std::min(1.0, 0.5 + 0.5 * band);
  return anchor[k] + u * (anchor[k - 1] - anchor[k]);
}

}  // namespace dofkit::detail::layered
