// Over 800 lines: the passes share one frame's slice buffers (FrameCtx; prep: lens_prepare.cpp).
// The fast form of `lens` (docs/methods/lens.md): the model of lens_plain.cpp, organised for
// speed and memory. Per frame:
//   1. prep (rows in parallel): each fragment's slice and hat weight, direct / exists flags,
//      the slices' mean inverse depths and the rows and columns their members occupy;
//   2. merge (blocks of rows aligned to the coarsest level, in parallel): every slice's merged
//      sources at its level, only over the cell rows it occupies (mirror-padded frame);
//   3. per slice, the convolution of its merged sources with its footprint (rows in parallel)
//      and the hidden-background estimate of its cells;
//   4. tiles of the frame (in parallel): the direct sources' exact pairs, every slice's sums
//      read back bilinearly, the estimate, and the composite (SIMD row kernels, kernels.hpp).
// One function per pass (render_fast at the end calls them in order), sharing a FrameCtx.
// Each output value is computed by one task in a fixed order, so the result is the same for
// any thread count. Tested against the plain form (tests/lens/).
#include <tbb/enumerable_thread_specific.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "core/clones.hpp"
#include "core/parallel.hpp"
#include "core/pass_profile.hpp"
#include "methods/lens/footprint.hpp"
#include "methods/lens/kernels.hpp"
#include "methods/lens/lens.hpp"
#include "methods/method.hpp"
#include "methods/lens/lens_prepare.hpp"

