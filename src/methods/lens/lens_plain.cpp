// The plain form of `lens` (the oracle of the fast path; see lens.hpp, docs/methods/lens.md).
#include <algorithm>
#include <cmath>
#include <vector>

#include "core/sampling.hpp"
#include "methods/lens/lens.hpp"
#include "methods/reference/disc_scatter.hpp"

namespace dofkit::detail::lens {

namespace {

inline float sat(float v) { return std::min(std::max(v, 0.0f), 1.0f); }

// One slice's data at its level: the merged sources (colour sums, mass, radius sum) and the
// scattered sums (colour, weight).
struct SliceGrid {
  int level = 0, w = 0, h = 0;
  std::vector<float> src;  // 6 per cell: rgba·h, h, ρ·h  (ρ in frame px)
  std::vector<float> acc;  // 5 per cell: rgba, weight (energy landing in the cell)
  std::vector<float> hacc;  // highlights of a level >= 1 slice: 5 per frame pixel
  std::vector<float> hid;  // 5 per cell: hidden-background colour sum, sample mass
  double mass = 0, u_sum = 0;
};

inline int round_clamp(float v, int hi) {
  if (!(v >= 0.5f)) return 0;
  const float t = v + 0.5f;
  return t >= static_cast<float>(hi) ? hi : static_cast<int>(t);
}

// Bilinear sample (clamp to edge) of `n` interleaved channels at frame pixel (x, y).
void sample(const SliceGrid& g, const std::vector<float>& buf, int n, int x, int y, float* out) {
  const float s = 1.0f / static_cast<float>(1 << g.level);
  const float fx = (x + 0.5f) * s - 0.5f, fy = (y + 0.5f) * s - 0.5f;
  const float cx = std::clamp(fx, 0.0f, static_cast<float>(g.w - 1));
  const float cy = std::clamp(fy, 0.0f, static_cast<float>(g.h - 1));
  const int x0 = std::min(static_cast<int>(cx), g.w - 1), y0 = std::min(static_cast<int>(cy), g.h - 1);
  const int x1 = std::min(x0 + 1, g.w - 1), y1 = std::min(y0 + 1, g.h - 1);
  const float ax = cx - x0, ay = cy - y0;
  const float wt[4] = {(1 - ax) * (1 - ay), ax * (1 - ay), (1 - ax) * ay, ax * ay};
  const std::size_t idx[4] = {(static_cast<std::size_t>(y0) * g.w + x0) * n, (static_cast<std::size_t>(y0) * g.w + x1) * n,
                              (static_cast<std::size_t>(y1) * g.w + x0) * n, (static_cast<std::size_t>(y1) * g.w + x1) * n};
  for (int c = 0; c < n; ++c) {
    float v = 0;
    for (int k = 0; k < 4; ++k) v += wt[k] * buf[idx[k] + c];
    out[c] = v;
  }
}

}  // namespace

void render_plain(const Image& colour, const Image& depth, const Image& coc, const SlicePlan& plan,
                  const LensOptions& opt, Image& out, Image* cover) {
  const int w = colour.width(), h = colour.height();
  const std::size_t n = colour.plane_size();
  const int k = plan.count();
  const float soft = opt.depth_softness;

  // Per pixel: slice membership, inverse depth, radius.
  std::vector<int> sj(n);
  std::vector<float> st(n), inv_z(n), rho(n), sharp(n);
  for (std::size_t i = 0; i < n; ++i) {
    const float r = coc.plane(0)[i];
    plan.member(r, sj[i], st[i]);
    const float z = depth.plane(0)[i];
    inv_z[i] = std::isinf(z) ? 0.0f : 1.0f / z;
    rho[i] = std::max(std::fabs(r), 0.5f);
    sharp[i] = std::max(std::fabs(r) - 0.5f, 0.0f);
  }

  // Highlights: bright sources of reduced-resolution slices (luminance against the mean of
  // the 2^(L+2) block around them).
  std::vector<float> lum(n);
  for (std::size_t i = 0; i < n; ++i)
    lum[i] = 0.2126f * colour.plane(0)[i] + 0.7152f * colour.plane(1)[i] + 0.0722f * colour.plane(2)[i];
  std::vector<std::vector<float>> block_mean(opt.max_level + 1);
  for (int L = 1; L <= opt.max_level; ++L) {
    const int b = 1 << (L + 2), bw = (w + b - 1) / b, bh = (h + b - 1) / b;
    std::vector<double> sum(static_cast<std::size_t>(bw) * bh, 0.0), cnt(sum.size(), 0.0);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        sum[static_cast<std::size_t>(y / b) * bw + x / b] += lum[static_cast<std::size_t>(y) * w + x];
        cnt[static_cast<std::size_t>(y / b) * bw + x / b] += 1;
      }
    block_mean[L].resize(n);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        block_mean[L][static_cast<std::size_t>(y) * w + x] =
            static_cast<float>(sum[static_cast<std::size_t>(y / b) * bw + x / b] / cnt[static_cast<std::size_t>(y / b) * bw + x / b]);
  }
  auto is_highlight = [&](std::size_t i, int level) {
    return level > 0 && lum[i] > opt.highlight_abs && lum[i] > opt.highlight_rel * block_mean[level][i];
  };

