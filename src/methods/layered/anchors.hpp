// Layer plan of the layered method (docs/methods/layered.md): how many layers, where their
// anchors lie, and which Gaussian each recursion step applies.
//
// Everything is in *signed CoC space* (r px, near > 0) instead of depth: for a thin lens
// r(z) = K (z_F / z − 1) is monotonic in z, so matting on r with anchors r_k is the same as
// matting on z with anchors z_k = z_F K / (K + r_k) (S4 Eq. 2.5 in pixel form), and it works
// unchanged for every other monotonic CoC model (four-plane, StarCraft, Sterna blend).
//
// Layers are indexed front to back: 0 = nearest, K − 1 = farthest, k_focus = the in-focus
// layer. Step σ_k = s_side · |k − k_focus| (S4: σ_k = |k − k_focus| px; s_side ≤ 1 shrinks
// the steps so that the outermost anchor lands exactly on the scene's extreme CoC, s_side > 1
// stretches them when the user's layer cap is too small for unit steps). By the Gaussian
// semigroup a layer n steps from focus ends up blurred by
//   σ̂_n = s · sqrt(1² + 2² + … + n²) = s · sqrt(n (n + 1)(2n + 1) / 6)   (S4 Eq. 2.6, reconstructed)
// and its anchor CoC radius is σ̂_n / c with c = sigma_per_radius (S4's d_pix = 4σ with d the
// CoC *diameter* gives c = 1/2, which is also the σ whose variance equals a disc's: R²/4).
#pragma once
#include <vector>

namespace dofkit::detail::layered {

/// sqrt(1² + … + n²): the blur (in units of s) of a layer n steps from focus.
double stacked_sigma(int n);

struct LayerPlan {
  /// Width of the matte's ramp as a fraction of the gap between two anchors (see weight):
  /// 1 = S&W's ramp over the whole gap, 0 = each fragment wholly in its nearest anchor's layer.
  double band = 1.0;
  int count = 1;                    ///< K
  int focus = 0;                    ///< k_focus
  double scale_front = 0;           ///< s for the near side (px per step unit)
  double scale_back = 0;            ///< s for the far side
  std::vector<double> anchor;       ///< a_k, signed CoC radius px, strictly decreasing, a_focus = 0
  std::vector<double> step_sigma;   ///< σ_k, px, applied after compositing layer k (0 at focus)
  std::vector<double> total_sigma;  ///< σ̂_k, px: the blur layer k ends up with

  /// Matte ω_k(r) of a fragment with signed CoC r in layer k (see matting.hpp).
  float weight(int k, float r) const;
  /// Largest r (nearest) that layer k still holds at full weight; +inf for layer 0.
  double near_limit(int k) const;
};

/// Chooses K and k_focus from the extreme CoCs of the fragments: `near_px` = largest r (> 0 if
/// anything is in front of focus), `far_px` = largest −r. Each side gets the fewest layers
/// whose unit-step anchors reach its extreme; if that exceeds `max_layers` (>= 3), layers are
/// taken away one at a time from the side whose steps would grow least. A side whose extreme
/// is within the focus field (|r| <= 0.5) gets no layer; an all-in-focus scene gives K = 1.
/// `unit_sigma_px` is the step unit before scaling (S4: 1 px); smaller gives more, finer layers.
LayerPlan plan_layers(double near_px, double far_px, int max_layers, double sigma_per_radius = 0.5,
                      double unit_sigma_px = 1.0);

}  // namespace dofkit::detail::layered
