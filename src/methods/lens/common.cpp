#include "methods/lens/common.hpp"

#include "core/parallel.hpp"
#include "core/sampling.hpp"

#include <cmath>

namespace dofkit::detail::lens {

std::vector<std::uint8_t> direct_sources(const float* rho, const float* lum, int w, int h, const LensOptions& opt) {
  const std::size_t n = static_cast<std::size_t>(w) * h;
  std::vector<std::uint8_t> direct(n, 0);
  const float r0 = opt.direct_px();
  // Block means of the luminance, level m = blocks of side 2^m, built from level m − 1 (sums
  // in double, in a fixed order), only as far as a highlight candidate needs.
  std::vector<std::vector<double>> sum(1), cnt(1);
  std::vector<int> bw(1, w), bh(1, h);
  sum[0].assign(lum, lum + n);
  cnt[0].assign(n, 1.0);
  auto level = [&](int m) {
    while (static_cast<int>(sum.size()) <= m) {
      const int l = static_cast<int>(sum.size());
      const int pw = bw[l - 1], ph = bh[l - 1], cw = (pw + 1) / 2, chh = (ph + 1) / 2;
      std::vector<double> s(static_cast<std::size_t>(cw) * chh, 0.0), c(s.size(), 0.0);
      for (int y = 0; y < ph; ++y)
        for (int x = 0; x < pw; ++x) {
          s[static_cast<std::size_t>(y / 2) * cw + x / 2] += sum[l - 1][static_cast<std::size_t>(y) * pw + x];
          c[static_cast<std::size_t>(y / 2) * cw + x / 2] += cnt[l - 1][static_cast<std::size_t>(y) * pw + x];
        }
      sum.push_back(std::move(s));
      cnt.push_back(std::move(c));
      bw.push_back(cw);
      bh.push_back(chh);
    }
  };
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * w + x;
      if (rho[i] < r0) {
        direct[i] = 1;
        continue;
      }
      if (!(lum[i] > opt.highlight_abs)) continue;
      int m = 0;
      while (static_cast<float>(1 << m) < 2.0f * rho[i] && m < 24) ++m;
      level(m);
      const int bx = x >> m, by = y >> m;
      const std::size_t b = static_cast<std::size_t>(by) * bw[m] + bx;
      if (lum[i] > opt.highlight_rel * static_cast<float>(sum[m][b] / cnt[m][b])) direct[i] = 1;
    }
  return direct;
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
  std::vector<float> lum(n);
  for (int f = 0; f < nf; ++f) {
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t q = f * n + i;
      const float r = s.coc[f]->plane(0)[i];
      plan.member(r, slice[q], t[q]);
      inv_z[q] = inv(s.depth[f]->plane(0)[i]);
      rho[q] = std::max(std::fabs(r), 0.5f);
      sharp[q] = std::max(std::fabs(r) - 0.5f, 0.0f);
      exists[q] = f == 0 || weight[q] > 0.0f;
      if (exists[q]) rho_max = std::max(rho_max, rho[q]);
      lum[i] = luminance(colour(q, 0), colour(q, 1), colour(q, 2));
    }
    const std::vector<std::uint8_t> d = direct_sources(&rho[f * n], lum.data(), w, h, opt);
    std::copy(d.begin(), d.end(), direct.begin() + static_cast<std::ptrdiff_t>(f * n));
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
