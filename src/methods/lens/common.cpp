#include "methods/lens/common.hpp"

#include "core/parallel.hpp"
#include "core/sampling.hpp"

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
