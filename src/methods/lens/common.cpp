#include "methods/lens/common.hpp"

#include <cmath>

#include "core/parallel.hpp"
#include "core/sampling.hpp"

namespace dofkit::detail::lens {

void mark_direct(const Image& colour, const Image& coc, const float* trans, const LensOptions& opt,
                 std::uint8_t* flags, std::uint8_t bit, std::vector<std::vector<double>>* scratch) {
  const int w = colour.width(), h = colour.height();
  const float r0 = opt.direct_px();
  auto lum_at = [&](std::size_t i) {
    const float s = trans ? trans[i] : 1.0f;
    return luminance(colour.plane(0)[i] * s, colour.plane(1)[i] * s, colour.plane(2)[i] * s);
  };
  // Small radii, and the highest block level a highlight candidate needs (0: none).
  std::vector<int> row_need(h, 0);
  core::parallel_for(
      h,
      [&](int y0, int y1) {
        for (int y = y0; y < y1; ++y) {
          int need = 0;
          for (int x = 0; x < w; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * w + x;
            const float rho = std::max(std::fabs(coc.plane(0)[i]), 0.5f);
            if (rho < r0) {
              flags[i] |= bit;
              continue;
            }
            if (!(lum_at(i) > opt.highlight_abs)) continue;
            need = std::max(need, block_level(rho));
          }
          row_need[y] = need;
        }
      },
      8);
  const int top = *std::max_element(row_need.begin(), row_need.end());
  if (top == 0) return;
  // Block sums of the luminance, level m from level m − 1 (children (0,0), (1,0), (0,1),
  // (1,1) in that order).
  std::vector<std::vector<double>> own;
  std::vector<std::vector<double>>& sum = scratch ? *scratch : own;
  if (static_cast<int>(sum.size()) < top + 1) sum.resize(top + 1);
  std::vector<int> bw(top + 1), bh(top + 1);
  bw[0] = w;
  bh[0] = h;
  for (int m = 1; m <= top; ++m) {
    bw[m] = (bw[m - 1] + 1) / 2;
    bh[m] = (bh[m - 1] + 1) / 2;
    sum[m].resize(static_cast<std::size_t>(bw[m]) * bh[m]);  // every element written below
    core::parallel_for(
        bh[m],
        [&](int y0, int y1) {
          for (int y = y0; y < y1; ++y)
            for (int x = 0; x < bw[m]; ++x) {
              double v = 0.0;
              for (int cy = 2 * y; cy < std::min(2 * y + 2, bh[m - 1]); ++cy)
                for (int cx = 2 * x; cx < std::min(2 * x + 2, bw[m - 1]); ++cx)
                  v += m == 1 ? static_cast<double>(lum_at(static_cast<std::size_t>(cy) * w + cx))
                              : sum[m - 1][static_cast<std::size_t>(cy) * bw[m - 1] + cx];
              sum[m][static_cast<std::size_t>(y) * bw[m] + x] = v;
            }
        },
        8);
  }
  core::parallel_for(
      h,
      [&](int y0, int y1) {
        for (int y = y0; y < y1; ++y) {
          if (row_need[y] == 0) continue;
          for (int x = 0; x < w; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * w + x;
            const float rho = std::max(std::fabs(coc.plane(0)[i]), 0.5f);
            if (rho < r0) continue;
            const float l = lum_at(i);
            if (!(l > opt.highlight_abs)) continue;
            const int m = block_level(rho);
            const int bx = x >> m, by = y >> m, side = 1 << m;
            const double count = static_cast<double>(std::min(w, (bx + 1) * side) - bx * side) *
                                 static_cast<double>(std::min(h, (by + 1) * side) - by * side);
            const double mean = sum[m][static_cast<std::size_t>(by) * bw[m] + bx] / count;
            if (l > opt.highlight_rel * static_cast<float>(mean)) flags[i] |= bit;
          }
        }
      },
      8);
}

Fragments::Fragments(const Sources& s, const SlicePlan& plan, const LensOptions& opt) : src(s) {
  const int w = s.width(), h = s.height(), nf = s.count();
  n = static_cast<std::size_t>(w) * h;
  const std::size_t nn = n * nf;
  slice.resize(nn);
  t.resize(nn);
  inv_z.resize(nn);
  rho.resize(nn);
  sharp.resize(nn);
  weight.assign(nn, 1.0f);
  trans.assign(nn, 1.0f);
  exists.assign(nn, 0);
  direct.assign(nn, 0);
  auto inv = [](float z) { return std::isinf(z) ? 0.0f : 1.0f / z; };
  // "a clearly in front of b" in inverse depth (the reference's softness).
  const float soft = opt.depth_softness;
  auto in_front = [&](float ua, float ub) { return ub > 0 ? (ua - ub) >= soft * ub : ua > 0; };
  for (std::size_t i = 0; i < n; ++i) {
    const float u0 = inv(s.depth[0]->plane(0)[i]);
    float through = 1.0f;  // what the hidden fragments so far let through
    for (int f = 1; f < nf; ++f) {
      const std::size_t q = f * n + i;
      const float a = s.colour[f]->plane(3)[i];
      if (!in_front(u0, inv(s.depth[f]->plane(0)[i]))) {
        trans[q] = weight[q] = 0.0f;  // peeled with the visible surface
        continue;
      }
      trans[q] = through;
      weight[q] = a * through;
      through *= 1.0f - a;
    }
  }
  for (int f = 0; f < nf; ++f) {
    mark_direct(*s.colour[f], *s.coc[f], f > 0 ? &trans[f * n] : nullptr, opt, &direct[f * n], 1);
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t q = f * n + i;
      const float r = s.coc[f]->plane(0)[i];
      plan.member(r, slice[q], t[q]);
      inv_z[q] = inv(s.depth[f]->plane(0)[i]);
      rho[q] = std::max(std::fabs(r), 0.5f);
      sharp[q] = std::max(std::fabs(r) - 0.5f, 0.0f);
      exists[q] = f == 0 || weight[q] > 0.0f;
      if (exists[q]) rho_max = std::max(rho_max, rho[q]);
    }
  }
  pad = reach(rho_max) + 1;
  this->soft = soft;
}

