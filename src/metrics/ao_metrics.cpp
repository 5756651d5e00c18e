// AO scores (ao_metrics.hpp).
#include "metrics/ao_metrics.hpp"

#include <cmath>
#include <string>

#include "dofkit/error.hpp"
#include "metrics/metrics.hpp"

namespace dofkit::metrics {

AoScores compare_ao(const Image& reference, const Image& test, const Image& depth) {
  if (reference.empty() || !reference.same_size(test) || !reference.same_size(depth))
    throw_bad_input("compare_ao: the reference (" + std::to_string(reference.width()) + "x" +
                    std::to_string(reference.height()) + "), test (" + std::to_string(test.width()) + "x" +
                    std::to_string(test.height()) + ") and depth must have the same size");
  const Image band = edge_band(depth, kEdgeBandPx, kEdgeJump);
  const int w = reference.width(), h = reference.height();
  double sse = 0, n = 0, sse_band = 0, n_band = 0, err = 0;
  for (int y = 0; y < h; ++y) {
    double s = 0, c = 0, sb = 0, cb = 0, e = 0;  // per row, then summed in row order
    for (int x = 0; x < w; ++x) {
      if (std::isinf(depth.at(x, y))) continue;
      const double d = static_cast<double>(test.at(x, y)) - reference.at(x, y);
      s += d * d;
      c += 1;
      e += d;
      if (band.at(x, y) > 0.5f) {
        sb += d * d;
        cb += 1;
      }
    }
    sse += s;
    n += c;
    sse_band += sb;
    n_band += cb;
    err += e;
  }
  const auto psnr = [](double sum, double count) {
    if (count <= 0) return std::numeric_limits<double>::quiet_NaN();
    return sum <= 0 ? std::numeric_limits<double>::infinity() : 10 * std::log10(count / sum);
  };
  AoScores r;
  r.psnr_db = psnr(sse, n);
  r.edge_psnr_db = psnr(sse_band, n_band);
  r.mean_error = n > 0 ? err / n : 0;
  r.ssim = ssim_values(reference.plane(0), test.plane(0), w, h);
  return r;
}

}  // namespace dofkit::metrics
