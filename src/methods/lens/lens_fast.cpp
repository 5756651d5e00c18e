// The fast form of `lens` (docs/methods/lens.md): the model of lens_plain.cpp, organised for
// speed and memory. Per frame:
//   1. prep (rows in parallel): each fragment's slice and hat weight, direct / exists flags,
//      the slices' mean inverse depths and row ranges;
//   2. merge (blocks of rows aligned to the coarsest level, in parallel): every slice's merged
//      sources at its level, only over the cell rows it occupies (mirror-padded frame);
//   3. per slice, the convolution of its merged sources with its footprint (rows in parallel)
//      and the hidden-background estimate of its cells;
//   4. tiles of the frame (in parallel): the direct sources' exact pairs, every slice's sums
//      read back bilinearly, the estimate, and the composite.
// Each output value is computed by one task in a fixed order, so the result is the same for
// any thread count. Tested against the plain form (tests/lens/).
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <vector>

#include <tbb/enumerable_thread_specific.h>

#include "core/clones.hpp"
#include "core/parallel.hpp"
#include "core/pass_profile.hpp"
#include "methods/lens/footprint.hpp"
#include "methods/lens/kernels.hpp"
#include "methods/lens/lens.hpp"

namespace dofkit::detail::lens {

namespace {

constexpr std::uint8_t kExists = 1, kDirect = 2;
constexpr int kTileRows = 16, kTileCols = 256;
constexpr int kRowBlock = 16;  // prep rows per task

inline float inv_depth(float z) { return std::isinf(z) ? 0.0f : 1.0f / z; }

// Per fragment (f·n + pixel) what the passes need; the rest is recomputed from the inputs.
struct Prep {
  int w = 0, h = 0, nf = 1, k = 0;
  std::size_t n = 0;
  std::vector<std::int16_t> slice;
  std::vector<float> t;
  std::vector<std::uint8_t> flags;
  std::vector<float> weight, trans;  // layers >= 1 only: index (f − 1)·n + i
  float rho_max = 0.5f;
  int pad = 1;
  std::vector<double> mass, u_sum;
  std::vector<int> lo[2], hi[2];  // per set and slice: rows holding members (lo > hi: none)
  // Highlights (direct sources with radius >= direct_px): per padded row y' in [−pad, h + pad),
  // their padded x' and fragment index, in row order (CSR: row y' at hl_start[y' + pad]).
  std::vector<int> hl_start;
  std::vector<int> hl_x;
  std::vector<std::size_t> hl_q;