SliceDepth::SliceDepth(const SlicePlan& plan, const std::vector<double>& mass, const std::vector<double>& u_sum) {
  const int k = plan.count();
  u.assign(k, 0.0f);
  sharp.assign(k, 0.0f);
  for (int j = 0; j < k; ++j) {
    u[j] = mass[j] > 0 ? static_cast<float>(u_sum[j] / mass[j]) : 0.0f;
    sharp[j] = std::max(std::fabs(plan.anchor[j]) - 0.5f, 0.0f);
  }
}

Receivers::Receivers(const Fragments& fr) {
  inv_z.assign(fr.inv_z.begin(), fr.inv_z.begin() + static_cast<std::ptrdiff_t>(fr.n));
  sharp.assign(fr.sharp.begin(), fr.sharp.begin() + static_cast<std::ptrdiff_t>(fr.n));
  isu.resize(fr.n);
  // 1 / (softness · inverse depth); a receiver at infinity: everything finite is in front.
  for (std::size_t i = 0; i < fr.n; ++i) isu[i] = inv_z[i] > 0 ? 1.0f / (fr.soft * inv_z[i]) : 1e30f;
}

HiddenPattern::HiddenPattern(int count) {
  const int g = count >= 64 ? 8 : 4;
  for (int j = 0; j < g; ++j)
    for (int i = 0; i < g; ++i) {
      double dx, dy;
      core::concentric_disc((i + 0.5) / g, (j + 0.5) / g, dx, dy);
      x_.push_back(static_cast<float>(dx));
      y_.push_back(static_cast<float>(dy));
    }
}

}  // namespace dofkit::detail::lens