namespace dofkit::detail::lens {

namespace {

constexpr int kTileRows = 16, kTileCols = 256;

// The padded range [lo', hi'] that shows frame rows (or columns) [lo, hi] of an axis of n
// pixels, with `pad` px of mirror padding: the range itself and its mirror copies.
void padded_range(int lo, int hi, int n, int pad, int& plo, int& phi) {
  plo = lo;
  phi = hi;
  if (pad >= n) {  // reflections repeat: all of it
    plo = -pad;
    phi = n + pad - 1;
    return;
  }
  if (lo < pad) plo = std::min(plo, -1 - std::min(hi, pad - 1));
  if (hi >= n - pad) phi = std::max(phi, 2 * n - 1 - std::max(lo, n - pad));
  plo = std::max(plo, -pad);
  phi = std::min(phi, n + pad - 1);
}

// One slice's buffers (per source set): planar rows of its grid.
enum { kMR, kMG, kMB, kMA, kMMass, kMAll, kMChannels };
struct SliceBuf {
  Grid grid;
  bool used = false, sliced = false, estimate = false;
  int m0 = 0, m1 = 0;  // merged rows [m0, m1)
  int a0 = 0, a1 = 0;  // acc rows [a0, a1)
  int ri = 0, reach = 0;
  bool near = false;        // the footprint's field (the anchor's side of focus)
  float* merged = nullptr;  // kMChannels planes of (m1 − m0)·grid.w (rgba, mass only if sliced; all only if estimate)
  float* acc = nullptr;     // 5 planes of (a1 − a0)·grid.w (if sliced)
  float* est = nullptr;     // 5 planes of (m1 − m0)·grid.w (if estimate)
  std::vector<int> mlo, mhi;  // per merged row: columns with sliced sources
  std::vector<int> alo, ahi;  // per acc row: columns with sums
  bool any_est = false;
  std::size_t mplane() const { return static_cast<std::size_t>(m1 - m0) * grid.w; }
  std::size_t aplane() const { return static_cast<std::size_t>(a1 - a0) * grid.w; }
  float* mrow(int c, int y) const { return merged + c * mplane() + static_cast<std::size_t>(y - m0) * grid.w; }
  float* arow(int c, int y) const { return acc + c * aplane() + static_cast<std::size_t>(y - a0) * grid.w; }
  float* erow(int c, int y) const { return est + c * mplane() + static_cast<std::size_t>(y - m0) * grid.w; }
};

// The content clearly behind a slice on a run of n frame pixels, added into its cells (level
// L, the run starting at a cell boundary): cells[c][x >> L] += m · colour[c][x],
// cells[4][x >> L] += m, with m = (u[x] < limit). tmp: 5 (n + 1) floats of scratch. The pixels
// of a cell are summed pairwise.
DOFKIT_CLONES DOFKIT_NO_TRAPPING_MATH void behind_row(const float* __restrict u, float limit,
                                                      const float* __restrict c0, const float* __restrict c1,
                                                      const float* __restrict c2, const float* __restrict c3, int n,
                                                      int level, float* __restrict tmp, float* const* cells) {
  const std::size_t s = static_cast<std::size_t>(n) + 1;
  float* t0 = tmp;
  float* t1 = tmp + s;
  float* t2 = tmp + 2 * s;
  float* t3 = tmp + 3 * s;
  float* t4 = tmp + 4 * s;
  for (int x = 0; x < n; ++x) {
    const float m = u[x] < limit ? 1.0f : 0.0f;
    t0[x] = m * c0[x];
    t1[x] = m * c1[x];
    t2[x] = m * c2[x];
    t3[x] = m * c3[x];
    t4[x] = m;
  }
  int m = n;
  for (int l = 0; l < level; ++l) {
    if (m & 1) {
      t0[m] = t1[m] = t2[m] = t3[m] = t4[m] = 0.0f;
      ++m;
    }
    m /= 2;
    for (int i = 0; i < m; ++i) {
      t0[i] = t0[2 * i] + t0[2 * i + 1];
      t1[i] = t1[2 * i] + t1[2 * i + 1];
      t2[i] = t2[2 * i] + t2[2 * i + 1];
      t3[i] = t3[2 * i] + t3[2 * i + 1];
      t4[i] = t4[2 * i] + t4[2 * i + 1];
    }
  }
  float* k0 = cells[0];
  float* k1 = cells[1];
  float* k2 = cells[2];
  float* k3 = cells[3];
  float* k4 = cells[4];
  for (int i = 0; i < m; ++i) {
    k0[i] += t0[i];
    k1[i] += t1[i];
    k2[i] += t2[i];
    k3[i] += t3[i];
    k4[i] += t4[i];
  }
}

// dst[x] = a[x] + ay (b[x] − a[x]) for x in [0, n); a null row is zero.
DOFKIT_CLONES
void lerp_rows(const float* __restrict a, const float* __restrict b, float ay, float* __restrict dst, int n) {
  if (a && b)
    for (int x = 0; x < n; ++x) dst[x] = a[x] + ay * (b[x] - a[x]);
  else if (a)
    for (int x = 0; x < n; ++x) dst[x] = a[x] + ay * (0.0f - a[x]);
  else if (b)
    for (int x = 0; x < n; ++x) dst[x] = 0.0f + ay * (b[x] - 0.0f);
  else
    for (int x = 0; x < n; ++x) dst[x] = 0.0f;
}

// A tile row's receivers: inverse depth, 1 / (softness · it), sharpness, slice and hat weight;
// and the visible in-focus sources under them (radius 0.5, only their own pixel: rel = 0,
// weight 1 / area(0.5) = 1, all to B), which need no footprint.
DOFKIT_CLONES DOFKIT_NO_TRAPPING_MATH void setup_receivers(
    const float* __restrict u, const float* __restrict coc, const std::int16_t* __restrict slice,
    const float* __restrict t, const std::uint8_t* __restrict flags, const float* __restrict c0,
    const float* __restrict c1, const float* __restrict c2, const float* __restrict c3, float soft, int n,
    float* __restrict ru, float* __restrict risu, float* __restrict rsharp, std::int32_t* __restrict rslice,
    float* __restrict rt, float* __restrict b0, float* __restrict b1, float* __restrict b2, float* __restrict b3,
    float* __restrict bw) {
  for (int x = 0; x < n; ++x) {
    ru[x] = u[x];
    risu[x] = u[x] > 0.0f ? 1.0f / (soft * u[x]) : 1e30f;
    const float sp = std::max(std::fabs(coc[x]) - 0.5f, 0.0f);
    rsharp[x] = sp;
    rslice[x] = slice[x];
    rt[x] = t[x];
    const float m = (flags[x] & kDirect) && !(sp > 0.0f) ? 1.0f : 0.0f;
    b0[x] = m * c0[x];
    b1[x] = m * c1[x];
    b2[x] = m * c2[x];
    b3[x] = m * c3[x];
    bw[x] = m;
  }
}

// A run of n pixels of one slice: sums of h·colour·trans (4), h·weight, h with h = t (part 1)
// or 1 − t (part 0); trans, weight null: 1.
DOFKIT_CLONES
void run_sums(const float* __restrict t, const float* __restrict c0, const float* __restrict c1,
              const float* __restrict c2, const float* __restrict c3, const float* __restrict trans,
              const float* __restrict weight, int n, bool part1, float* out) {
  float s0 = 0, s1 = 0, s2 = 0, s3 = 0, s4 = 0, s5 = 0;
  if (!trans) {
    for (int x = 0; x < n; ++x) {
      const float hw = part1 ? t[x] : 1.0f - t[x];
      s0 += hw * c0[x];
      s1 += hw * c1[x];
      s2 += hw * c2[x];
      s3 += hw * c3[x];
      s5 += hw;
    }
    s4 = s5;
  } else {
    for (int x = 0; x < n; ++x) {
      const float hw = part1 ? t[x] : 1.0f - t[x];
      const float ht = hw * trans[x];
      s0 += ht * c0[x];
      s1 += ht * c1[x];
      s2 += ht * c2[x];
      s3 += ht * c3[x];
      s4 += hw * weight[x];
      s5 += hw;
    }
  }
  out[0] = s0;
  out[1] = s1;
  out[2] = s2;
  out[3] = s3;
  out[4] = s4;
  out[5] = s5;
}

// acc[x] += src[x] for x in [0, n).
DOFKIT_CLONES
void add_row(float* __restrict acc, const float* __restrict src, int n) {
  for (int x = 0; x < n; ++x) acc[x] += src[x];
}

// acc[x] += wt · src[x] for x in [0, n).
DOFKIT_CLONES
void axpy(float* __restrict acc, const float* __restrict src, float wt, int n) {
  for (int x = 0; x < n; ++x) acc[x] += wt * src[x];
}

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
  GaugeTable gauge;
  std::vector<float> arena, behind, padded;
  std::vector<int> offsets;
  tbb::enumerable_thread_specific<TileScratch> scratch;
  tbb::enumerable_thread_specific<std::vector<float>> row_tmp;
};

// One frame of the fast form: what every pass reads, and the slices' buffers, which the passes
// fill in order (allocate_slices, merge_pass, convolve_pass, estimate_pass, then tile_pass).
struct FrameCtx {
  FrameCtx(const Sources& src_, const SlicePlan& plan_, const LensOptions& opt_, State& st_)
      : src(src_),
        plan(plan_),
        opt(opt_),
        st(st_),
        pr(st_.pr),
        w(src_.width()),
        h(src_.height()),
        nf(src_.count()),
        k(plan_.count()),
        sd(plan_, st_.pr.mass, st_.pr.u_sum) {
    for (int j = 0; j < k; ++j) lmax = std::max(lmax, plan.level[j]);
    // A common origin of every level's cells, −origin px, a multiple of the coarsest cell.
    unit = 1 << lmax;
    origin = (pr.pad + unit - 1) / unit * unit + unit;
    pad = pr.pad;
  }
  const Sources& src;
  const SlicePlan& plan;
  const LensOptions& opt;
  State& st;
  Prep& pr;  // st.pr, prepared for this frame
  int w, h, nf, k;
  SliceDepth sd;
  int lmax = 1, unit = 2, origin = 0, pad = 0;
  std::vector<SliceBuf> sb[2];  // per set (visible, hidden) and slice
};

// The debug views of the prep pass: slices and direct sources.
void slice_views(const FrameCtx& fc, const Views& views) {
  const SlicePlan& plan = fc.plan;
  Prep& pr = fc.pr;
  const int w = fc.w;
  const int h = fc.h;
  const int k = fc.k;
  if (views.slices || views.direct) {
    int top = 1;
    for (int j = 0; j < k; ++j) top = std::max(top, plan.level[j]);
    if (views.slices) views.slices->resize(w, h, 4);
    if (views.direct) views.direct->resize(w, h, 4);
    core::parallel_for(h, [&](int y0, int y1) {
      for (int y = y0; y < y1; ++y)
        for (int x = 0; x < w; ++x) {
          const std::size_t i = static_cast<std::size_t>(y) * w + x;
          const std::uint8_t fl = pr.flags[i];
          if (views.slices) {
            const int j = pr.slice[i];
            views.slices->at(x, y, 0) = k > 1 ? (static_cast<float>(j) + pr.t[i]) / static_cast<float>(k - 1) : 0.0f;
            views.slices->at(x, y, 1) = static_cast<float>(plan.level[j]) / static_cast<float>(top);
            views.slices->at(x, y, 2) = (fl & kDirect) ? 1.0f : 0.0f;
            views.slices->at(x, y, 3) = 1.0f;
          }
          if (views.direct) {
            views.direct->at(x, y, 0) = (fl & kDirect) && !(fl & kHighlight) ? 1.0f : 0.0f;
            views.direct->at(x, y, 1) = (fl & kHighlight) ? 1.0f : 0.0f;
            views.direct->at(x, y, 2) = 0.0f;
            views.direct->at(x, y, 3) = 1.0f;
          }
        }
    });
  }
}

// 1b. Buffers: per set and slice, the rows its members (and their mirror copies) occupy, in one arena.
void allocate_slices(FrameCtx& fc) {
  const SlicePlan& plan = fc.plan;
  const LensOptions& opt = fc.opt;
  State& st = fc.st;
  Prep& pr = fc.pr;
  const int w = fc.w;
  const int h = fc.h;
  const int k = fc.k;
  const int origin = fc.origin;
  const int pad = fc.pad;
  auto& sb = fc.sb;
  TapTable& taps = st.taps;
  std::size_t total = 0;
  for (int s = 0; s < 2; ++s) {
    sb[s].resize(k);
    for (int j = 0; j < k; ++j) {
      SliceBuf& b = sb[s][j];
      if (pr.ylo[s][j] > pr.yhi[s][j]) continue;
      const int L = plan.level[j];
      b.grid = Grid(w, h, L, origin >> L);
      b.sliced = pr.sliced[s][j];
      // The estimate of a slice whose receivers are blurred (radius > 0.5 cell at its level).
      b.estimate =
          s == 0 && opt.hidden && std::max(std::fabs(plan.anchor[j]), 0.5f) / static_cast<float>(1 << L) > 0.5f;
      if (!b.sliced && !b.estimate) continue;
      b.used = true;
      int lo, hi;
      padded_range(pr.ylo[s][j], pr.yhi[s][j], h, pad, lo, hi);
      b.m0 = (lo + origin) >> L;
      b.m1 = ((hi + origin) >> L) + 1;
      b.ri = slice_radius_index(plan, j);
      taps.prepare(radius_of_index(b.ri), opt.shape);
      b.near = plan.anchor[j] > 0.0f;
      b.reach = taps.at(b.ri, b.near).n;
      b.a0 = b.a1 = b.m0;
      if (b.sliced) {
        b.a0 = std::max(0, b.m0 - b.reach);
        b.a1 = std::min(b.grid.h, b.m1 + b.reach);
      }
      total += b.mplane() * kMChannels + b.aplane() * 5 + (b.estimate ? b.mplane() * 5 : 0);
      b.mlo.assign(b.m1 - b.m0, b.grid.w);
      b.mhi.assign(b.m1 - b.m0, -1);
      b.alo.assign(b.a1 - b.a0, b.grid.w);
      b.ahi.assign(b.a1 - b.a0, -1);
    }
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
        if (b.estimate) {
          b.est = p;
          p += b.mplane() * 5;
        }
      }
  }
}

