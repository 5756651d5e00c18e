// Accumulator and final composite, fast form (oracle: composite.cpp's Accumulator and over(),
// bit for bit; tests/layered). Inputs: the matted, filled layers in depth order; output: the
// near (F) and far (B) accumulators, blurred between layers as the plan says, and I = F over
// L_focus over B. The first layer is taken by swap (no copy); a half- or quarter-resolution
// blur stays reduced until the next composite or read, which up-samples it on the fly
// (AccRows) in the same pass as its "over".
#include <algorithm>
#include <cmath>
#include <utility>

#include "core/filters.hpp"
#include "core/parallel.hpp"
#include "methods/layered/composite.hpp"
#include "methods/layered/fast.hpp"
#include "methods/layered/fast_rows.hpp"

namespace dofkit::detail::layered {

void FastAccumulator::settle() {
  if (has_ && pending_var_ > 0) {
    const double sigma = std::sqrt(pending_var_);
    if (half_res_ && quarter_res_ && sigma >= 8.0) {
      if (lazy_up_) resolved();
      // composite.cpp's reduction and blur, up-sampling deferred as below.
      Image& q = ws_.image(name_ + ".quarter", (full_->width() + 3) / 4, (full_->height() + 3) / 4, 4);
      reduce_and_blur(*full_, 4, sigma, q);
      half_ = &q;
      factor_ = 4;
      lazy_up_ = true;
    } else if (half_res_ && sigma >= 4.0) {
      if (lazy_up_) resolved();
      // composite.cpp's reduction and blur (2×2 box down, blur of the remaining variance);
      // the bilinear up-sampling is deferred: the next composite or read does it on the fly.
      Image& half = ws_.image(name_ + ".half", (full_->width() + 1) / 2, (full_->height() + 1) / 2, 4);
      reduce_and_blur(*full_, 2, sigma, half);
      half_ = &half;
      factor_ = 2;
      lazy_up_ = true;
    } else {
      if (lazy_up_) resolved();
      core::gaussian_blur(*full_, static_cast<float>(sigma));
    }
  }
  pending_var_ = 0;
}

const Image& FastAccumulator::resolved() {
  if (pending_var_ > 0) settle();
  if (lazy_up_) {
    Image& img = *full_;
    const Image& half = *half_;
    const int w = img.width(), h = img.height();
    core::parallel_for(
        h,
        [&](int y0, int y1) {
          for (int c = 0; c < 4; ++c)
            for (int y = y0; y < y1; ++y)
              for (int x0 = 0; x0 < w; x0 += kBlock)
                up_block(half.plane(c), half.width(), half.height(), y, x0, std::min(kBlock, w - x0),
                         img.row(c, y) + x0, factor_);
        },
        4);
    lazy_up_ = false;
  }
  return *full_;
}

void FastAccumulator::combine(Image& layer, bool layer_in_front) {
  settle();
  if (!has_) {
    full_ = &ws_.image(name_ + ".full", layer.width(), layer.height(), 4);
    std::swap(*full_, layer);
    has_ = true;
    return;
  }
  if (!lazy_up_) {
    if (layer_in_front)
      over(layer, *full_, *full_);
    else
      over(*full_, layer, *full_);
    return;
  }
  // composite.cpp's over() with the accumulator's up-sampled rows read from the half image.
  Image& img = *full_;
  const AccRows acc(*this);
  const int w = img.width(), h = img.height();
  core::parallel_for(
      h,
      [&](int y0, int y1) {
        float buf[4][kBlock];
        float t[kBlock];
        for (int y = y0; y < y1; ++y)
          for (int x0 = 0; x0 < w; x0 += kBlock) {
            const int n = std::min(kBlock, w - x0);
            const float* a[4];
            acc.get(y, x0, n, buf, a);
            const float* l[4];
            for (int c = 0; c < 4; ++c) l[c] = layer.row(c, y) + x0;
            const float* const* f = layer_in_front ? l : a;
            const float* const* b = layer_in_front ? a : l;
            for (int i = 0; i < n; ++i) t[i] = 1.0f - f[3][i];
            float out[4][kBlock];
            for (int c = 0; c < 4; ++c)
              for (int i = 0; i < n; ++i) out[c][i] = f[c][i] + t[i] * b[c][i];
            for (int c = 0; c < 4; ++c) std::copy(out[c], out[c] + n, img.row(c, y) + x0);
          }
      },
      4);
  lazy_up_ = false;
}

void FastAccumulator::composite_front(Image& layer) { combine(layer, true); }
void FastAccumulator::composite_back(Image& layer) { combine(layer, false); }

void final_composite(FastAccumulator& front, const Image* focus, FastAccumulator& back, int w, int h, Image& out) {
  front.settle();
  back.settle();
  out.resize(w, h, 4);
  const AccRows F(front), B(back);
  core::parallel_for(
      h,
      [&](int y0, int y1) {
        float fb[4][kBlock], bb[4][kBlock];
        float cur[4][kBlock];
        for (int y = y0; y < y1; ++y)
          for (int x0 = 0; x0 < w; x0 += kBlock) {
            const int n = std::min(kBlock, w - x0);
            for (int c = 0; c < 4; ++c) {
              if (focus)
                std::copy(focus->row(c, y) + x0, focus->row(c, y) + x0 + n, cur[c]);
              else
                std::fill(cur[c], cur[c] + n, 0.0f);
            }
            if (B.present()) {  // out = out over B
              const float* b[4];
              B.get(y, x0, n, bb, b);
              float t[kBlock];
              for (int i = 0; i < n; ++i) t[i] = 1.0f - cur[3][i];
              for (int c = 0; c < 4; ++c)
                for (int i = 0; i < n; ++i) cur[c][i] = cur[c][i] + t[i] * b[c][i];
            }
            if (F.present()) {  // out = F over out
              const float* f[4];
              F.get(y, x0, n, fb, f);
              float t[kBlock];
              for (int i = 0; i < n; ++i) t[i] = 1.0f - f[3][i];
              for (int c = 0; c < 4; ++c)
                for (int i = 0; i < n; ++i) cur[c][i] = f[c][i] + t[i] * cur[c][i];
            }
            for (int c = 0; c < 4; ++c) std::copy(cur[c], cur[c] + n, out.row(c, y) + x0);
          }
      },
      4);
}

}  // namespace dofkit::detail::layered
