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
    DiscKernel::Row row{dy, 0, -1, {}};
    // Full taps are a contiguous run |dx| <= span (coverage falls with |dx|).
    int span = -1;
    while (span + 1 <= n && disc_coverage(k.radius, span + 1, dy) >= 1.0) ++span;
    row.lo = -span;
    row.hi = span;
    for (int dx = -n; dx <= n; ++dx) {
      if (std::abs(dx) <= span) continue;
      const double c = disc_coverage(k.radius, dx, dy);
      if (c > 0) row.rim.push_back({dx, c});
    }
    if (span < 0 && row.rim.empty()) continue;
    sum += (2.0 * span + 1.0) * (span >= 0);
    for (const auto& t : row.rim) sum += t.w;
    extent = std::max({extent, std::abs(dy), span});
    for (const auto& t : row.rim) extent = std::max(extent, std::abs(t.dx));
    k.rows.push_back(std::move(row));
  }
  k.extent = extent;
  k.full_weight = 1.0 / sum;
  for (auto& row : k.rows)
    for (auto& t : row.rim) t.w /= sum;
  return k;
}

DiscKernel make_aperture_kernel(const core::ApertureModel& model, double coc, int channel) {
  if (model.is_circle()) return make_disc_kernel(std::fabs(coc));
  const float rho = static_cast<float>(std::fabs(coc));
  // Gather taps read the footprint point-reflected: the other field's raster.
  const core::Field f = coc > 0 ? core::Field::far : core::Field::near;
  const int nch = channel < 0 ? model.channels() : 1;
  std::vector<core::ApertureModel::Kernel> ks;
  for (int c = 0; c < nch; ++c) ks.push_back(model.kernel(rho, f, 0, 0, channel < 0 ? c : channel, /*eye=*/false));
  const int r = ks[0].reach, p = 2 * r + 1;
  std::vector<double> w(static_cast<std::size_t>(p) * p, 0.0);
  for (const auto& k : ks)
    for (std::size_t i = 0; i < w.size(); ++i) w[i] += k.cov[i] / (k.sum * nch);
  DiscKernel out;
  out.radius = rho;
  double full = 0;  // the largest weight: a tap of full coverage
  for (double v : w) full = std::max(full, v);
  out.full_weight = full;
  int extent = 0;
  for (int dy = -r; dy <= r; ++dy) {
    DiscKernel::Row row{dy, 0, -1, {}};
    const double* wr = w.data() + static_cast<std::size_t>(dy + r) * p + r;  // wr[dx]
    // The first run of full-weight taps (the interior), then runs of equal partial weight.
    for (int dx = -r; dx <= r; ++dx) {
      const double v = wr[dx];
      if (v <= 0) continue;
      if (v == full && (row.lo > row.hi || row.hi == dx - 1)) {
        if (row.lo > row.hi) row.lo = dx;
        row.hi = dx;
      } else if (!row.rim.empty() && row.rim.back().w == v && row.rim.back().dx + row.rim.back().len == dx) {
        ++row.rim.back().len;
      } else {
        row.rim.push_back({dx, v, 1});
      }
      extent = std::max({extent, std::abs(dy), std::abs(dx)});
    }
    if (row.lo > row.hi && row.rim.empty()) continue;
    out.rows.push_back(std::move(row));
  }
  out.extent = extent;
  return out;
}

namespace {
void blur_plane(float* plane, int w, int h, const DiscKernel& k, std::vector<double>& prefix,
                std::vector<int>& nonzero_before, std::vector<std::uint8_t>& row_nonzero);
}

void disc_blur(Image& img, double coc, const core::ApertureModel* model) {
  if (!model || model->is_circle()) {
    disc_blur(img, std::fabs(coc));
    return;
  }
  if (model->channels() == 1) {
    const DiscKernel k = make_aperture_kernel(*model, coc, 0);
    if (k.extent == 0) return;
    const int w = img.width(), h = img.height();
    std::vector<double> prefix(static_cast<std::size_t>(w + 2 * k.extent + 1) * h);
    std::vector<int> nonzero_before(h + 1, 0);
    std::vector<std::uint8_t> row_nonzero(h, 0);
    for (int c = 0; c < img.channels(); ++c) blur_plane(img.plane(c), w, h, k, prefix, nonzero_before, row_nonzero);
    return;
  }
  // RGB kernels: plane c by kernel c, alpha by the mean kernel.
  for (int c = 0; c < img.channels(); ++c) {
    const DiscKernel k = make_aperture_kernel(*model, coc, c < 3 ? c : -1);
    if (k.extent == 0) continue;
    const int w = img.width(), h = img.height();
    std::vector<double> prefix(static_cast<std::size_t>(w + 2 * k.extent + 1) * h);
    std::vector<int> nonzero_before(h + 1, 0);
    std::vector<std::uint8_t> row_nonzero(h, 0);
    blur_plane(img.plane(c), w, h, k, prefix, nonzero_before, row_nonzero);
  }
}

void disc_blur(Image& img, double radius) {
  const DiscKernel k = make_disc_kernel(radius);
  if (k.extent == 0) return;  // centre tap only: identity
  const int w = img.width(), h = img.height();
  std::vector<double> prefix(static_cast<std::size_t>(w + 2 * k.extent + 1) * h);
  std::vector<int> nonzero_before(h + 1, 0);  // rows [0, y) with any non-zero sample
  std::vector<std::uint8_t> row_nonzero(h, 0);
  for (int c = 0; c < img.channels(); ++c) blur_plane(img.plane(c), w, h, k, prefix, nonzero_before, row_nonzero);
}

namespace {

void blur_plane(float* plane, int w, int h, const DiscKernel& k, std::vector<double>& prefix,
                std::vector<int>& nonzero_before, std::vector<std::uint8_t>& row_nonzero) {
  const int pad = k.extent;
  const int pw = w + 2 * pad;         // row padded by clamp-to-edge on both sides
  const std::size_t stride = pw + 1;  // prefix P[0 … pw]: P[i] = Σ_{j<i} padded[j]
  {
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
              if (row.lo <= row.hi) {
                const double fw = k.full_weight;
                const double* a = p + row.hi + 1;
                const double* b = p + row.lo;
                for (int x = 0; x < w; ++x) acc[x] += fw * (a[x] - b[x]);
              }
              for (const auto& t : row.rim) {
                const double* a = p + t.dx + t.len;
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

}  // namespace

}  // namespace dofkit::detail::layered
