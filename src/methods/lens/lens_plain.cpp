// The plain form of `lens`: straightforward loops over the model of docs/methods/lens.md (the
// oracle of the fast path, lens_fast.cpp).
#include <algorithm>
#include <cmath>
#include <vector>

#include "methods/lens/footprint.hpp"
#include "methods/lens/lens.hpp"

namespace dofkit::detail::lens {

namespace {

inline float sat(float v) { return std::min(std::max(v, 0.0f), 1.0f); }

// One slice's grids at its level over the extended frame (margin cells on every side):
// merged sources (kM*), scattered sums (rgba, weight) and the hidden-background estimate
// (rgba · mass, mass).
enum { kMR, kMG, kMB, kMA, kMMass, kMAll, kMChannels };
struct SliceGrid {
  Grid grid;
  std::vector<float> merged;  // kMChannels per cell
  std::vector<float> acc;     // 5 per cell
  std::vector<float> est;     // 5 per cell
};

// Bilinear sample of `n` interleaved channels at frame pixel (x, y).
void sample(const Grid& g, const std::vector<float>& buf, int n, int x, int y, float* out) {
  float ax, ay;
  int x0, y0;
  g.locate(x, y, x0, y0, ax, ay);
  const float wt[4] = {(1 - ax) * (1 - ay), ax * (1 - ay), (1 - ax) * ay, ax * ay};
  const std::size_t idx[4] = {g.index(x0, y0) * n, g.index(x0 + 1, y0) * n, g.index(x0, y0 + 1) * n,
                              g.index(x0 + 1, y0 + 1) * n};
  for (int c = 0; c < n; ++c) {
    float v = 0;
    for (int k = 0; k < 4; ++k) v += wt[k] * buf[idx[k] + c];
    out[c] = v;
  }
}

}  // namespace

void render_plain(const Sources& src, const SlicePlan& plan, const LensOptions& opt, Image& out, Image* cover) {
  const int w = src.width(), h = src.height();
  const std::size_t n = static_cast<std::size_t>(w) * h;
  const int k = plan.count();
  const int nf = src.count();
  const float soft = opt.depth_softness;
  const Fragments fr(src, plan, opt);
  const std::size_t nn = n * nf;
  auto col = [&](std::size_t q, int ch) { return fr.colour(q, ch); };

  // Slices: the mean inverse depth of their members (every fragment), and per source set
  // (0: visible, 1: hidden) the merged sources at the slice's level over the extended frame
  // (mirror padding; the visible set also counts its real members' mass and radius, which
  // the hidden-background estimate uses).
  std::vector<double> mass(k, 0.0), u_sum(k, 0.0);
  for (std::size_t q = 0; q < nn; ++q)
    if (fr.exists[q])
      for (int part = 0; part < 2; ++part) {
        const int j = fr.slice[q] + part;
        const float hw = part ? fr.t[q] : 1.0f - fr.t[q];
        if (j >= k || hw <= 0.0f) continue;
        mass[j] += hw;
        u_sum[j] += static_cast<double>(hw) * fr.inv_z[q];
      }
  const SliceDepth sd(plan, mass, u_sum);
  std::vector<SliceGrid> g[2];
  for (int set = 0; set < 2; ++set) {
    g[set].resize(k);
    for (int j = 0; j < k; ++j) {
      SliceGrid& s = g[set][j];
      s.grid = Grid(w, h, plan.level[j], Grid::min_margin(fr.pad, plan.level[j]));
      if (set == 0 || nf > 1) s.merged.assign(s.grid.cells() * kMChannels, 0.0f);
    }
  }
  for (int f = 0; f < nf; ++f)
    for (int y = -fr.pad; y < h + fr.pad; ++y)
      for (int x = -fr.pad; x < w + fr.pad; ++x) {
        const std::size_t q = f * n + static_cast<std::size_t>(mirror(y, h)) * w + mirror(x, w);
        const bool real = x >= 0 && x < w && y >= 0 && y < h;
        if (!fr.exists[q]) continue;
        for (int part = 0; part < 2; ++part) {
          const int j = fr.slice[q] + part;
          const float hw = part ? fr.t[q] : 1.0f - fr.t[q];
          if (j >= k || hw <= 0.0f) continue;
          SliceGrid& s = g[f > 0][j];
          if (!s.grid.covers(x, y)) continue;
          float* c = &s.merged[s.grid.cell_of(x, y) * kMChannels];
          if (f == 0 && real) c[kMAll] += hw;
          if (fr.direct[q]) continue;
          for (int ch = 0; ch < 4; ++ch) c[ch] += hw * col(q, ch);
          c[kMMass] += hw * fr.weight[q];
        }
      }

  // Merged sources: one footprint each at the slice's level (the slice's radius),
  // energy-normalised.
  TapTable taps;
  for (int set = 0; set < 2; ++set)
    for (int j = 0; j < k; ++j) {
      SliceGrid& s = g[set][j];
      if (s.merged.empty()) continue;
      const Grid& gr = s.grid;
      const int ri = slice_radius_index(plan, j);
      taps.prepare(radius_of_index(ri), opt.shape);
      for (int qy = 0; qy < gr.h; ++qy)
        for (int qx = 0; qx < gr.w; ++qx) {
          const float* c = &s.merged[(static_cast<std::size_t>(qy) * gr.w + qx) * kMChannels];
          if (c[kMMass] <= 0.0f) continue;
          if (s.acc.empty()) s.acc.assign(gr.cells() * 5, 0.0f);
          const Taps& t = taps.at(ri, plan.anchor[j] > 0.0f);
          for (int dy = -t.n; dy <= t.n; ++dy) {
            const int py = qy + dy;
            if (py < 0 || py >= gr.h) continue;
            const int row = dy + t.n;
            for (int e = 0; e < t.len[row]; ++e) {
              const int px = qx + t.x0[row] + e;
              if (px < 0 || px >= gr.w) continue;
              const float wt = t.w[t.off[row] + e];
              float* a = &s.acc[(static_cast<std::size_t>(py) * gr.w + px) * 5];
              for (int ch = 0; ch < 5; ++ch) a[ch] += wt * c[ch];
            }
          }
        }
    }

  // Hidden-background estimate per slice and cell (visible set): the mean colour of the
  // visible pixels clearly behind the slice, summed per cell, at fixed samples within the
  // members' mean radius of the cell.
  const HiddenPattern pattern;
  if (opt.hidden)
    for (int j = 0; j < k; ++j) {
      SliceGrid& s = g[0][j];
      if (mass[j] <= 0) continue;
      const Grid& gr = s.grid;
      const float limit = sd.u[j] * (1.0f - soft);
      std::vector<float> behind(gr.cells() * 5, 0.0f);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
          const std::size_t i = static_cast<std::size_t>(y) * w + x;
          if (!(fr.inv_z[i] < limit)) continue;
          float* b = &behind[gr.cell_of(x, y) * 5];
          for (int ch = 0; ch < 4; ++ch) b[ch] += col(i, ch);
          b[4] += 1.0f;
        }
      const float r = std::max(std::fabs(plan.anchor[j]), 0.5f) / static_cast<float>(1 << gr.level);
      if (r <= 0.5f) continue;  // in-focus receivers are opaque
      for (int qy = gr.margin; qy < gr.margin + gr.frame_h; ++qy)
        for (int qx = gr.margin; qx < gr.margin + gr.frame_w; ++qx) {
          const float* c = &s.merged[(static_cast<std::size_t>(qy) * gr.w + qx) * kMChannels];
          if (c[kMAll] <= 0.0f) continue;
          float sum[5] = {0, 0, 0, 0, 0};
          for (int t = 0; t < pattern.count(); ++t) {
            // The sample as a whole-cell offset (the same for every cell), clamped to the frame.
            const int dx = static_cast<int>(std::floor(pattern.x(t) * r + 0.5f));
            const int dy = static_cast<int>(std::floor(pattern.y(t) * r + 0.5f));
            const int bx = gr.margin + std::clamp(qx - gr.margin + dx, 0, gr.frame_w - 1);
            const int by = gr.margin + std::clamp(qy - gr.margin + dy, 0, gr.frame_h - 1);
            const float* b = &behind[(static_cast<std::size_t>(by) * gr.w + bx) * 5];
            for (int ch = 0; ch < 5; ++ch) sum[ch] += b[ch];
          }
          if (sum[4] <= 0.0f) continue;
          if (s.est.empty()) s.est.assign(gr.cells() * 5, 0.0f);
          float* e = &s.est[(static_cast<std::size_t>(qy) * gr.w + qx) * 5];
          for (int ch = 0; ch < 4; ++ch) e[ch] = sum[ch] / sum[4] * c[kMAll];
          e[4] = c[kMAll];
        }
    }