// 2. Merge. Blocks of `unit` padded rows starting at −origin: every level's cell rows lie
// wholly in one block, so each cell is written by one task.
void merge_pass(FrameCtx& fc) {
  const Sources& src = fc.src;
  const LensOptions& opt = fc.opt;
  Prep& pr = fc.pr;
  const int w = fc.w;
  const int h = fc.h;
  const int nf = fc.nf;
  const int k = fc.k;
  const std::size_t n = fc.pr.n;
  const int unit = fc.unit;
  const int origin = fc.origin;
  const int pad = fc.pad;
  auto& sb = fc.sb;
  {
    core::PassScope pass("merge");
    for (int s = 0; s < 2; ++s)
      for (int j = 0; j < k; ++j) {
        const SliceBuf& b = sb[s][j];
        if (!b.used) continue;
        if (b.sliced) std::fill(b.merged, b.merged + b.mplane() * (kMMass + 1), 0.0f);
        if (b.estimate) std::fill(b.mrow(kMAll, b.m0), b.mrow(kMAll, b.m0) + b.mplane(), 0.0f);
      }
    // Per set and slice, where its merged sources go (null: nowhere).
    struct Target {
      float* plane[kMChannels];
      int level, m0, gw;
      int* mlo;
      int* mhi;
    };
    std::vector<Target> targets(2 * static_cast<std::size_t>(k));
    for (int s = 0; s < 2; ++s)
      for (int j = 0; j < k; ++j) {
        Target& tg = targets[static_cast<std::size_t>(s) * k + j];
        SliceBuf& b = sb[s][j];
        for (int c = 0; c < kMChannels; ++c)
          tg.plane[c] = b.used && (c == kMAll ? b.estimate : b.sliced) ? b.merged + c * b.mplane() : nullptr;
        tg.level = b.grid.level;
        tg.m0 = b.m0;
        tg.gw = b.grid.w;
        tg.mlo = b.mlo.data();
        tg.mhi = b.mhi.data();
      }
    const int rows = h + 2 * origin;
    const int blocks = (rows + unit - 1) / unit;
    if (opt.progress) opt.progress->pass(0.05, 0.35, blocks);
    const auto merge_blocks = [&](int b0, int b1) {
      // The cells being filled, summed in registers while the pixels of a row run through
      // the same cells (a few slots; the oldest is written out when another cell comes).
      struct Open {
        const Target* tg = nullptr;
        std::size_t off = 0;
        int row = 0, X = 0;
        float v[6] = {};
        bool sliced = false;
      };
      constexpr int kSlots = 4;
      Open open[kSlots];
      int victim = 0;
      auto flush = [&](Open& o) {
        if (!o.tg) return;
        const Target& tg = *o.tg;
        if (o.sliced) {
          for (int c = 0; c < 4; ++c) tg.plane[c][o.off] += o.v[c];
          tg.plane[kMMass][o.off] += o.v[4];
          tg.mlo[o.row] = std::min(tg.mlo[o.row], o.X);
          tg.mhi[o.row] = std::max(tg.mhi[o.row], o.X);
        }
        if (tg.plane[kMAll]) tg.plane[kMAll][o.off] += o.v[5];
        o.tg = nullptr;
      };
      auto slot = [&](const Target* tg, int yp, int xp) -> Open& {
        const int L = tg->level;
        const int Y = (yp + origin) >> L, X = (xp + origin) >> L;
        const std::size_t off = static_cast<std::size_t>(Y - tg->m0) * tg->gw + X;
        for (Open& o : open)
          if (o.tg == tg && o.off == off) return o;
        Open& o = open[victim];
        victim = (victim + 1) % kSlots;
        flush(o);
        o.tg = tg;
        o.off = off;
        o.row = Y - tg->m0;
        o.X = X;
        for (float& v : o.v) v = 0.0f;
        o.sliced = false;
        return o;
      };
      for (int b = b0; b < b1; ++b)
        for (int yp = -origin + b * unit; yp < -origin + (b + 1) * unit; ++yp) {
          if (yp < -pad || yp >= h + pad) continue;
          const int y = mirror(yp, h);
          const bool real_row = yp >= 0 && yp < h;
          for (int f = 0; f < nf; ++f) {
            const Target* tset = &targets[static_cast<std::size_t>(f > 0) * k];
            const float* col[4];
            for (int c = 0; c < 4; ++c) col[c] = src.colour[f]->row(c, y);
            const std::size_t rowq = f * n + static_cast<std::size_t>(y) * w;
            const std::uint8_t* flr = &pr.flags[rowq];
            const std::int16_t* slr = &pr.slice[rowq];
            const float* tr = &pr.t[rowq];
            const float* wr = f > 0 ? &pr.weight[rowq - n] : nullptr;
            const float* trr = f > 0 ? &pr.trans[rowq - n] : nullptr;
            // The frame's columns in runs of pixels of one slice (neither direct nor missing):
            // per cell of each of the two slices' levels, the run's sums in one loop.
            const bool all_row = f == 0 && real_row;
            for (int x = 0; x < w;) {
              const std::uint8_t fl = flr[x];
              if ((fl & (kExists | kDirect)) != kExists) {
                if ((fl & kExists) && all_row) {  // a direct source: only the receivers' mass
                  for (int part = 0; part < 2; ++part) {
                    const int jj = slr[x] + part;
                    const float hw = part ? tr[x] : 1.0f - tr[x];
                    if (jj >= k || hw <= 0.0f || !tset[jj].plane[kMAll]) continue;
                    slot(&tset[jj], yp, x).v[5] += hw;
                  }
                }
                ++x;
                continue;
              }
              const int j = slr[x];
              int e = x + 1;
              while (e < w && slr[e] == j && (flr[e] & (kExists | kDirect)) == kExists) ++e;
              for (int part = 0; part < 2; ++part) {
                const int jj = j + part;
                if (jj >= k) continue;
                const Target* tg = &tset[jj];
                const bool want_all = all_row && tg->plane[kMAll];
                if (!tg->plane[kMR] && !want_all) continue;
                const int L = tg->level;
                for (int xa = x; xa < e;) {
                  const int X = (xa + origin) >> L;
                  const int xb = std::min(e, ((X + 1) << L) - origin);
                  float sum[6];
                  run_sums(tr + xa, col[0] + xa, col[1] + xa, col[2] + xa, col[3] + xa, trr ? trr + xa : nullptr,
                           wr ? wr + xa : nullptr, xb - xa, part == 1, sum);
                  if (sum[5] > 0.0f) {
                    Open& o = slot(tg, yp, xa);
                    if (tg->plane[kMR]) {
                      for (int c = 0; c < 5; ++c) o.v[c] += sum[c];
                      o.sliced = true;
                    }
                    if (want_all) o.v[5] += sum[5];
                  }
                  xa = xb;
                }
              }
              x = e;
            }
            // The padding's columns, pixel by pixel.
            for (int xp = -pad; xp < w + pad; ++xp) {
              if (xp == 0) xp = w;
              if (xp >= w + pad) break;
              const int x = mirror(xp, w);
              const std::uint8_t fl = flr[x];
              if (!(fl & kExists)) continue;
              const int j = slr[x];
              const float tt = tr[x];
              const bool all = f == 0 && real_row && xp >= 0 && xp < w;
              const bool direct = fl & kDirect;
              if (direct && !all) continue;
              const float tw = trr ? trr[x] : 1.0f, wt = wr ? wr[x] : 1.0f;
              const float c0 = col[0][x] * tw, c1 = col[1][x] * tw, c2 = col[2][x] * tw, c3 = col[3][x] * tw;
              for (int part = 0; part < 2; ++part) {
                const int jj = j + part;
                const float hw = part ? tt : 1.0f - tt;
                if (jj >= k || hw <= 0.0f) continue;
                const Target* tg = &tset[jj];
                const bool want_all = all && tg->plane[kMAll];
                const bool want_src = !direct && tg->plane[kMR];
                if (!want_all && !want_src) continue;
                Open& o = slot(tg, yp, xp);
                if (want_all) o.v[5] += hw;
                if (!want_src) continue;
                o.v[0] += hw * c0;
                o.v[1] += hw * c1;
                o.v[2] += hw * c2;
                o.v[3] += hw * c3;
                o.v[4] += hw * wt;
                o.sliced = true;
              }
            }
            for (Open& o : open) flush(o);
          }
        }
    };
    core::parallel_for(blocks, with_progress(opt.progress, merge_blocks));
  }
}

