// The passes of the fused Gaussian stack (render_gaussian_fused, fused.cpp), in the order they
// run: the code pass (fused_code.cpp), one composite pass per non-empty layer
// (fused_composite.cpp) and the final composite (fused_final.cpp). The oracle of all of them
// together is impl=plain (matting.cpp, inpaint.cpp, composite.cpp); tests/layered compare
// whole renders bit for bit and count that the fused path ran (fused_render_count).
#pragma once
#include <cstdint>

#include "dofkit/image.hpp"
#include "methods/layered/anchors.hpp"
#include "methods/layered/fast_rows.hpp"
#include "methods/layered/fused_layer.hpp"

namespace dofkit::detail::layered {

// ---------------------------------------------------------------------------------------
// Code pass (fused_code.cpp).

/// Where the code pass writes: per pixel (w·h) the first layer j0 with a non-zero matte, its
/// matte w0 and the code j0 | (second layer j0 + 1 at weight 1) << 5 | hk << 6 (hole from
/// layer hk on); per row block of kBlock pixels (nb·h) the layers present and the smallest /
/// largest hk; per row block and layer (16·nb·h) the matte spans and the hole spans (see
/// FusedLayer for each).
struct CodePlanes {
  float* w0;
  std::uint16_t* code;
  std::uint32_t* bpres;
  std::uint32_t* bhk;
  std::uint32_t* bspan;
  std::uint32_t* bhole;
  int nb;
};
/// What the code pass found: ok false if a pixel's mattes do not have the expected form (the
/// caller then renders layer by layer); otherwise the bit masks of the layers with a non-zero
/// matte somewhere and of the layers with a hole somewhere.
struct CodeSummary {
  bool ok = false;
  std::uint32_t nonempty = 0, holes = 0;
};
/// The codes of one fragment per pixel (colour, CoC) under `plan`; holes only with do_fill.
CodeSummary code_pass(const Image& color, const Image& coc, const LayerPlan& plan, bool do_fill, const CodePlanes& out);

// ---------------------------------------------------------------------------------------
// Composite pass (fused_composite.cpp).

/// The pull of the next layer's pyramid levels 1 and (if cv2 is non-null) 2, done in the same
/// pass as a composite (the two read the same input rows, once from memory; level 2 reads
/// level 1's rows while they are in cache).
struct NextPull {
  const FusedLayer* L = nullptr;
  Image* cv = nullptr;
  Image* cwt = nullptr;
  Image* cv2 = nullptr;
  Image* cwt2 = nullptr;
};

/// Where a composite pass writes, exactly one of: full resolution (may be the accumulator's
/// own full image), or reduced by composite.cpp's 2×2 box (half) or 4×4 box (quarter).
struct CompositeTarget {
  Image* full = nullptr;
  Image* half = nullptr;
  Image* quarter = nullptr;
};

/// One composite step of an accumulator A: C = L over A (layer_in_front) or A over L (A
/// absent: C = L), written to `dst`; `next` is the following layer's pull, if any.
struct CompositeStep {
  const FusedLayer& layer;
  const AccRows& acc;
  bool layer_in_front;
  CompositeTarget dst;
  NextPull next;
};
void composite_pass(const CompositeStep& step);

/// Row y, columns [x0, x0 + n) of one row block.
struct RowBlock {
  int y, x0, n;
};
/// The accumulator a fused row is composited with: mode 0 none (the row is the layer), 1 rows
/// of +0, 2 the up-sampling of `half` (reduced by `factor`, rows cached in `cache`, zero map
/// `zm` optional).
struct AccInput {
  int mode = 0;
  HCache* cache = nullptr;
  const Image* half = nullptr;
  int factor = 2;
  const ZeroMap* zm = nullptr;
};
/// Row rb.y of block rb.x0 of layer L (FusedLayer::get's values: the matte inside the layer's
/// span, the fill inside its hole span) in one kernel (crow_row_simd), "over" (front) or
/// under `acc`. For a layer whose fill, if any, has a pyramid level (L.l1).
void fused_row(const FusedLayer& L, RowBlock rb, HCache& fill_cache, const AccInput& acc, bool front,
               float (*c)[kBlock]);

// ---------------------------------------------------------------------------------------
// Final composite (fused_final.cpp).

/// out = F over L_focus over B (final_composite's arithmetic), the focus layer computed on
/// the fly (null: none).
void final_pass(const FusedLayer* focus, const AccRows& back, const AccRows& front, Image& out);

}  // namespace dofkit::detail::layered