  // Receivers (layer 0): F (in front), B (own surface and behind) and the fill from hidden
  // fragments, rgba + weight each.
  std::vector<float> acc(n * 15, 0.0f);
  const Receivers rc(fr);
  // Direct sources: one full-resolution footprint each (mirror-padded frame), exact weights.
  InverseArea inv_area;
  inv_area.prepare(fr.rho_max + 1.0f, opt.shape);
  for (int f = 0; f < nf; ++f)
    for (int qy = -fr.pad; qy < h + fr.pad; ++qy)
      for (int qx = -fr.pad; qx < w + fr.pad; ++qx) {
        const std::size_t q = f * n + static_cast<std::size_t>(mirror(qy, h)) * w + mirror(qx, w);
        if (!fr.exists[q] || !fr.direct[q]) continue;
        const float rq = fr.rho[q], ws = inv_area(rq);
        const float c[5] = {col(q, 0), col(q, 1), col(q, 2), col(q, 3), fr.weight[q]};
        const Source sq{fr.inv_z[q], fr.sharp[q]};
        const bool near = src.coc[f]->plane(0)[q % n] > 0.0f;
        const int e = opt.shape.reach(rq);
        for (int py = std::max(0, qy - e); py <= std::min(h - 1, qy + e); ++py)
          for (int px = std::max(0, qx - e); px <= std::min(w - 1, qx + e); ++px) {
            const float cov = opt.shape.coverage(rq, px - qx, py - qy, near);
            if (cov <= 0.0f) continue;
            const std::size_t p = static_cast<std::size_t>(py) * w + px;
            add_source(rc, p, f > 0, sq, cov * ws, c, &acc[p * 15]);
          }
      }

