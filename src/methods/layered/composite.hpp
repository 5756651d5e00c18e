// Blurring and composition of the layer stack (docs/methods/layered.md).
#pragma once
#include "dofkit/image.hpp"

namespace dofkit::detail::layered {

/// dst = front over back (premultiplied): dst = front + (1 − front.a) · back. dst may alias
/// either input.
void over(const Image& front, const Image& back, Image& dst);

/// The reduced-resolution part of a Gaussian blur of σ px at 1/f resolution, f = 2 (used
/// for σ >= 4) or 4 (σ >= 8): `low` = the f×f box reduction of img (edge-clamped), blurred
/// by the Gaussian whose variance, added to the box's and to that of the bilinear
/// up-sampling by f the caller then does, gives exactly σ².
void reduce_and_blur(const Image& img, int f, double sigma, Image& low);

/// A recursively blurred accumulator (S4's F or B). Blurs are deferred and merged: by the
/// Gaussian semigroup, H(σ₂) ∗ H(σ₁) ∗ X = H(sqrt(σ₁² + σ₂²)) ∗ X, so consecutive steps with
/// nothing composited in between (empty layers) cost one blur, not several.
class Accumulator {
 public:
  /// half_res: blurs of σ >= 4 px run at half resolution (same variance, a quarter the work);
  /// with quarter_res as well, those of σ >= 8 px at quarter resolution (a sixteenth).
  explicit Accumulator(bool half_res = true, bool quarter_res = false)
      : half_res_(half_res), quarter_res_(quarter_res) {}
  bool has_content() const { return has_; }
  /// img = layer over img (layer in front); first call takes the layer as is.
  void composite_front(const Image& layer);
  /// img = img over layer (the accumulator is in front: the near-field recursion).
  void composite_back(const Image& layer);
  /// Records a blur of σ px to be applied before the next composite or read.
  void blur(double sigma) {
    if (has_) pending_var_ += sigma * sigma;
  }
  /// Applies any pending blur and returns the image.
  const Image& resolved();
  double pending_sigma() const;

 private:
  void flush();
  Image img_;
  bool has_ = false;
  bool half_res_ = true;
  bool quarter_res_ = false;
  double pending_var_ = 0;
};

}  // namespace dofkit::detail::layered
