// Depth-ordered disc scatter (the reference method) — see docs/methods/reference.md.
//
// Each source pixel q with signed CoC r_q spreads its premultiplied colour over the pixels
// p within its disc, with coverage cov = saturate(ρ_q − |p − q| + 0.5), ρ = max(|r|, 0.5),
// and weight w = cov / A(ρ_q) where A is the exact sum of the coverages (so a disc carries
// exactly the energy of its source). A receiver p keeps two sums:
//   F — sources in front of p (they occlude p like a semi-transparent layer),
//   B — p's own surface and everything behind it.
// The output is F + (1 − min(1, ΣF_w)) · B / ΣB_w: front contributions composite "over" the
// normalised rest. The split is soft in inverse depth, so one continuous surface that
// crosses any depth never shows a seam (both halves then give the plain energy sum), and
// normalising B by its weight keeps image borders (clipped discs) at full brightness.
// A source behind the receiver reaches it only in proportion ρ'_p / ρ'_q
// (ρ' = max(|r| − 0.5, 0)): a sharp receiver is never covered by blurred background, a
// receiver blurred as much as the source lets it through.
#include "methods/reference/disc_scatter.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/parallel.hpp"

namespace dofkit::detail {

double disc_area(double r) {
  const int n = static_cast<int>(std::ceil(r + 0.5));
  double sum = 0;
  for (int dy = -n; dy <= n; ++dy)
    for (int dx = -n; dx <= n; ++dx) {
      const double c = r - std::sqrt(double(dx) * dx + double(dy) * dy) + 0.5;
      sum += c <= 0 ? 0 : (c >= 1 ? 1 : c);
    }
  return sum;
}

namespace {

inline float saturate(float t) { return t < 0.f ? 0.f : (t > 1.f ? 1.f : t); }

// Table of disc_area at 1/32 px steps; A(r) is piecewise linear in r, so linear
// interpolation between table points is nearly exact.
class AreaTable {
 public:
  explicit AreaTable(float rmax) {
    const int n = static_cast<int>(std::ceil(rmax * kSteps)) + 2;
    table_.resize(n);
    for (int i = 0; i < n; ++i) table_[i] = static_cast<float>(disc_area(double(i) / kSteps));
  }
  float operator()(float r) const {
    const float f = r * kSteps;
    int i = static_cast<int>(f);
    if (i >= static_cast<int>(table_.size()) - 1) i = static_cast<int>(table_.size()) - 2;
    const float t = f - i;
    return table_[i] + (table_[i + 1] - table_[i]) * t;
  }