// 3a. Convolution: acc = merged ⊛ footprint, rows in parallel.
void convolve_pass(FrameCtx& fc) {
  const int k = fc.k;
  auto& sb = fc.sb;
  const TapTable& taps = fc.st.taps;
  {
    core::PassScope pass("slices");
    for (int s = 0; s < 2; ++s)
      for (int j = 0; j < k; ++j) {
        SliceBuf& b = sb[s][j];
        if (!b.used || !b.sliced) continue;
        const Taps& tp = taps.at(b.ri, b.near);
        const int gw = b.grid.w;
        core::parallel_for(
            b.a1 - b.a0,
            [&](int r0, int r1) {
              for (int Y = b.a0 + r0; Y < b.a0 + r1; ++Y) {
                // Columns this row receives: the source rows' columns widened by the taps.
                int lo = gw, hi = -1;
                for (int dy = -tp.n; dy <= tp.n; ++dy) {
                  const int ys = Y - dy;
                  if (ys < b.m0 || ys >= b.m1 || b.mlo[ys - b.m0] > b.mhi[ys - b.m0]) continue;
                  const int row = dy + tp.n;
                  lo = std::min(lo, std::max(0, b.mlo[ys - b.m0] + tp.x0[row]));
                  hi = std::min(gw - 1, std::max(hi, b.mhi[ys - b.m0] + tp.x0[row] + tp.len[row] - 1));
                }
                b.alo[Y - b.a0] = lo;
                b.ahi[Y - b.a0] = hi;
                // The whole row: the tiles' bilinear read-back takes whole column ranges of a
                // row that has sums anywhere in them (the arena is kept from frame to frame).
                for (int c = 0; c < 5; ++c) std::fill(b.arow(c, Y), b.arow(c, Y) + gw, 0.0f);
                if (lo > hi) continue;
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
                    for (int c = 0; c < 5; ++c)
                      axpy(b.arow(c, Y) + x0, b.mrow(c == 4 ? kMMass : c, ys) + x0 - dx, wt, x1 - x0 + 1);
                  }
                }
              }
            },
            4);
      }
  }
}