  out.resize(w, h, 4);
  if (cover) cover->resize(w, h, 4);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const std::size_t p = static_cast<std::size_t>(y) * w + x;
      float* a = &acc[p * 15];
      // Slices: the same rule with the slice's mean inverse depth and anchor sharpness.
      for (int set = 0; set < 2; ++set)
        for (int j = 0; j < k; ++j) {
          const SliceGrid& s = g[set][j];
          if (s.acc.empty()) continue;
          float v[5];
          sample(s.grid, s.acc, 5, x, y, v);
          add_source(rc, p, set > 0, {sd.u[j], sd.sharp[j]}, 1.0f / static_cast<float>(1 << (2 * s.grid.level)), v, a);
        }
      float est[5] = {0, 0, 0, 0, 0};
      if (opt.hidden && fr.sharp[p] > 0.0f)
        for (int part = 0; part < 2; ++part) {
          const int j = fr.slice[p] + part;
          const float hw = part ? fr.t[p] : 1.0f - fr.t[p];
          if (j >= k || hw <= 0.0f || g[0][j].est.empty()) continue;
          float v[5];
          sample(g[0][j].grid, g[0][j].est, 5, x, y, v);
          for (int ch = 0; ch < 5; ++ch) est[ch] += hw * v[ch];
        }
      float px[4];
      const float m = composite(a, est, a + 10, col(p, 0), col(p, 1), col(p, 2), col(p, 3), px);
      for (int ch = 0; ch < 4; ++ch) out.row(ch, y)[x] = px[ch];
      if (cover) {
        cover->row(0, y)[x] = a[4];
        cover->row(1, y)[x] = a[9];
        cover->row(2, y)[x] = m;
        cover->row(3, y)[x] = 1.0f;
      }
    }
}

}  // namespace dofkit::detail::lens