  float weight_of(std::size_t q) const { return q < n ? 1.0f : weight[q - n]; }
  float trans_of(std::size_t q) const { return q < n ? 1.0f : trans[q - n]; }
};

void prepare(const Sources& src, const SlicePlan& plan, const LensOptions& opt, Prep& pr) {
  const int w = src.width(), h = src.height(), nf = src.count(), k = plan.count();
  pr.w = w;
  pr.h = h;
  pr.nf = nf;
  pr.k = k;
  pr.n = static_cast<std::size_t>(w) * h;
  const std::size_t n = pr.n, nn = n * nf;
  pr.slice.resize(nn);
  pr.t.resize(nn);
  pr.flags.assign(nn, 0);
  if (nf > 1) {
    pr.weight.assign(n * (nf - 1), 0.0f);
    pr.trans.assign(n * (nf - 1), 0.0f);
    // Hidden fragments (Fragments in common.cpp): peeled with the visible surface unless
    // clearly behind it; then what the hidden ones in front let through.
    const float soft = opt.depth_softness;
    core::parallel_for(
        h,
        [&](int y0, int y1) {
          for (std::size_t i = static_cast<std::size_t>(y0) * w; i < static_cast<std::size_t>(y1) * w; ++i) {
            const float u0 = inv_depth(src.depth[0]->plane(0)[i]);
            float through = 1.0f;
            for (int f = 1; f < nf; ++f) {
              const float uf = inv_depth(src.depth[f]->plane(0)[i]);
              const bool behind = uf > 0 ? (u0 - uf) >= soft * uf : u0 > 0;
              const std::size_t hq = (f - 1) * n + i;
              if (!behind) continue;
              const float a = src.colour[f]->plane(3)[i];
              pr.trans[hq] = through;
              pr.weight[hq] = a * through;
              through *= 1.0f - a;
            }
          }
        },
        8);
  }
  for (int f = 0; f < nf; ++f)
    mark_direct(*src.colour[f], *src.coc[f], f > 0 ? &pr.trans[(f - 1) * n] : nullptr, opt, &pr.flags[f * n],
                kDirect);
  // Slices, existence, per-block sums (combined in block order: deterministic).
  const int blocks = (h + kRowBlock - 1) / kRowBlock;
  std::vector<double> bmass(static_cast<std::size_t>(blocks) * k, 0.0), bu(bmass.size(), 0.0);
  std::vector<int> blo[2], bhi[2];
  for (int s = 0; s < 2; ++s) {
    blo[s].assign(static_cast<std::size_t>(blocks) * k, h);
    bhi[s].assign(static_cast<std::size_t>(blocks) * k, -1);
  }
  std::vector<float> brho(blocks, 0.5f);
  core::parallel_for(blocks, [&](int b0, int b1) {
    for (int b = b0; b < b1; ++b) {
      double* ms = &bmass[static_cast<std::size_t>(b) * k];
      double* us = &bu[static_cast<std::size_t>(b) * k];
      float rmax = 0.5f;
      for (int y = b * kRowBlock; y < std::min(h, (b + 1) * kRowBlock); ++y)
        for (int f = 0; f < nf; ++f) {
          const float* coc = src.coc[f]->row(0, y);
          const float* z = src.depth[f]->row(0, y);
          const int s = f > 0;
          for (int x = 0; x < w; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * w + x, q = f * n + i;
            const bool exists = f == 0 || pr.weight[q - n] > 0.0f;
            int j;
            float tt;
            plan.member(coc[x], j, tt);
            pr.slice[q] = static_cast<std::int16_t>(j);
            pr.t[q] = tt;
            if (!exists) {
              pr.flags[q] = 0;
              continue;
            }
            pr.flags[q] |= kExists;
            rmax = std::max(rmax, std::max(std::fabs(coc[x]), 0.5f));
            const float u = inv_depth(z[x]);
            for (int part = 0; part < 2; ++part) {
              const int jj = j + part;
              const float hw = part ? tt : 1.0f - tt;
              if (jj >= k || hw <= 0.0f) continue;
              ms[jj] += hw;
              us[jj] += static_cast<double>(hw) * u;
              int& l = blo[s][static_cast<std::size_t>(b) * k + jj];
              int& hh = bhi[s][static_cast<std::size_t>(b) * k + jj];
              l = std::min(l, y);
              hh = std::max(hh, y);
            }
          }
        }
      brho[b] = rmax;
    }
  });
  pr.mass.assign(k, 0.0);
  pr.u_sum.assign(k, 0.0);
  for (int s = 0; s < 2; ++s) {
    pr.lo[s].assign(k, h);
    pr.hi[s].assign(k, -1);
  }
  pr.rho_max = 0.5f;
  for (int b = 0; b < blocks; ++b) {
    for (int j = 0; j < k; ++j) {
      const std::size_t bj = static_cast<std::size_t>(b) * k + j;
      pr.mass[j] += bmass[bj];
      pr.u_sum[j] += bu[bj];
      for (int s = 0; s < 2; ++s) {
        pr.lo[s][j] = std::min(pr.lo[s][j], blo[s][bj]);
        pr.hi[s][j] = std::max(pr.hi[s][j], bhi[s][bj]);
      }
    }
    pr.rho_max = std::max(pr.rho_max, brho[b]);
  }
  pr.pad = reach(pr.rho_max) + 1;
  // Highlights: direct sources too large for the tiles' small-source window.
  const float r0 = opt.direct_px();
  const int pad = pr.pad;
  pr.hl_start.assign(static_cast<std::size_t>(h + 2 * pad) + 1, 0);
  pr.hl_x.clear();
  pr.hl_q.clear();
  for (int yp = -pad; yp < h + pad; ++yp) {
    const int y = mirror(yp, h);
    for (int f = 0; f < nf; ++f) {
      const float* coc = src.coc[f]->row(0, y);
      for (int xp = -pad; xp < w + pad; ++xp) {
        const int x = mirror(xp, w);
        const std::size_t q = f * n + static_cast<std::size_t>(y) * w + x;
        if ((pr.flags[q] & (kExists | kDirect)) != (kExists | kDirect)) continue;
        if (std::max(std::fabs(coc[x]), 0.5f) < r0) continue;
        pr.hl_x.push_back(xp);
        pr.hl_q.push_back(q);
      }
    }
    pr.hl_start[static_cast<std::size_t>(yp + pad) + 1] = static_cast<int>(pr.hl_x.size());
  }
}

// One slice's buffers (per source set): planar rows of its grid.
struct SliceBuf {
  Grid grid;
  bool used = false;
  int m0 = 0, m1 = 0;  // merged rows [m0, m1)
  int a0 = 0, a1 = 0;  // acc rows [a0, a1)
  int ri = 0, reach = 0;
  float* merged = nullptr;  // kMChannels planes of (m1 − m0)·grid.w
  float* acc = nullptr;     // 5 planes of (a1 − a0)·grid.w
  float* est = nullptr;     // 5 planes of (m1 − m0)·grid.w (set 0, estimate on)
  std::vector<int> mlo, mhi;  // per merged row: columns with sources
  std::vector<int> alo, ahi;  // per acc row: columns with sums
  bool any_est = false;
  std::size_t mplane() const { return static_cast<std::size_t>(m1 - m0) * grid.w; }
  std::size_t aplane() const { return static_cast<std::size_t>(a1 - a0) * grid.w; }
  float* mrow(int c, int y) const { return merged + c * mplane() + static_cast<std::size_t>(y - m0) * grid.w; }
  float* arow(int c, int y) const { return acc + c * aplane() + static_cast<std::size_t>(y - a0) * grid.w; }
  float* erow(int c, int y) const { return est + c * mplane() + static_cast<std::size_t>(y - m0) * grid.w; }
};
enum { kMR, kMG, kMB, kMA, kMMass, kMAll, kMChannels };

// acc[x] += wt · src[x] for x in [0, n).
DOFKIT_CLONES
void axpy(float* __restrict acc, const float* __restrict src, float wt, int n) {
  for (int x = 0; x < n; ++x) acc[x] += wt * src[x];
}

}  // namespace

namespace {
// Per-thread scratch of the tile pass.
struct TileScratch {
  std::vector<float> acc, est, rcv, outp, vrow;
  std::vector<std::int32_t> rslice;
};
// Everything kept from frame to frame (a Renderer's workspace object).
struct State {
  Prep pr;
  InverseArea inv_area;
  TapTable taps;
  std::vector<float> arena, behind;
  tbb::enumerable_thread_specific<TileScratch> scratch;
};
}  // namespace

void render_fast(const Sources& src, const SlicePlan& plan, const LensOptions& opt, Workspace& ws, Image& out,
                 Image* cover) {
  const int w = src.width(), h = src.height(), nf = src.count(), k = plan.count();
  const float soft = opt.depth_softness;
  State& st = ws.object<State>("lens.state");
  Prep& pr = st.pr;
  {
    core::PassScope pass("prep");
    prepare(src, plan, opt, pr);
  }
  const std::size_t n = pr.n;
  const SliceDepth sd(plan, pr.mass, pr.u_sum);
  int lmax = 1;
  for (int j = 0; j < k; ++j) lmax = std::max(lmax, plan.level[j]);
  // A common origin of every level's cells, −origin px, a multiple of the coarsest cell.
  const int unit = 1 << lmax;
  const int origin = (pr.pad + unit - 1) / unit * unit + unit;
  const int pad = pr.pad;

  // Buffers: per set and slice, the rows its members (and their mirror copies) occupy.
  std::vector<SliceBuf> sb[2];
  TapTable& taps = st.taps;
  std::size_t total = 0;
  for (int s = 0; s < 2; ++s) {
    sb[s].resize(k);
    for (int j = 0; j < k; ++j) {
      SliceBuf& b = sb[s][j];
      if (pr.lo[s][j] > pr.hi[s][j]) continue;
      const int L = plan.level[j];
      b.grid = Grid(w, h, L, origin >> L);
      b.used = true;
      // Padded rows that show a member row: the rows themselves and their mirror copies.
      int lo = pr.lo[s][j], hi = pr.hi[s][j];
      if (lo < pad) lo = std::min(lo, -1 - std::min(hi, pad - 1));
      if (hi >= h - pad) hi = std::max(hi, 2 * h - 1 - std::max(pr.lo[s][j], h - pad));
      lo = std::max(lo, -pad);
      hi = std::min(hi, h + pad - 1);
      b.m0 = (lo + origin) >> L;
      b.m1 = ((hi + origin) >> L) + 1;
      b.ri = slice_radius_index(plan, j);
      taps.prepare(radius_of_index(b.ri));
      b.reach = taps[b.ri].n;
      b.a0 = std::max(0, b.m0 - b.reach);
      b.a1 = std::min(b.grid.h, b.m1 + b.reach);
      total += b.mplane() * kMChannels + b.aplane() * 5 + (s == 0 && opt.hidden ? b.mplane() * 5 : 0);
      b.mlo.assign(b.m1 - b.m0, b.grid.w);
      b.mhi.assign(b.m1 - b.m0, -1);
      b.alo.assign(b.a1 - b.a0, b.grid.w);
      b.ahi.assign(b.a1 - b.a0, -1);
    }
  }
  if (getenv("LENS_DEBUG")) {
    fprintf(stderr, "lens: %d slices, pad %d origin %d, arena %.1f M floats\n", k, pad, origin, total / 1e6);
    for (int s = 0; s < 2; ++s)
      for (int j = 0; j < k; ++j)
        if (sb[s][j].used)
          fprintf(stderr, "  set %d slice %d a=%.2f L=%d grid %dx%d merged rows %d acc rows %d ri %d reach %d\n", s, j,
                  plan.anchor[j], plan.level[j], sb[s][j].grid.w, sb[s][j].grid.h, sb[s][j].m1 - sb[s][j].m0,
                  sb[s][j].a1 - sb[s][j].a0, sb[s][j].ri, sb[s][j].reach);
  }
  // One arena for all grids.
  if (st.arena.size() < total + 1) st.arena.resize(total + 1);
  {
    float* p = st.arena.data();
    for (int s = 0; s < 2; ++s)
      for (int j = 0; j < k; ++j) {
        SliceBuf& b = sb[s][j];
        if (!b.used) continue;
        b.merged = p;
        p += b.mplane() * kMChannels;
        b.acc = p;
        p += b.aplane() * 5;
        if (s == 0 && opt.hidden) {
          b.est = p;
          p += b.mplane() * 5;
        }
      }
  }

  // 2. Merge. Blocks of `unit` padded rows starting at −origin: every level's cell rows lie
  // wholly in one block, so each cell is written by one task.
  {
    core::PassScope pass("merge");
    for (int s = 0; s < 2; ++s)
      for (int j = 0; j < k; ++j)
        if (sb[s][j].used) std::fill(sb[s][j].merged, sb[s][j].merged + sb[s][j].mplane() * kMChannels, 0.0f);
    const int rows = h + 2 * origin;
    const int blocks = (rows + unit - 1) / unit;
    core::parallel_for(blocks, [&](int b0, int b1) {
      for (int b = b0; b < b1; ++b)
        for (int yp = -origin + b * unit; yp < -origin + (b + 1) * unit; ++yp) {
          if (yp < -pad || yp >= h + pad) continue;
          const int y = mirror(yp, h);
          const bool real_row = yp >= 0 && yp < h;
          for (int f = 0; f < nf; ++f) {
            const int set = f > 0;
            const float* col[4];
            for (int c = 0; c < 4; ++c) col[c] = src.colour[f]->row(c, y);
            for (int xp = -pad; xp < w + pad; ++xp) {
              const int x = mirror(xp, w);
              const std::size_t i = static_cast<std::size_t>(y) * w + x, q = f * n + i;
              const std::uint8_t fl = pr.flags[q];
              if (!(fl & kExists)) continue;
              const int j = pr.slice[q];
              const float tt = pr.t[q];
              const bool real = real_row && xp >= 0 && xp < w;
              const float tr = pr.trans_of(q), wt = pr.weight_of(q);
              for (int part = 0; part < 2; ++part) {
                const int jj = j + part;
                const float hw = part ? tt : 1.0f - tt;
                if (jj >= k || hw <= 0.0f) continue;
                SliceBuf& sbuf = sb[set][jj];
                const int L = sbuf.grid.level;
                const int Y = (yp + origin) >> L, X = (xp + origin) >> L;
                const std::size_t off = static_cast<std::size_t>(Y - sbuf.m0) * sbuf.grid.w + X;
                const std::size_t pl = sbuf.mplane();
                if (f == 0 && real) sbuf.merged[kMAll * pl + off] += hw;
                if (fl & kDirect) continue;
                for (int c = 0; c < 4; ++c) sbuf.merged[c * pl + off] += hw * col[c][x] * tr;
                sbuf.merged[kMMass * pl + off] += hw * wt;
                int& lo = sbuf.mlo[Y - sbuf.m0];
                int& hi = sbuf.mhi[Y - sbuf.m0];
                lo = std::min(lo, X);
                hi = std::max(hi, X);
              }
            }
          }
        }
    });
  }

  // 3a. Convolution: acc = merged ⊛ footprint, rows in parallel.
  {
    core::PassScope pass("slices");
    for (int s = 0; s < 2; ++s)
      for (int j = 0; j < k; ++j) {
        SliceBuf& b = sb[s][j];
        if (!b.used) continue;
        const Taps& tp = taps[b.ri];
        const int gw = b.grid.w;
        core::parallel_for(
            b.a1 - b.a0,
            [&](int r0, int r1) {
              for (int Y = b.a0 + r0; Y < b.a0 + r1; ++Y) {
                for (int c = 0; c < 5; ++c) std::fill(b.arow(c, Y), b.arow(c, Y) + gw, 0.0f);
                int lo = gw, hi = -1;
                for (int dy = -tp.n; dy <= tp.n; ++dy) {
                  const int ys = Y - dy;
                  if (ys < b.m0 || ys >= b.m1) continue;
                  const int slo = b.mlo[ys - b.m0], shi = b.mhi[ys - b.m0];
                  if (slo > shi) continue;
                  const int row = dy + tp.n;
                  for (int e = 0; e < tp.len[row]; ++e) {
                    const int dx = tp.x0[row] + e;
                    const float wt = tp.w[tp.off[row] + e];
                    const int x0 = std::max(0, slo + dx), x1 = std::min(gw - 1, shi + dx);
                    if (x0 > x1) continue;
                    lo = std::min(lo, x0);
                    hi = std::max(hi, x1);
                    for (int c = 0; c < 5; ++c)
                      axpy(b.arow(c, Y) + x0, b.mrow(c == 4 ? kMMass : c, ys) + x0 - dx, wt, x1 - x0 + 1);
                  }
                }
                b.alo[Y - b.a0] = lo;
                b.ahi[Y - b.a0] = hi;
              }
            },
            4);
      }
  }

  // 3b. Hidden-background estimate of every visible slice's frame cells.
  if (opt.hidden) {
    core::PassScope pass("estimate");
    const HiddenPattern pattern(opt.hidden_samples);
    std::vector<float>& behind = st.behind;
    for (int j = 0; j < k; ++j) {
      SliceBuf& b = sb[0][j];
      if (!b.used) continue;
      const Grid& g = b.grid;
      const int gw = g.w, L = g.level;
      for (int c = 0; c < 5; ++c) std::fill(b.erow(c, b.m0), b.erow(c, b.m0) + b.mplane(), 0.0f);
      const float r = std::max(std::fabs(plan.anchor[j]), 0.5f) / static_cast<float>(1 << L);
      if (r <= 0.5f) continue;
      const float limit = sd.u[j] * (1.0f - soft);
      // Frame cell rows the samples may reach.
      const int e = static_cast<int>(std::ceil(r)) + 1;
      const int f0 = g.margin, f1 = g.margin + g.frame_h;  // frame cell rows
      const int c0 = std::max(f0, b.m0 - e), c1 = std::min(f1, b.m1 + e);
      if (c0 >= c1) continue;
      const std::size_t bp = static_cast<std::size_t>(c1 - c0) * gw;
      behind.assign(bp * 5, 0.0f);
      core::parallel_for(
          c1 - c0,
          [&](int r0, int r1) {
            for (int Y = c0 + r0; Y < c0 + r1; ++Y) {
              float* brow[5];
              for (int c = 0; c < 5; ++c) brow[c] = behind.data() + c * bp + static_cast<std::size_t>(Y - c0) * gw;
              for (int y = ((Y - g.margin) << L); y < std::min(h, (Y - g.margin + 1) << L); ++y) {
                const float* z = src.depth[0]->row(0, y);
                for (int x = 0; x < w; ++x) {
                  if (!(inv_depth(z[x]) < limit)) continue;
                  const int X = (x >> L) + g.margin;
                  for (int c = 0; c < 4; ++c) brow[c][X] += src.colour[0]->row(c, y)[x];
                  brow[4][X] += 1.0f;
                }
              }
            }
          },
          4);
      std::atomic<bool> any{false};
      core::parallel_for(
          b.m1 - b.m0,
          [&](int r0, int r1) {
            bool found = false;
            for (int Y = b.m0 + r0; Y < b.m0 + r1; ++Y) {
              if (Y < f0 || Y >= f1) continue;
              const float* all = b.mrow(kMAll, Y);
              for (int X = g.margin; X < g.margin + g.frame_w; ++X) {
                if (all[X] <= 0.0f) continue;
                float sum[5] = {0, 0, 0, 0, 0};
                for (int tt = 0; tt < pattern.count(); ++tt) {
                  const int bx = g.margin + round_clamp(X - g.margin + pattern.x(tt) * r, g.frame_w - 1);
                  const int by = g.margin + round_clamp(Y - g.margin + pattern.y(tt) * r, g.frame_h - 1);
                  const std::size_t o = static_cast<std::size_t>(by - c0) * gw + bx;
                  for (int c = 0; c < 5; ++c) sum[c] += behind[c * bp + o];
                }
                if (sum[4] <= 0.0f) continue;
                for (int c = 0; c < 4; ++c) b.erow(c, Y)[X] = sum[c] / sum[4] * all[X];
                b.erow(4, Y)[X] = all[X];
                found = true;
              }
            }
            if (found) any.store(true, std::memory_order_relaxed);
          },
          4);
      b.any_est = any.load();
    }
  }

  // 4. Tiles.
  out.resize(w, h, 4);
  if (cover) cover->resize(w, h, 4);
  InverseArea& inv_area = st.inv_area;
  inv_area.prepare(pr.rho_max + 1.0f);
  const float r0 = opt.direct_px();
  const int small_reach = reach(r0);
  const int hreach = reach(pr.rho_max);
  const int tiles_x = (w + kTileCols - 1) / kTileCols, tiles_y = (h + kTileRows - 1) / kTileRows;
  int grid_w = 0;
  for (int s = 0; s < 2; ++s)
    for (int j = 0; j < k; ++j)
      if (sb[s][j].used) grid_w = std::max(grid_w, sb[s][j].grid.w);
  // Tile planes: rows of kStride floats (kernels may run up to 16 lanes past a row's end).
  constexpr int kStride = kTileCols + 32;
  constexpr std::size_t kPlane = static_cast<std::size_t>(kTileRows) * kStride;
  core::PassScope pass("tiles");
  core::parallel_for(tiles_x * tiles_y, [&](int t0, int t1) {
    TileScratch& ts = st.scratch.local();
    ts.acc.resize(kPlane * 15);
    ts.est.resize(kPlane * 5);
    ts.rcv.resize(kPlane * 4);
    ts.outp.resize(static_cast<std::size_t>(kStride) * 11);
    ts.rslice.resize(kPlane);
    ts.vrow.resize(static_cast<std::size_t>(grid_w + 32) * 5);
    std::vector<float>& acc = ts.acc;
    std::vector<float>& est = ts.est;
    std::vector<float>& rcv = ts.rcv;
    std::vector<float>& outp = ts.outp;
    std::vector<std::int32_t>& rslice = ts.rslice;
    std::vector<float>& vrow = ts.vrow;
    for (int tile = t0; tile < t1; ++tile) {
      const int tx0 = (tile % tiles_x) * kTileCols, ty0 = (tile / tiles_x) * kTileRows;
      const int tw = std::min(kTileCols, w - tx0), th = std::min(kTileRows, h - ty0);
      float* ru = rcv.data();
      float* risu = ru + kPlane;
      float* rsharp = risu + kPlane;
      float* rt = rsharp + kPlane;
      std::fill(rcv.begin(), rcv.end(), 0.0f);
      std::fill(rslice.begin(), rslice.end(), -2);
      for (int y = ty0; y < ty0 + th; ++y) {
        const float* z = src.depth[0]->row(0, y);
        const float* coc = src.coc[0]->row(0, y);
        const std::size_t row = static_cast<std::size_t>(y - ty0) * kStride;
        for (int x = tx0; x < tx0 + tw; ++x) {
          const std::size_t p = row + (x - tx0);
          const float u = inv_depth(z[x]);
          ru[p] = u;
          risu[p] = u > 0 ? 1.0f / (soft * u) : 1e30f;
          rsharp[p] = std::max(std::fabs(coc[x]) - 0.5f, 0.0f);
          const std::size_t i = static_cast<std::size_t>(y) * w + x;
          rslice[p] = pr.slice[i];
          rt[p] = pr.t[i];
        }
      }
      std::fill(acc.begin(), acc.end(), 0.0f);
      auto receivers = [&](int ty, int col, int count) {
        RowReceivers r;
        const std::size_t o = static_cast<std::size_t>(ty) * kStride + col;
        r.n = count;
        r.u = ru + o;
        r.isu = risu + o;
        r.sharp = rsharp + o;
        for (int c = 0; c < 15; ++c) r.acc[c] = acc.data() + c * kPlane + o;
        return r;
      };
      // Direct sources: one exact footprint each.
      auto direct = [&](int qx, int qy, std::size_t q) {
        const int f = static_cast<int>(q / n);
        const std::size_t i = q % n;
        DirectRow d;
        d.rho = std::max(std::fabs(src.coc[f]->plane(0)[i]), 0.5f);
        const float tr = pr.trans_of(q);
        for (int c = 0; c < 4; ++c) d.c[c] = src.colour[f]->plane(c)[i] * tr;
        d.c[4] = pr.weight_of(q);
        d.su = inv_depth(src.depth[f]->plane(0)[i]);
        d.ssharp = std::max(d.rho - 0.5f, 0.0f);
        d.hidden = f > 0;
        d.ws = inv_area(d.rho);
        const int e = reach(d.rho);
        if (e == 0) {  // in focus: the receiver under it only
          if (qx < tx0 || qx >= tx0 + tw || qy < ty0 || qy >= ty0 + th) return;
          const RowReceivers r = receivers(qy - ty0, qx - tx0, 1);
          float a[15];
          for (int c = 0; c < 15; ++c) a[c] = r.acc[c][0];
          add_source_at(r.u[0], r.isu[0], r.sharp[0], d.hidden, {d.su, d.ssharp}, d.ws, d.c, a);
          for (int c = 0; c < 15; ++c) r.acc[c][0] = a[c];
          return;
        }
        const float lim = d.rho + 0.5f;
        for (int py = std::max(ty0, qy - e); py <= std::min(ty0 + th - 1, qy + e); ++py) {
          d.dy = static_cast<float>(py - qy);
          const int hw = static_cast<int>(std::sqrt(std::max(0.0f, lim * lim - d.dy * d.dy)));
          const int px0 = std::max(tx0, qx - hw), px1 = std::min(tx0 + tw - 1, qx + hw);
          if (px0 > px1) continue;
          d.dx0 = static_cast<float>(px0 - qx);
          direct_row(d, receivers(py - ty0, px0 - tx0, px1 - px0 + 1));
        }
      };
      for (int yp = std::max(-pad, ty0 - small_reach); yp < std::min(h + pad, ty0 + th + small_reach); ++yp) {
        const int y = mirror(yp, h);
        for (int f = 0; f < nf; ++f) {
          const float* coc = src.coc[f]->row(0, y);
          const std::uint8_t* fl = &pr.flags[f * n + static_cast<std::size_t>(y) * w];
          for (int xp = std::max(-pad, tx0 - small_reach); xp < std::min(w + pad, tx0 + tw + small_reach); ++xp) {
            const int x = mirror(xp, w);
            if ((fl[x] & (kExists | kDirect)) != (kExists | kDirect)) continue;
            if (!(std::max(std::fabs(coc[x]), 0.5f) < r0)) continue;  // highlights below
            direct(xp, yp, f * n + static_cast<std::size_t>(y) * w + x);
          }
        }
      }
      for (int yp = std::max(-pad, ty0 - hreach); yp < std::min(h + pad, ty0 + th + hreach); ++yp)
        for (int e = pr.hl_start[yp + pad]; e < pr.hl_start[yp + pad + 1]; ++e) {
          const int xp = pr.hl_x[e];
          if (xp < tx0 - hreach || xp >= tx0 + tw + hreach) continue;
          direct(xp, yp, pr.hl_q[e]);
        }
      // A cell row interpolated vertically at fine row y: rows Y0, Y0 + 1 of `plane(c, Y)`
      // (rows outside [r0, r1) are zero), columns [xa, xb].
      auto vertical = [&](const Grid& g, int y, int ra, int rb, const auto& plane, int xa, int xb) {
        int x0, y0;
        float ax, ay;
        g.locate(tx0, y, x0, y0, ax, ay);
        for (int c = 0; c < 5; ++c) {
          float* dst = vrow.data() + static_cast<std::size_t>(c) * (grid_w + 32);
          const float* a = y0 >= ra && y0 < rb ? plane(c, y0) : nullptr;
          const float* b = y0 + 1 >= ra && y0 + 1 < rb ? plane(c, y0 + 1) : nullptr;
          for (int X = xa; X <= xb; ++X) {
            const float va = a ? a[X] : 0.0f, vb = b ? b[X] : 0.0f;
            dst[X] = va + ay * (vb - va);
          }
        }
      };
      // Slices, read back bilinearly.
      for (int s = 0; s < 2; ++s)
        for (int j = 0; j < k; ++j) {
          const SliceBuf& b = sb[s][j];
          if (!b.used) continue;
          const Grid& g = b.grid;
          int ya, yb, xa, xb;
          float ax, ay;
          g.locate(tx0, ty0, xa, ya, ax, ay);
          g.locate(tx0 + tw - 1, ty0 + th - 1, xb, yb, ax, ay);
          ++xb;
          ++yb;
          if (yb < b.a0 || ya >= b.a1) continue;
          bool any = false;
          for (int Y = std::max(ya, b.a0); Y <= std::min(yb, b.a1 - 1); ++Y)
            any |= b.alo[Y - b.a0] <= xb && b.ahi[Y - b.a0] >= xa;
          if (!any) continue;
          FoldRow fr;
          fr.x0 = tx0;
          fr.level = g.level;
          fr.margin = g.margin;
          fr.norm = 1.0f / static_cast<float>(1 << (2 * g.level));
          fr.su = sd.u[j];
          fr.ssharp = sd.sharp[j];
          fr.hidden = s > 0;
          for (int c = 0; c < 5; ++c) fr.row[c] = vrow.data() + static_cast<std::size_t>(c) * (grid_w + 32);
          for (int y = ty0; y < ty0 + th; ++y) {
            vertical(g, y, b.a0, b.a1, [&](int c, int Y) { return b.arow(c, Y); }, xa, xb);
            fold_row(fr, receivers(y - ty0, 0, tw));
          }
        }
      // Estimate: each receiver's two slices.
      std::fill(est.begin(), est.end(), 0.0f);
      if (opt.hidden) {
        int jlo = k, jhi = -1;
        for (int y = 0; y < th; ++y)
          for (int x = 0; x < tw; ++x) {
            const int sl = rslice[static_cast<std::size_t>(y) * kStride + x];
            jlo = std::min(jlo, sl);
            jhi = std::max(jhi, sl + 1);
          }
        for (int j = std::max(jlo, 0); j <= std::min(jhi, k - 1); ++j) {
          const SliceBuf& b = sb[0][j];
          if (!b.used || !b.any_est) continue;
          const Grid& g = b.grid;
          int ya, yb, xa, xb;
          float ax, ay;
          g.locate(tx0, ty0, xa, ya, ax, ay);
          g.locate(tx0 + tw - 1, ty0 + th - 1, xb, yb, ax, ay);
          ++xb;
          ++yb;
          if (yb < b.m0 || ya >= b.m1) continue;
          EstRow er;
          er.x0 = tx0;
          er.level = g.level;
          er.margin = g.margin;
          er.j = j;
          for (int c = 0; c < 5; ++c) er.row[c] = vrow.data() + static_cast<std::size_t>(c) * (grid_w + 32);
          for (int y = ty0; y < ty0 + th; ++y) {
            const std::size_t o = static_cast<std::size_t>(y - ty0) * kStride;
            vertical(g, y, b.m0, b.m1, [&](int c, int Y) { return b.erow(c, Y); }, xa, xb);
            er.n = tw;
            er.slice = rslice.data() + o;
            er.t = rt + o;
            er.sharp = rsharp + o;
            for (int c = 0; c < 5; ++c) er.est[c] = est.data() + c * kPlane + o;
            est_row(er);
          }
        }
      }
      // Composite.
      for (int y = ty0; y < ty0 + th; ++y) {
        const std::size_t o = static_cast<std::size_t>(y - ty0) * kStride;
        CompositeRow cr;
        cr.n = tw;
        for (int c = 0; c < 15; ++c) cr.acc[c] = acc.data() + c * kPlane + o;
        for (int c = 0; c < 5; ++c) cr.est[c] = est.data() + c * kPlane + o;
        float* srcrow = outp.data();  // the receivers' own colour, padded
        for (int c = 0; c < 4; ++c) {
          std::memcpy(srcrow + c * kStride, src.colour[0]->row(c, y) + tx0, sizeof(float) * tw);
          cr.src[c] = srcrow + c * kStride;
          cr.out[c] = srcrow + (4 + c) * kStride - (c == 3 ? 0 : 0);
        }
        float* res = outp.data() + 4 * kStride;
        for (int c = 0; c < 4; ++c) cr.out[c] = res + c * kStride;
        float* cov = outp.data() + 8 * kStride;
        if (cover)
          for (int c = 0; c < 3; ++c) cr.cover[c] = cov + c * kStride;
        composite_row(cr);
        for (int c = 0; c < 4; ++c) std::memcpy(out.row(c, y) + tx0, res + c * kStride, sizeof(float) * tw);
        if (cover) {
          for (int c = 0; c < 3; ++c) std::memcpy(cover->row(c, y) + tx0, cov + c * kStride, sizeof(float) * tw);
          std::fill(cover->row(3, y) + tx0, cover->row(3, y) + tx0 + tw, 1.0f);
        }
      }
    }
  });
}

}  // namespace dofkit::detail::lens