  // Merged sources per slice at the slice's level.
  std::vector<SliceGrid> g(k);
  for (int j = 0; j < k; ++j) {
    g[j].level = plan.level[j];
    g[j].w = (w + (1 << g[j].level) - 1) >> g[j].level;
    g[j].h = (h + (1 << g[j].level) - 1) >> g[j].level;
    g[j].src.assign(static_cast<std::size_t>(g[j].w) * g[j].h * 6, 0.0f);
  }
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * w + x;
      for (int part = 0; part < 2; ++part) {
        const int j = sj[i] + part;
        const float hw = part ? st[i] : 1.0f - st[i];
        if (j >= k || hw <= 0.0f) continue;
        SliceGrid& s = g[j];
        s.mass += hw;
        s.u_sum += static_cast<double>(hw) * inv_z[i];
        if (is_highlight(i, s.level)) {
          // Scattered now, at full resolution, into the slice's highlight sums.
          if (s.hacc.empty()) s.hacc.assign(n * 5, 0.0f);
          const float r = rho[i];
          const float inv_area = static_cast<float>(1.0 / disc_area(r));
          const int ext = static_cast<int>(std::ceil(r + 0.5f)) - 1;
          const float c[5] = {colour.plane(0)[i], colour.plane(1)[i], colour.plane(2)[i], colour.plane(3)[i], 1.0f};
          for (int py = std::max(0, y - ext); py <= std::min(h - 1, y + ext); ++py)
            for (int px = std::max(0, x - ext); px <= std::min(w - 1, x + ext); ++px) {
              const float dx = static_cast<float>(px - x), dy = static_cast<float>(py - y);
              const float cov = sat(r - std::sqrt(dx * dx + dy * dy) + 0.5f);
              if (cov <= 0.0f) continue;
              float* a = &s.hacc[(static_cast<std::size_t>(py) * w + px) * 5];
              for (int ch = 0; ch < 5; ++ch) a[ch] += hw * cov * inv_area * c[ch];
            }
          continue;
        }
        float* c = &s.src[((static_cast<std::size_t>(y >> s.level)) * s.w + (x >> s.level)) * 6];
        for (int ch = 0; ch < 4; ++ch) c[ch] += hw * colour.plane(ch)[i];
        c[4] += hw;
        c[5] += hw * rho[i];
      }
    }

  // Scatter every merged source over its disc at the slice's level, energy-normalised.
  std::vector<float> slice_u(k, 0.0f), slice_sharp(k, 0.0f);
  for (int j = 0; j < k; ++j) {
    SliceGrid& s = g[j];
    slice_u[j] = s.mass > 0 ? static_cast<float>(s.u_sum / s.mass) : 0.0f;
    slice_sharp[j] = std::max(std::fabs(plan.anchor[j]) - 0.5f, 0.0f);
    if (s.mass <= 0) continue;
    s.acc.assign(static_cast<std::size_t>(s.w) * s.h * 5, 0.0f);
    const float scale = 1.0f / static_cast<float>(1 << s.level);
    for (int qy = 0; qy < s.h; ++qy)
      for (int qx = 0; qx < s.w; ++qx) {
        const float* c = &s.src[(static_cast<std::size_t>(qy) * s.w + qx) * 6];
        if (c[4] <= 0.0f) continue;
        const float rf = c[5] / c[4];
        // The box merge and the bilinear read-back blur by a variance of 4^L / 4 per axis; the
        // disc is shrunk to keep the total (a disc of radius ρ has ρ² / 4 per axis).
        const float r = std::max(std::sqrt(std::max(rf * rf - (s.level ? static_cast<float>(1 << (2 * s.level)) : 0.0f), 0.25f)) * scale, 0.5f);
        const float inv_area = static_cast<float>(1.0 / disc_area(r));
        const int ext = static_cast<int>(std::ceil(r + 0.5f)) - 1;
        for (int dy = -ext; dy <= ext; ++dy) {
          const int py = qy + dy;
          if (py < 0 || py >= s.h) continue;
          for (int dx = -ext; dx <= ext; ++dx) {
            const int px = qx + dx;
            if (px < 0 || px >= s.w) continue;
            const float cov = sat(r - std::sqrt(static_cast<float>(dx * dx + dy * dy)) + 0.5f);
            if (cov <= 0.0f) continue;
            float* a = &s.acc[(static_cast<std::size_t>(py) * s.w + px) * 5];
            const float wt = cov * inv_area;
            for (int ch = 0; ch < 5; ++ch) a[ch] += wt * c[ch];
          }
        }
      }
  }

  // Hidden background per slice: for the cells where slice j has sources, the mean colour of
  // the content of the slices behind it within the slice's radius (64 fixed samples of the
  // unit disc, as the reference).
  if (opt.hidden) {
    std::vector<float> ox, oy;
    constexpr int kGrid = 8;
    for (int jy = 0; jy < kGrid; ++jy)
      for (int ix = 0; ix < kGrid; ++ix) {
        double dx, dy;
        core::concentric_disc((ix + 0.5) / kGrid, (jy + 0.5) / kGrid, dx, dy);
        ox.push_back(static_cast<float>(dx));
        oy.push_back(static_cast<float>(dy));
      }
    for (int j = 0; j < k; ++j) {
      SliceGrid& s = g[j];
      if (s.mass <= 0) continue;
      // Content behind slice j at its level: rgba sums and mass of everything farther.
      std::vector<float> behind(static_cast<std::size_t>(s.w) * s.h * 5, 0.0f);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
          const std::size_t i = static_cast<std::size_t>(y) * w + x;
          const float hb = inv_z[i] < slice_u[j] * (1.0f - soft) ? 1.0f : 0.0f;
          if (hb <= 0.0f) continue;
          float* b = &behind[((static_cast<std::size_t>(y >> s.level)) * s.w + (x >> s.level)) * 5];
          for (int ch = 0; ch < 4; ++ch) b[ch] += hb * colour.plane(ch)[i];
          b[4] += hb;
        }
      s.hid.assign(static_cast<std::size_t>(s.w) * s.h * 5, 0.0f);
      const float scale = 1.0f / static_cast<float>(1 << s.level);
      for (int qy = 0; qy < s.h; ++qy)
        for (int qx = 0; qx < s.w; ++qx) {
          const float* c = &s.src[(static_cast<std::size_t>(qy) * s.w + qx) * 6];
          if (c[4] <= 0.0f) continue;
          const float r = c[5] / c[4] * scale;
          float sum[5] = {0, 0, 0, 0, 0};
          for (std::size_t t = 0; t < ox.size(); ++t) {
            const int bx = round_clamp(qx + ox[t] * r, s.w - 1), by = round_clamp(qy + oy[t] * r, s.h - 1);
            const float* b = &behind[(static_cast<std::size_t>(by) * s.w + bx) * 5];
            if (b[4] <= 0.0f) continue;
            for (int ch = 0; ch < 5; ++ch) sum[ch] += b[ch];
          }
          // Weighted by the slice's mass in the cell, so that interpolation between cells
          // and slices is a mean over sources.
          float* hd = &s.hid[(static_cast<std::size_t>(qy) * s.w + qx) * 5];
          if (sum[4] > 0)
            for (int ch = 0; ch < 5; ++ch) hd[ch] = (ch < 4 ? sum[ch] / sum[4] : 1.0f) * c[4];
        }
    }
  }

  // Receivers.
  out.resize(w, h, 4);
  if (cover) cover->resize(w, h, 4);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const std::size_t p = static_cast<std::size_t>(y) * w + x;
      const float up = inv_z[p], sp = sharp[p];
      const float isu = up > 0 ? 1.0f / (soft * up) : 1e30f;
      float F[5] = {0, 0, 0, 0, 0}, B[5] = {0, 0, 0, 0, 0}, H[5] = {0, 0, 0, 0, 0};
      for (int j = 0; j < k; ++j) {
        const SliceGrid& s = g[j];
        if (s.mass <= 0) continue;
        float v[5];
        sample(s, s.acc, 5, x, y, v);
        const float norm = 1.0f / static_cast<float>(1 << (2 * s.level));
        if (!s.hacc.empty())
          for (int ch = 0; ch < 5; ++ch) v[ch] += s.hacc[p * 5 + ch] / norm;
        const float rel = (slice_u[j] - up) * isu;
        const float front = sat(rel), behind = sat(-rel);
        const float inv_sq = slice_sharp[j] > 0 ? 1.0f / slice_sharp[j] : 1e30f;
        const float pass = std::min(sp * inv_sq, 1.0f);
        const float wt = norm * (1.0f - behind * (1.0f - pass));
        for (int ch = 0; ch < 5; ++ch) {
          F[ch] += wt * front * v[ch];
          B[ch] += wt * (1.0f - front) * v[ch];
        }
      }
      if (opt.hidden && sp > 0.0f) {
        const int jr = sj[p];
        for (int part = 0; part < 2; ++part) {
          const int j = jr + part;
          const float hw = part ? st[p] : 1.0f - st[p];
          if (j >= k || hw <= 0.0f || g[j].hid.empty()) continue;
          float v[5];
          sample(g[j], g[j].hid, 5, x, y, v);
          for (int ch = 0; ch < 5; ++ch) H[ch] += hw * v[ch];
        }
      }
      const bool has_hidden = H[4] > 1e-6f;
      const float fw = F[4], bw = B[4];
      const float missing = has_hidden ? std::max(0.0f, 1.0f - fw - bw) : 0.0f;
      if (cover) {
        cover->row(0, y)[x] = fw;
        cover->row(1, y)[x] = bw;
        cover->row(2, y)[x] = missing;
        cover->row(3, y)[x] = has_hidden ? H[1] / H[4] : -1.0f;
      }
      for (int ch = 0; ch < 4; ++ch) {
        float v;
        if (bw + missing > 0) {
          const float fs = fw > 1.0f ? 1.0f / fw : 1.0f;
          const float hc = has_hidden ? H[ch] / H[4] : 0.0f;
          const float back = (B[ch] + missing * hc) / (bw + missing);
          v = F[ch] * fs + (1.0f - std::min(fw, 1.0f)) * back;
        } else if (fw > 0) {
          v = F[ch] / fw;
        } else {
          v = colour.plane(ch)[p];
        }
        out.row(ch, y)[x] = v;
      }
    }
}

}  // namespace dofkit::detail::lens