// 3b. Hidden-background estimate of every visible slice's frame cells.
void estimate_pass(FrameCtx& fc) {
  const Sources& src = fc.src;
  const SlicePlan& plan = fc.plan;
  const LensOptions& opt = fc.opt;
  State& st = fc.st;
  Prep& pr = fc.pr;
  const int w = fc.w;
  const int h = fc.h;
  const int k = fc.k;
  const float soft = fc.opt.depth_softness;
  const SliceDepth& sd = fc.sd;
  auto& sb = fc.sb;
  if (opt.hidden) {
    core::PassScope pass("estimate");
    const HiddenPattern pattern;
    for (int j = 0; j < k; ++j) {
      SliceBuf& b = sb[0][j];
      if (!b.used || !b.estimate) continue;
      const Grid& g = b.grid;
      const int L = g.level;
      for (int c = 0; c < 5; ++c) std::fill(b.erow(c, b.m0), b.erow(c, b.m0) + b.mplane(), 0.0f);
      const float r = std::max(std::fabs(plan.anchor[j]), 0.5f) / static_cast<float>(1 << L);
      const float limit = sd.u[j] * (1.0f - soft);
      // The samples as integer cell offsets: round_clamp(X + o·r) = clamp(X + round(o·r)) for a
      // cell X >= 0 of the frame, so a sample is the same shift for every cell.
      std::vector<int>& ox = st.offsets;
      ox.resize(2 * static_cast<std::size_t>(pattern.count()));
      int D = 0;
      for (int tt = 0; tt < pattern.count(); ++tt) {
        ox[2 * tt] = static_cast<int>(std::floor(pattern.x(tt) * r + 0.5f));
        ox[2 * tt + 1] = static_cast<int>(std::floor(pattern.y(tt) * r + 0.5f));
        D = std::max({D, std::abs(ox[2 * tt]), std::abs(ox[2 * tt + 1])});
      }
      // Frame cells the samples may reach: the members' cells widened by D.
      const int f0 = g.margin, f1 = g.margin + g.frame_h;
      const int c0 = std::max(f0, b.m0 - D), c1 = std::min(f1, b.m1 + D);
      const int x0c = std::max(0, (pr.xlo[0][j] >> L) - D), x1c = std::min(g.frame_w - 1, (pr.xhi[0][j] >> L) + D);
      if (c0 >= c1 || x0c > x1c) continue;
      const int cw = x1c - x0c + 1;
      // Behind content per cell over those rows and columns, extended by its edge cells so that
      // the shifts need no clamping.
      const int pw = cw + 2 * D, ph = c1 - c0 + 2 * D;
      const std::size_t pp = static_cast<std::size_t>(pw) * ph;
      st.padded.assign(pp * 5, 0.0f);
      core::parallel_for(
          c1 - c0,
          [&](int r0, int r1) {
            std::vector<float>& tmp = st.row_tmp.local();
            const int px0 = x0c << L, pn = std::min(w, (x1c + 1) << L) - px0;
            tmp.resize(static_cast<std::size_t>(pn + 1) * 5);
            for (int Y = c0 + r0; Y < c0 + r1; ++Y) {
              float* prow[5];
              for (int c = 0; c < 5; ++c)
                prow[c] = st.padded.data() + c * pp + static_cast<std::size_t>(Y - c0 + D) * pw + D;
              for (int y = ((Y - g.margin) << L); y < std::min(h, (Y - g.margin + 1) << L); ++y)
                behind_row(&pr.inv_z[static_cast<std::size_t>(y) * w + px0], limit, src.colour[0]->row(0, y) + px0,
                           src.colour[0]->row(1, y) + px0, src.colour[0]->row(2, y) + px0,
                           src.colour[0]->row(3, y) + px0, pn, L, tmp.data(), prow);
              // Edge cells: clamp to the frame's first / last cell column, if the range ends there.
              for (int c = 0; c < 5; ++c) {
                for (int x = 0; x < D; ++x) {
                  prow[c][-1 - x] = x0c == 0 ? prow[c][0] : 0.0f;
                  prow[c][cw + x] = x1c == g.frame_w - 1 ? prow[c][cw - 1] : 0.0f;
                }
              }
            }
          },
          4);
      for (int yy = 0; yy < D; ++yy)
        for (int c = 0; c < 5; ++c) {
          float* base = st.padded.data() + c * pp;
          if (c0 == f0)
            std::copy(base + static_cast<std::size_t>(D) * pw, base + static_cast<std::size_t>(D + 1) * pw,
                      base + static_cast<std::size_t>(yy) * pw);
          if (c1 == f1)
            std::copy(base + static_cast<std::size_t>(ph - D - 1) * pw, base + static_cast<std::size_t>(ph - D) * pw,
                      base + static_cast<std::size_t>(ph - 1 - yy) * pw);
        }
      std::atomic<bool> any{false};
      core::parallel_for(
          b.m1 - b.m0,
          [&](int r0, int r1) {
            bool found = false;
            std::vector<float>& sum = st.row_tmp.local();
            sum.resize(static_cast<std::size_t>(cw) * 5);
            for (int Y = b.m0 + r0; Y < b.m0 + r1; ++Y) {
              if (Y < f0 || Y >= f1) continue;
              const float* all = b.mrow(kMAll, Y) + g.margin;
              int xa = x0c, xb = x1c;
              while (xa <= xb && !(all[xa] > 0.0f)) ++xa;
              while (xb >= xa && !(all[xb] > 0.0f)) --xb;
              if (xa > xb) continue;
              const int cn = xb - xa + 1;
              for (int c = 0; c < 5; ++c) std::fill(sum.begin() + c * cw, sum.begin() + c * cw + cn, 0.0f);
              for (int tt = 0; tt < pattern.count(); ++tt) {
                const std::size_t o =
                    static_cast<std::size_t>(Y - c0 + D + ox[2 * tt + 1]) * pw + (xa - x0c + D + ox[2 * tt]);
                for (int c = 0; c < 5; ++c) add_row(sum.data() + c * cw, st.padded.data() + c * pp + o, cn);
              }
              for (int X = xa; X <= xb; ++X) {
                const float s4 = sum[4 * cw + (X - xa)];
                if (!(all[X] > 0.0f) || !(s4 > 0.0f)) continue;
                for (int c = 0; c < 4; ++c) b.erow(c, Y)[X + g.margin] = sum[c * cw + (X - xa)] / s4 * all[X];
                b.erow(4, Y)[X + g.margin] = all[X];
                found = true;
              }
            }
            if (found) any.store(true, std::memory_order_relaxed);
          },
          4);
      b.any_est = any.load();
    }
  }
}

