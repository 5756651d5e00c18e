#include "methods/layered/composite.hpp"

#include <algorithm>
#include <cmath>

#include "core/filters.hpp"
#include "core/parallel.hpp"

namespace dofkit::detail::layered {

void over(const Image& front, const Image& back, Image& dst) {
  const int w = front.width(), h = front.height();
  if (&dst != &front && &dst != &back) dst.resize(w, h, 4);
  core::parallel_for(h, [&](int y0, int y1) {
    for (int y = y0; y < y1; ++y) {
      const float* fa = front.row(3, y);
      float t[4096];
      for (int x0 = 0; x0 < w; x0 += 4096) {
        const int n = std::min(4096, w - x0);
        for (int i = 0; i < n; ++i) t[i] = 1.0f - fa[x0 + i];
        for (int c = 0; c < 4; ++c) {
          const float* f = front.row(c, y) + x0;
          const float* b = back.row(c, y) + x0;
          float* d = dst.row(c, y) + x0;
          for (int i = 0; i < n; ++i) d[i] = f[i] + t[i] * b[i];
        }
      }
    }
  }, 4);
}

void Accumulator::flush() {
  if (has_ && pending_var_ > 0) core::gaussian_blur(img_, static_cast<float>(std::sqrt(pending_var_)));
  pending_var_ = 0;
}

void Accumulator::composite_front(const Image& layer) {
  flush();
  if (!has_) { img_ = layer; has_ = true; return; }
  over(layer, img_, img_);
}

void Accumulator::composite_back(const Image& layer) {
  flush();
  if (!has_) { img_ = layer; has_ = true; return; }
  over(img_, layer, img_);
}

const Image& Accumulator::resolved() {
  flush();
  return img_;
}

double Accumulator::pending_sigma() const { return std::sqrt(pending_var_); }

}  // namespace dofkit::detail::layered
