// Pass 4 — the smart Gaussian blur (§5.5 "Blurs"), plain oracle and the pass driver.
// Inputs: the AO term, the full-res depth and the internal normals. Output: the blurred AO.
// Each pass is a horizontal then a vertical sweep of Gaussian taps −r … r (σ = r / 2). A tap
// gets weight 0 when its depth differs from the centre's by more than depth_threshold × the
// centre's depth, or when the dot product of its normal with the centre's is below
// normal_threshold (the centre always counts); the weights left are renormalised. The sky
// (z = +inf) stays 1 and never contributes to a surface pixel (its depth difference is
// infinite). Separable sweeps make the pass O(r) per pixel; the chapter does not say whether
// its blur was separable, and several passes hide the difference (docs/methods/ssao.md).
// The Highway row kernels (blur_simd.cpp) give the same values bit for bit: the same float
// operations in the same order (taps summed from −r to r), no FMA contraction.
#include <cmath>
#include <limits>

#include "core/parallel.hpp"
#include "effects/ssao/ssao.hpp"

namespace dofkit::detail::ao {

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

// One output pixel of a sweep: taps at offsets −r … r, tap k read through the accessors.
template <class Tap>
float blur_pixel(float zc, float nc0, float nc1, float nc2, const float* taps, int r, float depth_t, float normal_t,
                 Tap tap) {
  if (!(zc < kInf)) return 1.0f;
  const float limit = depth_t * zc;
  float sw = 0.0f, s = 0.0f;
  for (int k = -r; k <= r; ++k) {
    float zt, a0, a1, a2, v;
    if (!tap(k, zt, a0, a1, a2, v)) continue;
    const float g = taps[k < 0 ? -k : k];
    const bool keep = k == 0 || (std::abs(zt - zc) <= limit && (a0 * nc0 + a1 * nc1) + a2 * nc2 >= normal_t);
    if (!keep) continue;
    sw += g;
    s += g * v;
  }
  return s / sw;
}

}  // namespace

std::vector<float> blur_taps(int radius_px) {
  std::vector<float> g(radius_px + 1);
  const double sigma = 0.5 * radius_px;
  for (int k = 0; k <= radius_px; ++k) g[k] = static_cast<float>(std::exp(-0.5 * k * k / (sigma * sigma)));
  return g;
}

void blur_h_span_plain(const Image& depth, const Image& n, const float* in, float* out, const std::vector<float>& taps,
                       float depth_t, float normal_t, int y, int x0, int x1) {
  const int w = depth.width(), r = static_cast<int>(taps.size()) - 1;
  const float* z = depth.row(0, y);
  const float *n0 = n.row(0, y), *n1 = n.row(1, y), *n2 = n.row(2, y);
  const float* a = in + static_cast<std::size_t>(y) * w;
  float* o = out + static_cast<std::size_t>(y) * w;
  for (int x = x0; x < x1; ++x)
    o[x] = blur_pixel(z[x], n0[x], n1[x], n2[x], taps.data(), r, depth_t, normal_t,
                      [&](int k, float& zt, float& t0, float& t1, float& t2, float& v) {
                        const int xx = x + k;
                        if (xx < 0 || xx >= w) return false;
                        zt = z[xx];
                        t0 = n0[xx];
                        t1 = n1[xx];
                        t2 = n2[xx];
                        v = a[xx];
                        return true;
                      });
}

void blur_h_rows_plain(const Image& depth, const Image& n, const float* in, float* out, const std::vector<float>& taps,
                       float depth_t, float normal_t, int y0, int y1) {
  for (int y = y0; y < y1; ++y) blur_h_span_plain(depth, n, in, out, taps, depth_t, normal_t, y, 0, depth.width());
}