// 4. Tiles: the direct sources' exact pairs, the slices and estimates read back, the composite.
void tile_pass(FrameCtx& fc, Image& out, const Views& views) {
  const Sources& src = fc.src;
  const LensOptions& opt = fc.opt;
  State& st = fc.st;
  Prep& pr = fc.pr;
  const int w = fc.w;
  const int h = fc.h;
  const int nf = fc.nf;
  const int k = fc.k;
  const float soft = fc.opt.depth_softness;
  const std::size_t n = fc.pr.n;
  const SliceDepth& sd = fc.sd;
  const int pad = fc.pad;
  auto& sb = fc.sb;
  Image* const cover = views.coverage;
  out.resize(w, h, 4);
  if (cover) cover->resize(w, h, 4);
  InverseArea& inv_area = st.inv_area;
  inv_area.prepare(pr.rho_max + 1.0f, opt.shape);
  const int small_reach = opt.shape.reach(opt.direct_px());
  const int hreach = opt.shape.reach(pr.rho_max);
  if (!opt.shape.circle()) st.gauge.prepare(opt.shape, hreach);
  const int tiles_x = (w + kTileCols - 1) / kTileCols, tiles_y = (h + kTileRows - 1) / kTileRows;
  int grid_w = 0;
  for (int s = 0; s < 2; ++s)
    for (int j = 0; j < k; ++j)
      if (sb[s][j].used) grid_w = std::max(grid_w, sb[s][j].grid.w);
  // Tile planes: rows of kStride floats (kernels may run up to 16 lanes past a row's end).
  constexpr int kStride = kTileCols + 32;
  constexpr std::size_t kPlane = static_cast<std::size_t>(kTileRows) * kStride;
  core::PassScope pass("tiles");
  for (Image* v : {views.front, views.back, views.estimate, views.tiles})
    if (v) v->resize(w, h, 4);
  if (opt.progress) opt.progress->pass(0.45, 1.0, static_cast<long>(tiles_x) * tiles_y);
  const auto tile_body = [&](int t0, int t1) {
    TileScratch& ts = st.scratch.local();
    ts.acc.resize(kPlane * 15);
    ts.est.resize(kPlane * 5);
    ts.rcv.resize(kPlane * 4);
    ts.outp.resize(static_cast<std::size_t>(kStride) * 11);
    ts.rslice.resize(kPlane);
    ts.vrow.resize(static_cast<std::size_t>(grid_w + 32) * 5);
    float* const acc = ts.acc.data();
    float* const est = ts.est.data();
    float* const ru = ts.rcv.data();
    float* const risu = ru + kPlane;
    float* const rsharp = risu + kPlane;
    float* const rt = rsharp + kPlane;
    std::int32_t* const rslice = ts.rslice.data();
    float* const vrow = ts.vrow.data();
    const std::size_t vstride = static_cast<std::size_t>(grid_w + 32);
    for (int tile = t0; tile < t1; ++tile) {
      int tile_folds = 0, tile_direct = 0, tile_est = 0;
      const int tx0 = (tile % tiles_x) * kTileCols, ty0 = (tile / tiles_x) * kTileRows;
      const int tw = std::min(kTileCols, w - tx0), th = std::min(kTileRows, h - ty0);
      // F and the fill start at zero; B starts with the visible in-focus sources
      // (setup_receivers writes it).
      for (int c = 0; c < (nf > 1 ? 15 : 5); ++c) {
        if (c == 5) c = 10;
        std::fill(acc + c * kPlane, acc + c * kPlane + th * kStride, 0.0f);
      }
      // Receivers, and the visible in-focus sources into B.
      for (int y = ty0; y < ty0 + th; ++y) {
        const std::size_t row = static_cast<std::size_t>(y - ty0) * kStride, i = static_cast<std::size_t>(y) * w + tx0;
        setup_receivers(&pr.inv_z[i], src.coc[0]->row(0, y) + tx0, &pr.slice[i], &pr.t[i], &pr.flags[i],
                        src.colour[0]->row(0, y) + tx0, src.colour[0]->row(1, y) + tx0, src.colour[0]->row(2, y) + tx0,
                        src.colour[0]->row(3, y) + tx0, soft, tw, ru + row, risu + row, rsharp + row, rslice + row,
                        rt + row, acc + 5 * kPlane + row, acc + 6 * kPlane + row, acc + 7 * kPlane + row,
                        acc + 8 * kPlane + row, acc + 9 * kPlane + row);
      }
      auto receivers = [&](int ty, int col, int count) {
        RowReceivers r;
        const std::size_t o = static_cast<std::size_t>(ty) * kStride + col;
        r.n = count;
        r.u = ru + o;
        r.isu = risu + o;
        r.sharp = rsharp + o;
        for (int c = 0; c < 15; ++c) r.acc[c] = acc + c * kPlane + o;
        return r;
      };
      // Direct sources with a footprint: exact pairs.
      TileReceivers tr;
      tr.rows = th;
      tr.cols = tw;
      tr.stride = kStride;
      tr.u = ru;
      tr.isu = risu;
      tr.sharp = rsharp;
      for (int c = 0; c < 15; ++c) tr.acc[c] = acc + c * kPlane;
      auto direct = [&](int qx, int qy, std::size_t q) {
        const int f = static_cast<int>(q / n);
        const std::size_t i = q % n;
        DirectSource d;
        d.qx = qx - tx0;
        d.qy = qy - ty0;
        const float coc = src.coc[f]->plane(0)[i];
        d.rho = std::max(std::fabs(coc), 0.5f);
        if (!opt.shape.circle()) {
          d.gauge = st.gauge.row(0, coc > 0.0f);
          d.pitch = st.gauge.pitch();
          d.reach = opt.shape.reach(d.rho);
          d.lim = opt.shape.model()->lim(d.rho);
        }
        const float trn = pr.trans_of(q);
        for (int c = 0; c < 4; ++c) d.c[c] = src.colour[f]->plane(c)[i] * trn;
        d.c[4] = pr.weight_of(q);
        d.su = inv_depth(src.depth[f]->plane(0)[i]);
        d.ssharp = std::max(d.rho - 0.5f, 0.0f);
        d.hidden = f > 0;
        d.ws = inv_area(d.rho);
        direct_source(d, tr);
        ++tile_direct;
      };
      for (int yp = std::max(-pad, ty0 - small_reach); yp < std::min(h + pad, ty0 + th + small_reach); ++yp) {
        const int y = mirror(yp, h);
        if (pr.row_small[y] == 0) continue;
        for (int f = 0; f < nf; ++f) {
          const std::uint8_t* fl = &pr.flags[f * n + static_cast<std::size_t>(y) * w];
          for (int xp = std::max(-pad, tx0 - small_reach); xp < std::min(w + pad, tx0 + tw + small_reach); ++xp) {
            const int x = xp >= 0 && xp < w ? xp : mirror(xp, w);
            if (fl[x] & kSmall) direct(xp, yp, f * n + static_cast<std::size_t>(y) * w + x);
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
      // (rows outside [ra, rb) are zero), columns [xa, xb].
      auto vertical = [&](const Grid& g, int y, int ra, int rb, const auto& plane, int xa, int xb) {
        int x0, y0;
        float ax, ay;
        g.locate(tx0, y, x0, y0, ax, ay);
        for (int c = 0; c < 5; ++c) {
          float* dst = vrow + c * vstride;
          const float* a = y0 >= ra && y0 < rb ? plane(c, y0) : nullptr;
          const float* b = y0 + 1 >= ra && y0 + 1 < rb ? plane(c, y0 + 1) : nullptr;
          lerp_rows(a ? a + xa : nullptr, b ? b + xa : nullptr, ay, dst + xa, xb - xa + 1);
        }
      };
      // Slices, read back bilinearly.
      for (int s = 0; s < 2; ++s)
        for (int j = 0; j < k; ++j) {
          const SliceBuf& b = sb[s][j];
          if (!b.used || !b.sliced) continue;
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
          ++tile_folds;
          FoldRow fr;
          fr.x0 = tx0;
          fr.level = g.level;
          fr.margin = g.margin;
          fr.norm = 1.0f / static_cast<float>(1 << (2 * g.level));
          fr.su = sd.u[j];
          fr.ssharp = sd.sharp[j];
          fr.hidden = s > 0;
          for (int c = 0; c < 5; ++c) fr.row[c] = vrow + c * vstride;
          for (int y = ty0; y < ty0 + th; ++y) {
            vertical(
                g, y, b.a0, b.a1, [&](int c, int Y) { return b.arow(c, Y); }, xa, xb);
            fold_row(fr, receivers(y - ty0, 0, tw));
          }
        }
      // Estimate: each receiver's two slices.
      for (int c = 0; c < 5; ++c) std::fill(est + c * kPlane, est + c * kPlane + th * kStride, 0.0f);
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
          ++tile_est;
          EstRow er;
          er.x0 = tx0;
          er.level = g.level;
          er.margin = g.margin;
          er.j = j;
          for (int c = 0; c < 5; ++c) er.row[c] = vrow + c * vstride;
          for (int y = ty0; y < ty0 + th; ++y) {
            const std::size_t o = static_cast<std::size_t>(y - ty0) * kStride;
            vertical(
                g, y, b.m0, b.m1, [&](int c, int Y) { return b.erow(c, Y); }, xa, xb);
            er.n = tw;
            er.slice = rslice + o;
            er.t = rt + o;
            er.sharp = rsharp + o;
            for (int c = 0; c < 5; ++c) er.est[c] = est + c * kPlane + o;
            est_row(er);
          }
        }
      }
      // Debug views of the tile.
      if (views.front || views.back || views.estimate)
        for (int y = ty0; y < ty0 + th; ++y)
          for (int x = tx0; x < tx0 + tw; ++x) {
            const std::size_t p = static_cast<std::size_t>(y - ty0) * kStride + (x - tx0);
            float a[15], e[5], fr4[4], bk[4], es[4];
            for (int c = 0; c < 15; ++c) a[c] = c < 10 || nf > 1 ? acc[c * kPlane + p] : 0.0f;
            for (int c = 0; c < 5; ++c) e[c] = est[c * kPlane + p];
            composite_parts(a, e, a + 10, fr4, bk, es);
            for (int c = 0; c < 4; ++c) {
              if (views.front) views.front->at(x, y, c) = fr4[c];
              if (views.back) views.back->at(x, y, c) = bk[c];
              if (views.estimate) views.estimate->at(x, y, c) = es[c];
            }
          }
      if (views.tiles) {
        const float v[4] = {static_cast<float>(tile_folds) / static_cast<float>(std::max(k, 1)),
                            tile_direct > 0 ? 1.0f : 0.0f,
                            static_cast<float>(tile_est) / static_cast<float>(std::max(k, 1)), 1.0f};
        for (int c = 0; c < 4; ++c)
          for (int y = ty0; y < ty0 + th; ++y)
            std::fill(&views.tiles->at(tx0, y, c), &views.tiles->at(tx0, y, c) + tw, v[c]);
      }
      // Composite, straight into the frame's rows.
      float* const cov = ts.outp.data();
      for (int y = ty0; y < ty0 + th; ++y) {
        const std::size_t o = static_cast<std::size_t>(y - ty0) * kStride;
        CompositeRow cr;
        cr.n = tw;
        cr.hidden = nf > 1;
        for (int c = 0; c < 15; ++c) cr.acc[c] = acc + c * kPlane + o;
        for (int c = 0; c < 5; ++c) cr.est[c] = est + c * kPlane + o;
        for (int c = 0; c < 4; ++c) {
          cr.src[c] = src.colour[0]->row(c, y) + tx0;
          cr.out[c] = out.row(c, y) + tx0;
        }
        if (cover)
          for (int c = 0; c < 3; ++c) cr.cover[c] = cov + c * kStride;
        composite_row(cr);
        if (cover) {
          for (int c = 0; c < 3; ++c) std::memcpy(cover->row(c, y) + tx0, cov + c * kStride, sizeof(float) * tw);
          std::fill(cover->row(3, y) + tx0, cover->row(3, y) + tx0 + tw, 1.0f);
        }
      }
    }
  };
  core::parallel_for(tiles_x * tiles_y, with_progress(opt.progress, tile_body));
}

}  // namespace

void render_fast(const Sources& src, const SlicePlan& plan, const LensOptions& opt, Workspace& ws, Image& out,
                 const Views& views) {
  State& st = ws.object<State>("lens.state");
  {
    core::PassScope pass("prep");
    prepare(src, plan, opt, st.pr);
  }
  FrameCtx fc(src, plan, opt, st);
  slice_views(fc, views);
  allocate_slices(fc);
  merge_pass(fc);
  convolve_pass(fc);
  estimate_pass(fc);
  tile_pass(fc, out, views);
}

}  // namespace dofkit::detail::lens
