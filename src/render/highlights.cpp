#include "render/highlights.hpp"

#include <algorithm>
#include <cmath>

#include "core/parallel.hpp"

namespace dofkit::detail {

namespace {

double encode_srgb(double v) {
  if (!(v > 0)) return 0;
  if (v >= 1) return 1;
  return v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1 / 2.4) - 0.055;
}

double decode_srgb(double e) { return e <= 0.04045 ? e / 12.92 : std::pow((e + 0.055) / 1.055, 2.4); }

// m² for a straight (alpha divided out) largest channel value L.
double mask_of(double L, double threshold) {
  const double m = std::clamp((encode_srgb(L) - threshold) / (1 - threshold), 0.0, 1.0);
  return m * m;
}

}  // namespace

float highlight_mask(float r, float g, float b, float a, double threshold, float linear_threshold) {
  if (!(a > 0)) return 0.0f;
  const float L = std::max({r, g, b}) / a;
  if (!(L > linear_threshold)) return 0.0f;
  return static_cast<float>(mask_of(L, threshold));
}

void boost_highlights(const Image& src, const HighlightRecovery& h, Image& dst, Image* mask) {
  dst.resize(src.width(), src.height(), 4);
  if (mask) mask->resize(src.width(), src.height(), 1);
  const float lt = static_cast<float>(decode_srgb(h.threshold));
  const float boost = static_cast<float>(h.boost);
  const int w = src.width();
  core::parallel_for(src.height(), [&](int y0, int y1) {
    for (int y = y0; y < y1; ++y) {
      const float *r = src.row(0, y), *g = src.row(1, y), *b = src.row(2, y), *a = src.row(3, y);
      float* m = mask ? mask->row(0, y) : nullptr;
      for (int x = 0; x < w; ++x) {
        const float m2 = highlight_mask(r[x], g[x], b[x], a[x], h.threshold, lt);
        const float gain = 1.0f + boost * m2;
        dst.row(0, y)[x] = r[x] * gain;
        dst.row(1, y)[x] = g[x] * gain;
        dst.row(2, y)[x] = b[x] * gain;
        dst.row(3, y)[x] = a[x];
        if (m) m[x] = m2;
      }
    }
  });
}

void restore_highlights(Image& img, const HighlightRecovery& h) {
  if (!h.enabled()) return;
  const double lt = decode_srgb(h.threshold);
  const int w = img.width();
  core::parallel_for(img.height(), [&](int y0, int y1) {
    for (int y = y0; y < y1; ++y)
      for (int x = 0; x < w; ++x) {
        const float a = img.row(3, y)[x];
        if (!(a > 0)) continue;
        const double out = std::max({img.row(0, y)[x], img.row(1, y)[x], img.row(2, y)[x]}) / double(a);
        if (!(out > lt)) continue;
        // Solve v·(1 + boost·mask(v)) = out for v in [out / (1 + boost), out] (the left side
        // is increasing in v): bisection to float precision.
        double lo = out / (1 + h.boost), hi = out;
        for (int it = 0; it < 60 && hi - lo > 1e-9 * out; ++it) {
          const double mid = 0.5 * (lo + hi);
          (mid * (1 + h.boost * mask_of(mid, h.threshold)) < out ? lo : hi) = mid;
        }
        const float k = static_cast<float>(0.5 * (lo + hi) / out);
        for (int c = 0; c < 3; ++c) img.row(c, y)[x] *= k;
      }
  });
}

}  // namespace dofkit::detail
