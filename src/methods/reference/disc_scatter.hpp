// Shared machinery of the two scatter methods (`reference` and the depth-blind `scatter`
// baseline): every source pixel spreads its colour over a disc of radius |r| with an
// anti-aliased edge (or over the footprint of the aperture model), energy-normalised so the
// footprint's weights sum to 1.
#pragma once
#include "core/aperture.hpp"
#include "dofkit/image.hpp"

namespace dofkit::detail {

class Progress;

struct DiscScatterOptions {
  /// true: depth-ordered compositing (the reference); false: one normalised sum that
  /// ignores depth (what common lens-blur filters do).
  bool depth_order = true;
  /// Relative inverse-depth difference over which a source goes from "same surface" to
  /// "in front of the receiver" (soft, so a continuous surface shows no seams).
  float depth_softness = 0.05f;
  /// SIMD hot loop (default) or the plain scalar one (the test oracle).
  bool simd = true;
  /// Refuse (Error(usage)) a frame whose discs need more pixel visits than this
  /// (scatter_work); RenderSettings::max_work. 0 = no limit.
  double max_work = 0;
  /// The aperture every source spreads over (core/aperture.hpp); null = the circle. An RGB
  /// aperture image takes one scatter per colour channel (alpha: the mean of the three).
  const core::ApertureModel* aperture = nullptr;
  /// Progress per band of rows, and cancellation (null: none; methods/method.hpp).
  Progress* progress = nullptr;
};

/// The work of scattering a CoC map, in pixel visits: Σ over sources of the receivers their
/// disc's bounding square holds, (2 ⌈ρ + 0.5⌉ − 1)² with ρ = max(|r|, 0.5). The scatter's time
/// is proportional to it (the bands visit each disc's rows across its whole width).
double scatter_work(const Image& coc);

/// colour: RGBA premultiplied; depth: z; coc: signed px. Writes RGBA into `out`.
void disc_scatter(const Image& colour, const Image& depth, const Image& coc, const DiscScatterOptions& opt, Image& out);

/// Weight-sum of a disc of radius r (px) sampled at pixel centres with the coverage
/// saturate(r − d + 0.5): the energy normaliser (exact, not π r²).
double disc_area(double r);

}  // namespace dofkit::detail