void blur_v_span_plain(const Image& depth, const Image& n, const float* in, float* out, const std::vector<float>& taps,
                       float depth_t, float normal_t, int y, int x0, int x1) {
  const int w = depth.width(), h = depth.height(), r = static_cast<int>(taps.size()) - 1;
  for (int x = x0; x < x1; ++x)
    out[static_cast<std::size_t>(y) * w + x] =
        blur_pixel(depth.row(0, y)[x], n.row(0, y)[x], n.row(1, y)[x], n.row(2, y)[x], taps.data(), r, depth_t,
                   normal_t, [&](int k, float& zt, float& t0, float& t1, float& t2, float& v) {
                     const int yy = y + k;
                     if (yy < 0 || yy >= h) return false;
                     zt = depth.row(0, yy)[x];
                     t0 = n.row(0, yy)[x];
                     t1 = n.row(1, yy)[x];
                     t2 = n.row(2, yy)[x];
                     v = in[static_cast<std::size_t>(yy) * w + x];
                     return true;
                   });
}

void blur_v_rows_plain(const Image& depth, const Image& n, const float* in, float* out, const std::vector<float>& taps,
                       float depth_t, float normal_t, int y0, int y1) {
  for (int y = y0; y < y1; ++y) blur_v_span_plain(depth, n, in, out, taps, depth_t, normal_t, y, 0, depth.width());
}

void blur(const Image& depth, const Image& n, const BlurParams& p, bool plain, float* ao, float* tmp,
          const std::function<void(int, const float*)>& on_pass) {
  const int w = depth.width(), h = depth.height();
  const std::vector<float> taps = blur_taps(p.radius_px);
  const int r = p.radius_px;
  const float dt = static_cast<float>(p.depth_threshold), nt = static_cast<float>(p.normal_threshold);
  for (int pass = 1; pass <= p.passes; ++pass) {
    core::parallel_for(
        h,
        [&](int y0, int y1) {
          if (plain) return blur_h_rows_plain(depth, n, ao, tmp, taps, dt, nt, y0, y1);
          for (int y = y0; y < y1; ++y) {
            // The kernel takes the columns whose taps all lie inside the row.
            const float* nr[3] = {n.row(0, y), n.row(1, y), n.row(2, y)};
            const std::size_t o = static_cast<std::size_t>(y) * w;
            const int x0 = std::min(r, w);
            const int done =
                x0 < w - r ? blur_h_row_simd(depth.row(0, y), nr, ao + o, tmp + o, taps.data(), r, dt, nt, x0, w - r)
                           : x0;
            blur_h_span_plain(depth, n, ao, tmp, taps, dt, nt, y, 0, x0);
            blur_h_span_plain(depth, n, ao, tmp, taps, dt, nt, y, done, w);
          }
        },
        8);
    core::parallel_for(
        h,
        [&](int y0, int y1) {
          if (plain) return blur_v_rows_plain(depth, n, tmp, ao, taps, dt, nt, y0, y1);
          std::vector<const float*> rz(2 * r + 1), r0(2 * r + 1), r1(2 * r + 1), r2(2 * r + 1), ra(2 * r + 1);
          for (int y = y0; y < y1; ++y) {
            for (int k = -r; k <= r; ++k) {
              const int yy = y + k;
              const bool in = yy >= 0 && yy < h;
              rz[k + r] = in ? depth.row(0, yy) : nullptr;
              r0[k + r] = in ? n.row(0, yy) : nullptr;
              r1[k + r] = in ? n.row(1, yy) : nullptr;
              r2[k + r] = in ? n.row(2, yy) : nullptr;
              ra[k + r] = in ? tmp + static_cast<std::size_t>(yy) * w : nullptr;
            }
            const VRows rows{rz.data(), r0.data(), r1.data(), r2.data(), ra.data()};
            const int done = blur_v_row_simd(rows, r, taps.data(), dt, nt, ao + static_cast<std::size_t>(y) * w, 0, w);
            blur_v_span_plain(depth, n, tmp, ao, taps, dt, nt, y, done, w);
          }
        },
        8);
    if (on_pass) on_pass(pass, ao);
  }
}

}  // namespace dofkit::detail::ao
