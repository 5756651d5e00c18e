// Fast forms of the layered method's per-layer passes (issue 8). Same arithmetic as the plain
// forms in matting.cpp, inpaint.cpp and composite.cpp, in the same order, so the output is
// bit-identical to impl=plain (tests/layered/fast_test.cpp); what changes is the data flow:
//  * matting evaluates the matte inline (no call per fragment) and reduces its flags without
//    per-row vectors;
//  * push-pull keeps its pyramid in the workspace, builds level 1 straight from the layer and
//    its hole mask (no copy of level 0, no weight plane at full resolution), pushes with the
//    fixed 2× bilinear weights row by row, and fills level 0 in the same pass that applies
//    the opaque / under rules, writing into the layer;
//  * the accumulator takes the first layer by swap (no copy), keeps a half-resolution blur
//    at half resolution until the next composite or read, and up-samples it inside that
//    composite (one pass instead of an up-sampling pass plus an "over" pass);
//  * the final F over focus over B is one pass.
// The definitions are one file per pass (docs/methods/layered.md lists them): fast_matting.cpp,
// fast_push_pull.cpp, fast_accumulator.cpp, and the fused stack's fused.cpp (order of passes),
// fused_code.cpp, fused_layer.cpp, fused_pull.cpp, fused_composite.cpp, fused_final.cpp.
#pragma once
#include <cstdint>
#include <string>

#include "dofkit/image.hpp"
#include "methods/layered/anchors.hpp"
#include "methods/layered/matting.hpp"
#include "methods/method.hpp"

namespace dofkit::detail::layered {

/// matte_layer with the same result; `hole` points to width·height bytes (or is null).
MatteStats matte_layer_fast(const Fragments& frags, const LayerPlan& plan, int k, Image& layer, std::uint8_t* hole);

/// push_pull_fill with the same result; the pyramid levels come from `ws` (keys "layered.pp*").
void push_pull_fill_fast(Image& layer, const std::uint8_t* hole, bool opaque, bool under, Workspace& ws);

/// Accumulator with the same result (see composite.hpp); buffers come from the workspace
/// under keys prefixed by `name`.
class FastAccumulator {
 public:
  FastAccumulator(Workspace& ws, std::string name, bool half_res, bool quarter_res = false)
      : ws_(ws), name_(std::move(name)), half_res_(half_res), quarter_res_(quarter_res) {}
  bool has_content() const { return has_; }
  /// acc = layer over acc. `layer` may be swapped with the accumulator's buffer (its
  /// contents are unspecified afterwards).
  void composite_front(Image& layer);
  /// acc = acc over layer.
  void composite_back(Image& layer);
  void blur(double sigma) {
    if (has_) pending_var_ += sigma * sigma;
  }
  /// Applies the pending blur; afterwards the content is either full() or, if
  /// half_pending(), the bilinear 2× (or 4×, factor()) up-sampling of half().
  void settle();
  bool half_pending() const { return lazy_up_; }
  const Image& full() const { return *full_; }
  const Image& half() const { return *half_; }
  int factor() const { return factor_; }  ///< reduction of half(): 2 or 4
  /// The full-resolution image (up-sampled if needed); for debug views.
  const Image& resolved();

 private:
  void combine(Image& layer, bool layer_in_front);
  Workspace& ws_;
  std::string name_;
  bool half_res_;
  bool quarter_res_;
  int factor_ = 2;
  bool has_ = false;
  bool lazy_up_ = false;
  double pending_var_ = 0;
  Image* full_ = nullptr;
  Image* half_ = nullptr;
};

/// out = F over L_focus over B (the same as copying L_focus, or zeros if `focus` is null, and
/// applying the two "over"s of composite.cpp). F, B may be without content.
void final_composite(FastAccumulator& front, const Image* focus, FastAccumulator& back, int w, int h, Image& out);

/// The whole psf=gaussian stack for one fragment per pixel (RGB-D input) in fused passes,
/// bit-identical to the plain form: one code pass stores, per pixel, the (at most two
/// adjacent) layers with a non-zero matte and from which layer on the pixel is a hole;
/// then per non-empty layer one pass builds push-pull level 1 from the matte computed on the
/// fly and one pass computes L_k (matte or fill) over/under the accumulator (up-sampled on
/// the fly) and writes the composite at the resolution of the blur that follows (2×2 box
/// straight into the half-resolution buffer); no full-resolution layer is ever stored.
/// The final F over L_focus over B computes the focus layer on the fly. Returns false,
/// having written nothing, where it does not apply (several fragments per pixel, a debug
/// view requested, a pixel whose mattes do not have the expected form); the caller then
/// uses the per-layer fast path.
bool render_gaussian_fused(const MethodContext& ctx, const Fragments& frags, const LayerPlan& plan, bool half_res,
                           bool quarter_res, bool do_fill, bool fill_under, Image& out);

/// How many frames render_gaussian_fused has rendered in this process (lets the tests check
/// that the fused path, not the fallback, produced what they compare).
std::uint64_t fused_render_count();

/// How many band blocks (4 rows × 256 columns) the fused composite passes have written as +0
/// without computing them: an empty layer over an accumulator known to be +0 there (lets the
/// tests check that the shortcut is taken).
std::uint64_t zero_block_count();

/// How many (coarse row, block)s of the reduced accumulators' zero maps have been marked as
/// holding tiny samples (0 < |x| < 2^-96), whose readers multiply through double (lets the
/// tests check that the fast-vs-plain comparisons cover those kernels).
std::uint64_t tiny_block_count();

}  // namespace dofkit::detail::layered
