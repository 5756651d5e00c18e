#include "methods/layered/disc_blur.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "core/parallel.hpp"

namespace dofkit::detail::layered {

double disc_coverage(double r, int dx, int dy) {
  const double c = r - std::sqrt(double(dx) * dx + double(dy) * dy) + 0.5;
  return c <= 0 ? 0.0 : (c >= 1 ? 1.0 : c);
}

DiscKernel make_disc_kernel(double radius) {
  DiscKernel k;
  k.radius = std::max(0.0, radius);
  // cov > 0 needs |(dx, dy)| < R + 0.5, so |dx|, |dy| <= ceil(R + 0.5) − 1 covers every tap.
  const int n = std::max(0, static_cast<int>(std::ceil(k.radius + 0.5)) - 1);
  double sum = 0;
  int extent = 0;
  for (int dy = -n; dy <= n; ++dy) {
    DiscKernel::Row row{dy, -1, {}};
    // Full taps are a contiguous run |dx| <= span (coverage falls with |dx|).
    while (row.span + 1 <= n && disc_coverage(k.radius, row.span + 1, dy) >= 1.0) ++row.span;
    for (int dx = -n; dx <= n; ++dx) {
      if (std::abs(dx) <= row.span) continue;
      const double c = disc_coverage(k.radius, dx, dy);
      if (c > 0) row.rim.push_back({dx, c});
    }
    if (row.span < 0 && row.rim.empty()) continue;
    sum += (2.0 * row.span + 1.0) * (row.span >= 0);
    for (const auto& t : row.rim) sum += t.w;
    extent = std::max({extent, std::abs(dy), row.span});
    for (const auto& t : row.rim) extent = std::max(extent, std::abs(t.dx));
    k.rows.push_back(std::move(row));
  }
  k.extent = extent;
  k.full_weight = 1.0 / sum;
  for (auto& row : k.rows)
    for (auto& t : row.rim) t.w /= sum;
  return k;
}

void disc_blur(Image& img, double radius) {
  const DiscKernel k = make_disc_kernel(radius);
  if (k.extent == 0) return;  // centre tap only: identity
  const int w = img.width(), h = img.height(), pad = k.extent;
  const int pw = w + 2 * pad;         // row padded by clamp-to-edge on both sides
  const std::size_t stride = pw + 1;  // prefix P[0 … pw]: P[i] = Σ_{j<i} padded[j]
  std::vector<double> prefix(stride * h);
  std::vector<int> nonzero_before(h + 1, 0);  // rows [0, y) with any non-zero sample
  std::vector<std::uint8_t> row_nonzero(h, 0);

  for (int c = 0; c < img.channels(); ++c) {
    float* plane = img.plane(c);
    core::parallel_for(
        h,
        [&](int y0, int y1) {
          for (int y = y0; y < y1; ++y) {
            const float* src = plane + static_cast<std::size_t>(y) * w;
            double* p = prefix.data() + stride * y;
            bool any = false;
            for (int x = 0; x < w; ++x) any |= src[x] != 0.0f;
            row_nonzero[y] = any;
            if (!any) continue;
            double s = 0;
            p[0] = 0;
            for (int i = 0; i < pw; ++i) {
              const int x = std::clamp(i - pad, 0, w - 1);
              s += src[x];
              p[i + 1] = s;
            }
          }
        },
        8);
    for (int y = 0; y < h; ++y) nonzero_before[y + 1] = nonzero_before[y] + row_nonzero[y];

    core::parallel_for(
        h,
        [&](int y0, int y1) {
          std::vector<double> acc(w);
          for (int y = y0; y < y1; ++y) {
            float* dst = plane + static_cast<std::size_t>(y) * w;
            // Clamped source rows of y lie in [max(0, y − pad), min(h − 1, y + pad)].
            const int lo = std::max(0, y - pad), hi = std::min(h - 1, y + pad);
            if (nonzero_before[hi + 1] == nonzero_before[lo]) {
              std::fill(dst, dst + w, 0.0f);
              continue;
            }
            std::fill(acc.begin(), acc.end(), 0.0);
            for (const auto& row : k.rows) {
              const int sy = std::clamp(y + row.dy, 0, h - 1);
              if (!row_nonzero[sy]) continue;
              const double* p = prefix.data() + stride * sy + pad;  // p[x] = P at padded index x + pad
              if (row.span >= 0) {
                const double fw = k.full_weight;
                const double* a = p + row.span + 1;
                const double* b = p - row.span;
                for (int x = 0; x < w; ++x) acc[x] += fw * (a[x] - b[x]);
              }
              for (const auto& t : row.rim) {
                const double* a = p + t.dx + 1;
                const double* b = p + t.dx;
                for (int x = 0; x < w; ++x) acc[x] += t.w * (a[x] - b[x]);
              }
            }
            for (int x = 0; x < w; ++x) dst[x] = static_cast<float>(acc[x]);
          }
        },
        4);
  }
}

}  // namespace dofkit::detail::layered
