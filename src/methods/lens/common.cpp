#include "methods/lens/common.hpp"

#include <algorithm>
#include <cmath>

#include "core/parallel.hpp"
#include "core/sampling.hpp"

namespace dofkit::detail::lens {

void mark_direct(const Image& colour, const Image& coc, const float* trans, const LensOptions& opt, std::uint8_t* flags,
                 std::uint8_t bit, std::vector<std::vector<double>>* scratch) {
  const int w = colour.width(), h = colour.height();
  const float r0 = opt.direct_px();
  std::vector<std::vector<double>> own;
  std::vector<std::vector<double>>& sum = scratch ? *scratch : own;
  if (sum.size() < 2) sum.resize(2);
  // Block sums of the luminance, level m from level m − 1 (children (0,0), (1,0), (0,1),
  // (1,1) in that order, in double): level 1 here, in the pass that reads the colour once.
  std::vector<int> bw(1, w), bh(1, h);
  bw.push_back((w + 1) / 2);
  bh.push_back((h + 1) / 2);
  sum[1].resize(static_cast<std::size_t>(bw[1]) * bh[1]);
  // Highlight candidates (radius >= r0, luminance above highlight_abs) per pair of rows.
  struct Candidate {
    int x, y, m;
    float lum;
  };
  std::vector<std::vector<Candidate>> cand(bh[1]);
  core::parallel_for(
      bh[1],
      [&](int p0, int p1) {
        for (int yy = p0; yy < p1; ++yy) {
          double* s1 = &sum[1][static_cast<std::size_t>(yy) * bw[1]];
          std::fill(s1, s1 + bw[1], 0.0);
          cand[yy].clear();
          for (int y = 2 * yy; y < std::min(h, 2 * yy + 2); ++y) {
            const float* r = colour.row(0, y);
            const float* g = colour.row(1, y);
            const float* b = colour.row(2, y);
            const float* c = coc.row(0, y);
            const float* tr = trans ? trans + static_cast<std::size_t>(y) * w : nullptr;
            std::uint8_t* fl = flags + static_cast<std::size_t>(y) * w;
            for (int x = 0; x < w; ++x) {
              const float sc = tr ? tr[x] : 1.0f;
              const float l = luminance(r[x] * sc, g[x] * sc, b[x] * sc);
              s1[x >> 1] += static_cast<double>(l);
              const float rho = std::max(std::fabs(c[x]), 0.5f);
              if (rho < r0)
                fl[x] |= bit;
              else if (l > opt.highlight_abs)
                cand[yy].push_back({x, y, block_level(rho), l});
            }
          }
        }
      },
      4);
  int top = 0;
  for (const auto& c : cand)
    for (const Candidate& k : c) top = std::max(top, k.m);
  if (top == 0) return;
  if (static_cast<int>(sum.size()) < top + 1) sum.resize(top + 1);
  for (int m = 2; m <= top; ++m) {
    bw.push_back((bw[m - 1] + 1) / 2);
    bh.push_back((bh[m - 1] + 1) / 2);
    sum[m].resize(static_cast<std::size_t>(bw[m]) * bh[m]);  // every element written below
    core::parallel_for(
        bh[m],
        [&](int y0, int y1) {
          for (int y = y0; y < y1; ++y)
            for (int x = 0; x < bw[m]; ++x) {
              double v = 0.0;
              for (int cy = 2 * y; cy < std::min(2 * y + 2, bh[m - 1]); ++cy)
                for (int cx = 2 * x; cx < std::min(2 * x + 2, bw[m - 1]); ++cx)
                  v += sum[m - 1][static_cast<std::size_t>(cy) * bw[m - 1] + cx];
              sum[m][static_cast<std::size_t>(y) * bw[m] + x] = v;
            }
        },
        8);
  }
  core::parallel_for(
      bh[1],
      [&](int p0, int p1) {
        for (int yy = p0; yy < p1; ++yy)
          for (const Candidate& k : cand[yy]) {
            const int m = k.m;
            if (m == 0) {  // a one-pixel block: the pixel itself
              if (k.lum > opt.highlight_rel * k.lum) flags[static_cast<std::size_t>(k.y) * w + k.x] |= bit;
              continue;
            }
            const int bx = k.x >> m, by = k.y >> m, side = 1 << m;
            const double count = static_cast<double>(std::min(w, (bx + 1) * side) - bx * side) *
                                 static_cast<double>(std::min(h, (by + 1) * side) - by * side);
            const double mean = sum[m][static_cast<std::size_t>(by) * bw[m] + bx] / count;
            if (k.lum > opt.highlight_rel * static_cast<float>(mean))
              flags[static_cast<std::size_t>(k.y) * w + k.x] |= bit;
          }
      },
      16);
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
  pad = opt.shape.reach(rho_max) + 1;
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

HiddenPattern::HiddenPattern() {
  constexpr int g = 8;
  for (int j = 0; j < g; ++j)
    for (int i = 0; i < g; ++i) {
      double dx, dy;
      core::concentric_disc((i + 0.5) / g, (j + 0.5) / g, dx, dy);
      x_.push_back(static_cast<float>(dx));
      y_.push_back(static_cast<float>(dy));
    }
}

}  // namespace dofkit::detail::lens
