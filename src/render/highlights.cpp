#include "render/highlights.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/parallel.hpp"

namespace dofkit::detail {

namespace {

// A clipped region counts as small up to this fraction of the frame (and at least 16 px).
constexpr double kSmallAreaFraction = 2e-4;
// The display value (largest channel) around a region: at most kRingDark it stands out as a
// light (full boost), from kRingBright on it is a bright surface (no boost), linear between.
constexpr double kRingDark = 0.2, kRingBright = 0.5;

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

double small_area_px(int w, int h) { return std::max(16.0, kSmallAreaFraction * double(w) * double(h)); }

void boost_highlights(const Image& src, const HighlightRecovery& h, Image& dst, Image* mask) {
  const int w = src.width(), hh = src.height();
  const std::size_t n = src.plane_size();
  dst.resize(w, hh, 4);
  const float lt = static_cast<float>(decode_srgb(h.threshold));
  const float boost = static_cast<float>(h.boost);
  // m² per pixel.
  std::vector<float> m2(n);
  core::parallel_for(hh, [&](int y0, int y1) {
    for (int y = y0; y < y1; ++y)
      for (int x = 0; x < w; ++x)
        m2[static_cast<std::size_t>(y) * w + x] =
            highlight_mask(src.row(0, y)[x], src.row(1, y)[x], src.row(2, y)[x], src.row(3, y)[x], h.threshold, lt);
  });
  // Each 8-connected region of pixels above the threshold gets the weight min(1, A0 / area):
  // small clipped blobs (lights, speculars) get the whole boost, large clipped areas (a bright
  // wall or sky just over white) almost none. A fixed scan order: the same for any thread count.
  const double a0 = small_area_px(w, hh);
  std::vector<int> label(n, -1), stack;
  std::vector<float> weight;
  for (std::size_t i = 0; i < n; ++i) {
    if (m2[i] <= 0 || label[i] >= 0) continue;
    const int id = static_cast<int>(weight.size());
    std::size_t area = 0, ring_n = 0;
    double ring = 0;  // display values of the pixels around the region (each time it is met)
    stack.assign(1, static_cast<int>(i));
    label[i] = id;
    while (!stack.empty()) {
      const std::size_t p = static_cast<std::size_t>(stack.back());
      stack.pop_back();
      ++area;
      const int px = static_cast<int>(p % w), py = static_cast<int>(p / w);
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int qx = px + dx, qy = py + dy;
          if (qx < 0 || qy < 0 || qx >= w || qy >= hh) continue;
          const std::size_t q = static_cast<std::size_t>(qy) * w + qx;
          if (m2[q] > 0) {
            if (label[q] < 0) {
              label[q] = id;
              stack.push_back(static_cast<int>(q));
            }
          } else {
            const float a = src.row(3, qy)[qx];
            const double v = a > 0 ? std::max({src.row(0, qy)[qx], src.row(1, qy)[qx], src.row(2, qy)[qx]}) / a : 0.0;
            ring += encode_srgb(v);
            ++ring_n;
          }
        }
    }
    // A light stands out of a darker surround; a bright surface just over white does not.
    const double r = ring_n ? ring / ring_n : 0.0;
    const double contrast = std::clamp((kRingBright - r) / (kRingBright - kRingDark), 0.0, 1.0);
    weight.push_back(static_cast<float>(std::min(1.0, a0 / double(area)) * contrast));
  }
  if (mask) mask->resize(w, hh, 1);
  core::parallel_for(hh, [&](int y0, int y1) {
    for (int y = y0; y < y1; ++y)
      for (int x = 0; x < w; ++x) {
        const std::size_t i = static_cast<std::size_t>(y) * w + x;
        const float k = label[i] < 0 ? 0.0f : m2[i] * weight[static_cast<std::size_t>(label[i])];
        const float gain = 1.0f + boost * k;
        for (int c = 0; c < 3; ++c) dst.row(c, y)[x] = src.row(c, y)[x] * gain;
        dst.row(3, y)[x] = src.row(3, y)[x];
        if (mask) mask->row(0, y)[x] = k;
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
