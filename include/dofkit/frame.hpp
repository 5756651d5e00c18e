// dofkit — the input of a render: colour + depth (+ optional hidden fragments).
#pragma once
#include <vector>

#include "dofkit/image.hpp"

namespace dofkit {

/// One RGB-D frame as a pinhole camera saw it.
struct Frame {
  /// Linear-light RGBA, premultiplied alpha, 4 planes, W × H. Opaque inputs have alpha 1.
  /// HDR values (> 1) are allowed.
  Image color;
  /// Planar depth `z` (scene units, metres by default) along the optical axis, 1 plane,
  /// W × H, z > 0. `+inf` means infinitely far and is valid.
  Image depth;
  /// Optional multi-fragment input (front to back) for methods that can use hidden
  /// surfaces (the layered method). `layer_color[i]` is RGBA premultiplied (4 planes),
  /// `layer_depth[i]` is z (1 plane); a missing fragment has alpha 0 and z = +inf.
  /// Layer 0 is the visible surface. Empty for ordinary single-layer input.
  std::vector<Image> layer_color;
  std::vector<Image> layer_depth;

  int width() const noexcept { return color.width(); }
  int height() const noexcept { return color.height(); }
  bool has_layers() const noexcept { return !layer_color.empty(); }
};

/// Checks that colour is 4-plane, depth is 1-plane of the same size, layers are consistent
/// and depth contains no NaN, zero or negative value. Throws Error(bad_input) naming the
/// first offending pixel and the count; `what` names the source (e.g. the file) in messages.
void validate_frame(const Frame& frame, const char* what = "frame");

}  // namespace dofkit
