// The depth slices of `lens` (see docs/methods/lens.md): anchors in signed-CoC space, each
// with the resolution level its discs are scattered at. A source between two anchors is split
// between their slices by hat weights (linear in its CoC), so sums over a slice interpolate
// linearly between anchors and a continuous surface shows no seam at a slice boundary.
#pragma once
#include <vector>

#include "methods/lens/footprint.hpp"

namespace dofkit::detail {
class Progress;
}

namespace dofkit::detail::lens {

struct LensOptions {
  /// Relative inverse-depth difference over which a source goes from "same surface" to
  /// "in front" (the reference's depth_softness).
  float depth_softness = 0.05f;
  /// Anchor spacing: max(slice_px, slice_rel·|a|) px of CoC between neighbouring anchors.
  float slice_px = 1.0f;
  float slice_rel = 0.15f;
  /// Sources with radius < 2·level_px (and highlights) are scattered exactly, one full-
  /// resolution footprint each, with the reference's per-pair depth order ("direct"); the
  /// others are merged per slice and scattered at resolution level L >= 1 (1/2^L of the frame
  /// in each direction), the largest L <= max_level with level_px·2^L <= the slice's smallest
  /// radius.
  float level_px = 3.0f;
  int max_level = 5;
  float direct_px() const { return 2.0f * level_px; }
  /// Highlights: a source of a reduced-resolution slice whose luminance is above highlight_abs
  /// and above highlight_rel times the mean of its 2^(L+2) block is scattered at full
  /// resolution (its disc's rim stays sharp).
  float highlight_abs = 1.0f;
  float highlight_rel = 4.0f;
  /// The footprint's shape (default: the circle).
  Shape shape;
  /// The hidden-background estimate (partial occlusion of a near blurred object).
  bool hidden = true;
  /// The SIMD / tiled path (default) or the plain one (the test oracle).
  bool simd = true;
  /// Progress per block / tile of the fast path (null: none; method.hpp).
  Progress* progress = nullptr;
};

struct SlicePlan {
  /// Signed CoC of each anchor (px, near > 0), strictly decreasing: slice 0 is the nearest.
  std::vector<float> anchor;
  /// Resolution level (>= 1) of each slice's merged sources, and of its hidden-background
  /// estimate.
  std::vector<int> level;
  int count() const { return static_cast<int>(anchor.size()); }
  /// The slice j that a CoC r falls in and the weight t of slice j + 1 (r between anchors j
  /// and j + 1; beyond the outermost anchors the nearest one takes everything, t = 0).
  void member(float r, int& j, float& t) const;
  /// member() through a table of 1/8 px bins (the same j and t): build_lookup() first.
  void build_lookup();
  void member_fast(float r, int& j, float& t) const {
    const int k = count();
    if (!(r < anchor[0])) {
      j = 0;
      t = 0.0f;
      return;
    }
    if (!(r > anchor[k - 1])) {
      j = k - 1;
      t = 0.0f;
      return;
    }
    j = lookup_[static_cast<std::size_t>((anchor[0] - r) * kBins)];
    while (j > 0 && anchor[j] < r) --j;
    while (j + 1 < k && anchor[j + 1] >= r) ++j;
    t = (anchor[j] - r) / (anchor[j] - anchor[j + 1]);
  }

 private:
  static constexpr float kBins = 8.0f;
  std::vector<int> lookup_;
};

/// Anchors covering the CoC range [−far_max, near_max] of the frame.
SlicePlan plan_slices(float near_max, float far_max, const LensOptions& opt);

}  // namespace dofkit::detail::lens
