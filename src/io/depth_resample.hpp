// A depth map at another resolution than its colour image (phone depth maps are a quarter of
// the photo's size or less): its size checked against the colour's, then resampled to it.
// docs/cli.md (--depth-upsample) has the measurement behind the default.
#pragma once
#include <string>

#include "dofkit/image.hpp"

namespace dofkit::io {

enum class DepthUpsample {
  nearest,        ///< the nearest depth sample (blocky, never a depth that is not in the file)
  bilinear,       ///< bilinear in inverse depth (1/z: linear in the CoC), edges blurred over the ratio
  guided,         ///< edge-aware, colour-guided: depth edges follow colour edges, no blend across them
  guided_filter,  ///< He et al.'s guided filter on the bilinear result (the measured alternative)
};
/// Parses nearest|bilinear|guided|guided-filter (Error(usage) naming --depth-upsample).
DepthUpsample parse_depth_upsample(const std::string& name);
/// The --depth-upsample name of a method.
const char* depth_upsample_name(DepthUpsample how);

/// Checks that a depth map of dw x dh can serve a colour image of cw x ch: the same size, or
/// smaller in both directions with the same aspect ratio (dh = ch·dw/cw within half a depth
/// pixel, either way) unless `stretch` (--depth-fit stretch: any smaller size, scaled per
/// axis). Throws Error(bad_input) naming `depth_path`, both sizes and the flag that helps.
void check_depth_fit(const std::string& depth_path, int dw, int dh, const std::string& color_path, int cw, int ch,
                     bool stretch);

/// `depth` (planar z, 1 plane, +inf allowed) resampled to `color`'s size (RGBA planes,
/// linear). Pixel centres are aligned (colour x ↦ depth (x + 0.5)·dw/cw − 0.5, clamped to the
/// edge samples). Every output pixel is computed on its own from the inputs, so the result is
/// the same for any thread count.
Image resample_depth(const Image& depth, const Image& color, DepthUpsample how);

/// The factor by which refine_depth reduces the map before bringing it back.
inline constexpr int kRefineFactor = 4;

/// `--depth-refine`: a soft depth map of the colour's size (a phone's, whose edges are blurred
/// into halos) re-snapped to the colour's edges: reduced kRefineFactor times (each sample the
/// mean 1/z of its footprint) and brought back by the `guided` upsampling, which takes every
/// pixel's depth from one side of an edge only. Detail finer than the factor is lost.
Image refine_depth(const Image& depth, const Image& color);

}  // namespace dofkit::io
