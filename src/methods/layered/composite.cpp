#include "methods/layered/composite.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/filters.hpp"
#include "core/parallel.hpp"

namespace dofkit::detail::layered {

void over(const Image& front, const Image& back, Image& dst) {
  const int w = front.width(), h = front.height();
  if (&dst != &front && &dst != &back) dst.resize(w, h, 4);
  core::parallel_for(
      h,
      [&](int y0, int y1) {
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
      },
      4);
}

// Half resolution (docs/methods/layered.md): 2×2 box down (per-axis variance
// (2² − 1)/12 = 1/4 px²), blur, bilinear up (a tent of half-width 2 px: variance 2²/6 =
// 2/3 px²), so 4 σ'² + 1/4 + 2/3 = σ² and the total variance is exact; the blur costs a
// quarter. Quarter resolution, the same construction one octave down: 4×4 box (per-axis
// variance (4² − 1)/12 = 5/4 px²), bilinear up by 4 (a tent of half-width 4 px: 4²/6 =
// 8/3 px²), so 16 σ'² + 5/4 + 8/3 = σ². At its threshold σ' = sqrt((64 − 5/4 − 8/3)/16) ≈ 1.94
// quarter-res px, the same σ' in its own pixels as the half-resolution path has at 4 px, so
// the sampling is as fine relative to the blur; the blur costs a sixteenth.
void reduce_and_blur(const Image& img, int f, double sigma, Image& low) {
  const int w = img.width(), h = img.height(), nc = img.channels();
  const int lw = (w + f - 1) / f, lh = (h + f - 1) / f;
  low.resize(lw, lh, nc);
  if (f == 2) {
    core::parallel_for(
        lh,
        [&](int y0, int y1) {
          for (int c = 0; c < nc; ++c)
            for (int y = y0; y < y1; ++y) {
              const float* a = img.row(c, 2 * y);
              const float* b = img.row(c, std::min(2 * y + 1, h - 1));
              float* d = low.row(c, y);
              for (int x = 0; x < lw; ++x) {
                const int x1 = std::min(2 * x + 1, w - 1);
                d[x] = 0.25f * (a[2 * x] + a[x1] + b[2 * x] + b[x1]);
              }
            }
        },
        4);
  } else {
    core::parallel_for(
        lh,
        [&](int y0, int y1) {
          for (int c = 0; c < nc; ++c)
            for (int y = y0; y < y1; ++y) {
              float* d = low.row(c, y);
              for (int x = 0; x < lw; ++x) {
                float s = 0.0f;
                for (int dy = 0; dy < 4; ++dy) {
                  const float* r = img.row(c, std::min(4 * y + dy, h - 1));
                  for (int dx = 0; dx < 4; ++dx) s += r[std::min(4 * x + dx, w - 1)];
                }
                d[x] = 0.0625f * s;
              }
            }
        },
        2);
  }
  const double var = f == 2 ? (sigma * sigma - 0.25 - 2.0 / 3.0) / 4.0 : (sigma * sigma - 1.25 - 8.0 / 3.0) / 16.0;
  if (var > 0) core::gaussian_blur(low, static_cast<float>(std::sqrt(var)));
}

namespace {

// One row of core::sample_bilinear samples (its arithmetic and order: horizontal lerps, then
// the vertical one). Compiled for the baseline target only: where a target has FMA the
// compiler may contract the lerps, which would make this oracle's result depend on the
// machine (impl=fast must equal it bit for bit).
void upsample_row(const float* ra, const float* rb, float ty, const int* xa, const int* xb, const float* tx, int n,
                  float* dst) {
  for (int x = 0; x < n; ++x) {
    const float top = ra[xa[x]] + (ra[xb[x]] - ra[xa[x]]) * tx[x];
    const float bot = rb[xa[x]] + (rb[xb[x]] - rb[xa[x]]) * tx[x];
    dst[x] = top + (bot - top) * ty;
  }
}

// Gaussian blur of σ px at 1/f resolution, f = 2 (σ >= 4) or 4 (σ >= 8): f×f box down,
// blur, bilinear up by f, with exact total variance (reduce_and_blur, composite.hpp).
void blur_reduced(Image& img, int f, double sigma) {
  const int w = img.width(), h = img.height();
  Image low;
  reduce_and_blur(img, f, sigma, low);
  const int lw = low.width(), lh = low.height();
  const float scale = 1.0f / static_cast<float>(f);  // 0.5 or 0.25: exact
  // Full-res pixel centre (x + 0.5) sits at (x + 0.5) / f in reduced pixel units. The
  // bilinear footprint (core::sample_bilinear, same arithmetic) is computed once per column.
  std::vector<int> xa(w), xb(w);
  std::vector<float> tx(w);
  for (int x = 0; x < w; ++x) core::bilinear_footprint((x + 0.5f) * scale, lw, xa[x], xb[x], tx[x]);
  core::parallel_for(
      h,
      [&](int y0, int y1) {
        for (int c = 0; c < img.channels(); ++c) {
          const float* p = low.plane(c);
          for (int y = y0; y < y1; ++y) {
            int ya, yb;
            float ty;
            core::bilinear_footprint((y + 0.5f) * scale, lh, ya, yb, ty);
            upsample_row(p + static_cast<std::size_t>(ya) * lw, p + static_cast<std::size_t>(yb) * lw, ty, xa.data(),
                         xb.data(), tx.data(), w, img.row(c, y));
          }
        }
      },
      4);
}

}  // namespace

void Accumulator::flush() {
  if (has_ && pending_var_ > 0) {
    const double sigma = std::sqrt(pending_var_);
    if (half_res_ && quarter_res_ && sigma >= 8.0)
      blur_reduced(img_, 4, sigma);
    else if (half_res_ && sigma >= 4.0)
      blur_reduced(img_, 2, sigma);
    else
      core::gaussian_blur(img_, static_cast<float>(sigma));
  }
  pending_var_ = 0;
}

void Accumulator::composite_front(const Image& layer) {
  flush();
  if (!has_) {
    img_ = layer;
    has_ = true;
    return;
  }
  over(layer, img_, img_);
}

void Accumulator::composite_back(const Image& layer) {
  flush();
  if (!has_) {
    img_ = layer;
    has_ = true;
    return;
  }
  over(img_, layer, img_);
}

const Image& Accumulator::resolved() {
  flush();
  return img_;
}

double Accumulator::pending_sigma() const { return std::sqrt(pending_var_); }

}  // namespace dofkit::detail::layered
