// Matting of the input fragments into one depth layer (docs/methods/layered.md).
#pragma once
#include <cstdint>
#include <vector>

#include "dofkit/image.hpp"
#include "methods/layered/anchors.hpp"

namespace dofkit::detail::layered {

/// The input fragments, front to back at every pixel: premultiplied RGBA and signed CoC (px).
/// A single RGB-D frame is one fragment per pixel.
struct Fragments {
  std::vector<const Image*> color;
  std::vector<const Image*> coc;
  int width() const { return color.front()->width(); }
  int height() const { return color.front()->height(); }
};

struct MatteStats {
  bool empty = true;   ///< no pixel has alpha > 0
  bool holes = false;  ///< some pixel is marked as a hole
};

/// L_k = (I_0 ω_k(r_0)) over (I_1 ω_k(r_1)) over … (premultiplied "over", front to back).
/// If `hole` is non-null it receives 1 where the pixel's *visible* fragment is nearer than
/// layer k's plateau (it belongs to a nearer layer, so layer k is unknown — disoccluded —
/// there) and 0 elsewhere. Returns whether the layer is empty and has holes.
MatteStats matte_layer(const Fragments& frags, const LayerPlan& plan, int k, Image& layer,
                       std::vector<std::uint8_t>* hole);

/// Largest r and largest −r over all fragments with alpha > 0 (0 if none on a side).
/// check_colour: the same pass, which reads every fragment's alpha, also tests every sample
/// of the fragments' 4 colour planes against render()'s sanitation rules
/// (render/sanitize.hpp, sample_is_sanitary; see MethodContext::colour_dirty) and returns
/// false if one fails (near_px / far_px are then unspecified). Otherwise returns true.
bool coc_extremes(const Fragments& frags, double& near_px, double& far_px, bool check_colour = false);

}  // namespace dofkit::detail::layered