 private:
  static constexpr int kSteps = 32;
  std::vector<float> table_;
};

}  // namespace

void disc_scatter(const Image& colour, const Image& depth, const Image& coc, const DiscScatterOptions& opt,
                  Image& out) {
  const int w = colour.width(), h = colour.height();
  const std::size_t n = colour.plane_size();
  // Per-pixel precomputation: disc radius, inverse depth, weight per unit coverage.
  std::vector<float> rho(n), sharpness(n), inv_z(n), wscale(n);
  float rmax = 0.5f;
  for (std::size_t i = 0; i < n; ++i) {
    const float r = std::fabs(coc.plane(0)[i]);
    rho[i] = std::max(r, 0.5f);
    sharpness[i] = std::max(r - 0.5f, 0.0f);
    const float z = depth.plane(0)[i];
    inv_z[i] = std::isinf(z) ? 0.0f : 1.0f / z;
    rmax = std::max(rmax, rho[i]);
  }
  const AreaTable area(rmax + 1);
  for (std::size_t i = 0; i < n; ++i) wscale[i] = 1.0f / area(rho[i]);
  const int reach = static_cast<int>(std::ceil(rmax + 0.5f));
  const float soft = opt.depth_softness;

  // Receivers are processed in fixed bands of rows; each band gathers the discs of every
  // source that can reach it, in a fixed order, so the result is the same for any thread count.
  constexpr int kBand = 8;
  const int bands = (h + kBand - 1) / kBand;
  out.resize(w, h, 4);
  core::parallel_for(bands, [&](int b0, int b1) {
    // Accumulators: 4 colour channels + weight, for the front (F) and back (B) sums.
    std::vector<float> acc(static_cast<std::size_t>(kBand) * w * 10);
    for (int b = b0; b < b1; ++b) {
      const int y0 = b * kBand, y1 = std::min(h, y0 + kBand);
      std::fill(acc.begin(), acc.end(), 0.0f);
      const int sy0 = std::max(0, y0 - reach), sy1 = std::min(h, y1 + reach);
      for (int qy = sy0; qy < sy1; ++qy) {
        for (int qx = 0; qx < w; ++qx) {
          const std::size_t q = static_cast<std::size_t>(qy) * w + qx;
          const float rq = rho[q];
          const int ext = static_cast<int>(std::ceil(rq + 0.5f)) - 1;  // farthest integer offset with cov > 0
          const int py0 = std::max(y0, qy - ext), py1 = std::min(y1 - 1, qy + ext);
          if (py0 > py1) continue;
          const float c[4] = {colour.plane(0)[q], colour.plane(1)[q], colour.plane(2)[q], colour.plane(3)[q]};
          const float ws = wscale[q], uq = inv_z[q], sq = sharpness[q];
          const float inv_sq = sq > 0 ? 1.0f / sq : 0.0f;
          for (int py = py0; py <= py1; ++py) {
            const float dy = static_cast<float>(py - qy);
            const float lim = rq + 0.5f;
            const int hw = static_cast<int>(std::sqrt(std::max(0.0f, lim * lim - dy * dy)));
            const int px0 = std::max(0, qx - hw), px1 = std::min(w - 1, qx + hw);
            float* row = acc.data() + static_cast<std::size_t>(py - y0) * w * 10;
            const std::size_t prow = static_cast<std::size_t>(py) * w;
            for (int px = px0; px <= px1; ++px) {
              const float dx = static_cast<float>(px - qx);
              const float cov = saturate(rq - std::sqrt(dx * dx + dy * dy) + 0.5f);
              if (cov <= 0.0f) continue;
              float wt = cov * ws;
              float front = 0.0f;
              if (opt.depth_order) {
                const float up = inv_z[prow + px];
                // Soft "q is in front of p" (positive) / "q is behind p" (negative) in inverse depth.
                const float rel = up > 0 ? (uq - up) / (soft * up) : (uq > 0 ? 1.0f : 0.0f);
                front = saturate(rel);
                const float behind = saturate(-rel);
                if (behind > 0) {
                  const float pass = sq > 0 ? saturate(sharpness[prow + px] * inv_sq) : 1.0f;
                  wt *= 1.0f - behind * (1.0f - pass);
                }
              }
              float* a = row + static_cast<std::size_t>(px) * 10;
              const float wf = wt * front, wb = wt - wf;
              a[0] += wf * c[0]; a[1] += wf * c[1]; a[2] += wf * c[2]; a[3] += wf * c[3]; a[4] += wf;
              a[5] += wb * c[0]; a[6] += wb * c[1]; a[7] += wb * c[2]; a[8] += wb * c[3]; a[9] += wb;
            }
          }
        }
      }
      for (int py = y0; py < y1; ++py) {
        const float* row = acc.data() + static_cast<std::size_t>(py - y0) * w * 10;
        for (int px = 0; px < w; ++px) {
          const float* a = row + static_cast<std::size_t>(px) * 10;
          const float fw = a[4], bw = a[9];
          for (int ch = 0; ch < 4; ++ch) {
            float v;
            if (bw > 0) {
              const float fs = fw > 1.0f ? 1.0f / fw : 1.0f;
              v = a[ch] * fs + (1.0f - std::min(fw, 1.0f)) * (a[5 + ch] / bw);
            } else if (fw > 0) {
              v = a[ch] / fw;
            } else {
              v = colour.row(ch, py)[px];
            }
            out.row(ch, py)[px] = v;
          }
        }
      }
    }
  });
}

}  // namespace dofkit::detail
