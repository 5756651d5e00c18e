// Fast P2/P3/P4 of the McGuire method for book/demo (impl=fast). Same sums as the plain
// passes in blur.cpp / composite.cpp, organised so that no output visits a tap that cannot
// contribute and no tap weight costs more than a division and a table lookup:
//
// * Far/focus blur, far centre (nearness 0): w = table[⌊5|δ| / den_B⌋] is exactly 0 once
//   |δ| >= 1.2·den_B, so the taps stop at the largest such reach over the outputs' window
//   (per block of outputs); the remaining taps run in SIMD across adjacent outputs
//   (far_gather_simd). Horizontal: the (virtually) padded row is read from the source row
//   straight into f phase planes, so the taps of f-strided outputs are contiguous; a row is
//   set up piece by piece just ahead of the blocks that read it. Vertical: taps are rows,
//   outputs are contiguous columns.
// * Far/focus blur, near centre (nearness 1): every tap has w = wn + (1 − wn) = 1, so the
//   result is the mean of the 2R+1 taps: a box, read from double prefix sums (horizontal) or
//   double sliding row sums (vertical) in O(1) per output.
// * Fractional nearness (only when focus_px < 0.25): the generic weight over all 2R+1 taps.
// * Near field, horizontal: tap B adds α_B·(colour, 1) to every output within
//   h_B = min(⌊r_B⌋, ⌈R_near⌉ − 1) px (the |δ| <= r_B test times the box |δ| < R_near) — a
//   box scatter. Sources are grouped by h ("levels"): all sources of one level give every
//   output the window sum of the level's (masked) sources, from block sums over f-pixel
//   blocks + a prefix (SIMD for f = 2, 4), O(extent/f) per level. Levels with few sources for
//   their extent keep the per-source difference array over the output index (double).
//   Vertical: the box |δ| < R_near of the premultiplied rows, as a double sliding row sum.
//
// Box sums are exact in double up to the final rounding, so they differ from the plain
// float running sums by that rounding only (< 1e-6 relative); the SIMD gather differs by FMA
// rounding. Work is split into a fixed number of chunks (independent of the thread count),
// and each chunk's arithmetic does not depend on the others, so output is identical for any
// number of threads.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <type_traits>
#include <vector>

#include "core/parallel.hpp"
#include "methods/mcguire/blur_weights.hpp"
#include "methods/mcguire/fast.hpp"
#include "methods/mcguire/gather.hpp"

namespace dofkit::detail::mcguire {

namespace {

/// Fixed chunking: chunk c of n covers [N·c/n, N·(c+1)/n).
inline int chunk_begin(int N, int n, int c) { return static_cast<int>(static_cast<long long>(N) * c / n); }

void load_table(const Constants& k, float* table16) {
  std::fill_n(table16, 16, 0.0f);
  std::copy_n(k.variant == Variant::book ? kGaussianTable : kDiscTable, 7, table16);
}

/// ⌊a / b⌋ and ⌈a / b⌉ for b > 0 and any sign of a.
inline int floor_div(int a, int b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }
inline int ceil_div(int a, int b) { return a <= 0 ? -((-a) / b) : (a + b - 1) / b; }

// In-place running sums p[k][j] += p[k][j − 1] for j = 1 … n, for K arrays at once. A lone
// running sum is bound by the add's latency (one element per ~4 cycles); K independent
// chains in one loop overlap. Each array's additions are the same, in the same order, as a
// loop of its own (s + v and v + s round alike), so the sums are bit-identical.
template <int K>
void running_sums(double* const (&p)[K], int n) {
  double s[K];
  for (int k = 0; k < K; ++k) s[k] = p[k][0];
  for (int j = 1; j <= n; ++j)
    for (int k = 0; k < K; ++k) {
      s[k] += p[k][j];
      p[k][j] = s[k];
    }
}

constexpr int kBlock = 32;  // outputs per tap-bound block

/// Far gather of outputs [i0, i1) of row `row` of `dst` (planes 0-3) from the taps
/// δ = −L … L of `taps` (2R + 1 entries pointing at output 0's sources); r_a and nearness
/// are indexed by output from the row's start. frac: some output in [i0, i1) has a
/// fractional nearness (else the near centres' outputs are left for the caller's box
/// sums). Shared by the horizontal and vertical passes.
void far_gather_outputs(const std::vector<GatherTap>& taps, std::ptrdiff_t col_stride, std::ptrdiff_t aux_stride, int L,
                        const float* r_a, const float* nearness, bool frac, const float* table, bool occlusion,
                        Image& dst, int row, int i0, int i1) {
  // taps[R + d] is tap δ = d for output 0 (R = (taps.size() − 1) / 2); output i0 reads i0 on.
  GatherJob job;
  job.n = i1 - i0;
  job.ntaps = 2 * L + 1;
  job.taps = taps.data() + ((static_cast<int>(taps.size()) - 1) / 2 - L);
  job.tap_offset = i0;
  job.col_stride = col_stride;
  job.aux_stride = aux_stride;
  job.r_a = r_a + i0;
  job.nearness = nearness + i0;
  job.frac = frac;
  job.table = table;
  job.occlusion = occlusion;
  for (int c = 0; c < 4; ++c) job.out[c] = dst.row(c, row) + i0;
  far_gather_simd(job);
}

}  // namespace

bool fast_supported(const Constants& k) { return k.variant != Variant::g3d; }

void blur_horizontal_fast(const Image& colour, const Image& coc, const Rect& src, const Constants& k, int ox, int wo,
                          Image& t_blur, Image& t_near, Workspace& /*ws*/, std::atomic<bool>* colour_dirty,
                          int* near_span) {
  const int W = src.w, H = src.h, R = k.r_max, f = k.f;
  const float rmax = static_cast<float>(R);
  t_blur.resize(wo, H, 5);
  t_near.resize(wo, H, 5);
  const float near_inv = near_box_inverse_norm(k);
  // Near box: |δ| < R_near ⟺ |δ| <= ⌈R_near⌉ − 1, and taps only span [−R, R].
  const int hbox = k.r_near > 0 ? std::min(R, static_cast<int>(std::ceil(k.r_near)) - 1) : -1;
  float table[16];
  load_table(k, table);

  const int P = W + 2 * R;           // padded row: x = source + R, clamped at the edges
  const int ng = prep_groups(P, f);  // f-pixel groups x = f·m … f·m + f − 1 the set-up writes
  const int M = ng + 64;             // phase array length (+ the set-up's last vector)
  // Scratch of a chunk (one per thread, below), in floats (each block rounded up to 16
  // floats = 64 bytes): the row set-up's 9 phase planes (f·M each, PrepRowJob) and its
  // per-group arrays rc, sc, nc, reach (M each), lvl_n/lo/hi; then doubles: block prefix +
  // partial sums 4·PST (PST = 2P + 4 >= 2·nb + 1), near bins 5·(wo+2), level sums, level
  // accumulators 5·wo.
  auto up16 = [](std::size_t n) { return (n + 15) & ~std::size_t(15); };
  const std::size_t n_ph = up16(9 * static_cast<std::size_t>(f) * M), n_m = up16(M);
  const std::size_t n_lvl = up16(static_cast<std::size_t>(std::max(hbox, 0)) + 1);
  const std::size_t n_float = n_ph + 4 * n_m + 3 * n_lvl;
  const std::size_t PST = 2 * static_cast<std::size_t>(P) + 4;
  const std::size_t n_double =
      4 * PST + 5 * static_cast<std::size_t>(wo + 2) +
      std::max(5 * static_cast<std::size_t>(P + 1), 10 * static_cast<std::size_t>(wo + R + 3)) +
      5 * static_cast<std::size_t>(wo);
  const std::size_t per_chunk = n_float + 2 * n_double + 32;
  const int nchunk = std::min(H, 64);
  const float inv_rmax = R > 0 ? 1.0f / rmax : 0.0f;
  const std::size_t plane = static_cast<std::size_t>(f) * M;
  const int cx0 = ox + R;                 // padded x of output 0's centre
  const int p0 = cx0 % f, mc0 = cx0 / f;  // its phase and group: output i is group mc0 + i

  core::parallel_for(nchunk, [&](int c0, int c1) {
    std::vector<GatherTap> taps(2 * R + 1);
    // Scratch per thread, not per chunk: a thread's chunks reuse the same ≈ 0.3 MB (at
    // 1080p), which stays in its L2; per-chunk rows of one workspace image (64 of them,
    // 20 MB) were written cold by every chunk (callgrind with a 2 MB last-level cache: 14 %
    // fewer write misses in P2). Each chunk writes what it reads before reading it, so the
    // bits do not depend on which thread ran what before. Grown once, reused by later frames.
    thread_local std::vector<float> scratch;
    if (scratch.size() < per_chunk) scratch.resize(per_chunk);
    for (int chunk = c0; chunk < c1; ++chunk) {
      float* base =
          reinterpret_cast<float*>((reinterpret_cast<std::uintptr_t>(scratch.data()) + 63) & ~std::uintptr_t(63));
      float* ph = base;  // phase planes: q·(f·M) + p·M + m
      float* rc = base + n_ph;
      float* sc = rc + n_m;
      float* nc = sc + n_m;
      int* greach = reinterpret_cast<int*>(nc + n_m);
      int* lvl_n = greach + n_m;    // per box half-width h <= hbox: source count, first and
      int* lvl_lo = lvl_n + n_lvl;  // last padded x
      int* lvl_hi = lvl_lo + n_lvl;
      double* prefix = reinterpret_cast<double*>(lvl_hi + n_lvl);  // 4 × PST
      double* bins = prefix + 4 * PST;                             // 5 × (wo+2)
      double* lsum = bins + 5 * static_cast<std::size_t>(wo + 2);  // 5 × (P+1)
      double* acc =
          lsum + std::max(5 * static_cast<std::size_t>(P + 1), 10 * static_cast<std::size_t>(wo + R + 3));  // 5 × wo
      const float* const r_a = rc + mc0;  // per output: centre r_B and nearness
      const float* const nearness = nc + mc0;
      const int32_t* const nh = reinterpret_cast<const int32_t*>(ph + 8 * plane);  // near h, α by phase
      const float* const na = ph + 7 * plane;
      auto at = [&](int x) { return static_cast<std::size_t>(x % f) * M + x / f; };  // padded x in a plane

      // Taps of output 0 (padded x ox + R + δ), the same for every row of the chunk.
      for (int d = -R; d <= R; ++d) {
        const int q = ox + R + d;
        const std::size_t xq = at(q);
        GatherTap& t = taps[R + d];
        t.col = ph + xq;              // planes 0-3, stride `plane`
        t.aux = ph + 4 * plane + xq;  // planes 4-6
        t.d5 = d == 0 ? kCentreD5 : 5.0f * static_cast<float>(std::abs(d));
      }
      PrepRowJob prep;
      prep.W = W;
      prep.R = R;
      prep.f = f;
      prep.M = M;
      prep.ph = ph;
      prep.p0 = p0;
      prep.rc = rc;
      prep.sc = sc;
      prep.nc = nc;
      prep.reach = greach;
      prep.inv_rmax = inv_rmax;
      prep.rmax = rmax;
      prep.focus_px = k.focus_px;
      prep.dc = k.variant == Variant::book ? 0.5f : 0.8f;
      prep.abs_r = k.far_occlusion;
      if (hbox >= 0) {
        prep.near = true;
        prep.hbox = hbox;
        prep.inv_near = k.inv_near;
        prep.alpha_code = k.near_alpha_code;
      }

      for (int y = chunk_begin(H, nchunk, chunk); y < chunk_begin(H, nchunk, chunk + 1); ++y) {
        for (int c = 0; c < 5; ++c) prep.src[c] = (c < 4 ? colour.row(c, src.y + y) : coc.row(0, src.y + y)) + src.x;
        // render()'s colour check is made by the set-up on the colour it loads.
        prep.check_colour = colour_dirty != nullptr;
        prep.dirty = false;
        prep.reset_stats();
        // The row is set up in pieces just ahead of the far gather's blocks, so each block
        // reads what was written a moment before (the whole row's planes, ≈ 80 KB at 1080p,
        // do not fit in L1, and read after a whole-row set-up most taps came from L2).
        int done = 0;  // groups [0, done) are set up
        auto prep_to = [&](int g) {
          g = std::min(g, ng);
          if (g > done) prep_row_simd(prep, done, g);
          done = std::max(done, g);
        };
        int box_lo = wo, box_hi = -1;  // first and last output with a near centre
        for (int i0 = 0; i0 < wo; i0 += kBlock) {
          const int i1 = std::min(wo, i0 + kBlock);
          // The block's taps read padded x in [ox + f·i0, ox + f·(i1 − 1) + 2R].
          const int g_lo = (ox + f * i0) / f, g_hi = (ox + f * (i1 - 1) + 2 * R) / f;
          prep_to(g_hi + 1);
          // The block's near centres (box sums below), whether it has far or fractional
          // centres (gather needed; fractional: no tap bound), and the tap bound: the largest
          // reach over the groups that hold the window (a superset of it by < f pixels each
          // side; taps past every source's reach add exact zeros to the far centres' sums,
          // so a larger bound gives the same bits).
          ScanBlockJob scan;
          scan.nearness = nearness + i0;
          scan.n = i1 - i0;
          scan.reach = greach;
          scan.g0 = g_lo;
          scan.g1 = g_hi;
          scan_block_simd(scan);
          if (scan.first_one >= 0) {
            box_lo = std::min(box_lo, i0 + scan.first_one);
            box_hi = i0 + scan.last_one;
          }
          if (!scan.any_far) continue;
          const int L = scan.any_frac ? R : std::min(R, scan.max_reach);
          far_gather_outputs(taps, static_cast<std::ptrdiff_t>(plane), static_cast<std::ptrdiff_t>(plane), L, r_a,
                             nearness, scan.any_frac, table, k.far_occlusion, t_blur, y, i0, i1);
        }
        prep_to(ng);
        if (prep.dirty) colour_dirty->store(true, std::memory_order_relaxed);
        finish_near_stats(prep);
        // Near-centre box (written over the gather's output for those centres): output i's
        // window is padded [ox + f·i, ox + f·i + 2R], i.e. with 2R + 1 = f·qb + rem, the q
        // whole f-blocks j = i .. i + qb − 1 of the grid starting at ox plus the first rem
        // pixels of block i + qb. So W(i) = PG[i + qb] − PG[i] + Rm(i + qb) with G(j) the
        // block sums, PG their prefix sums and Rm(j) the partial block sums (all double): a
        // running sum over ≈ P/f blocks instead of P pixels. Only the blocks j in
        // [box_lo, box_hi + qb] are read (PG from box_lo on, relative to PG[box_lo] = 0: the
        // differences are what counts).
        const int qb = (2 * R + 1) / f, rem = (2 * R + 1) % f, nb = wo + qb;
        if (box_hi >= 0) {
          const int j0 = box_lo, nj = box_hi - box_lo + qb + 1;
          double* pg[4];
          for (int c = 0; c < 4; ++c) {
            double* PG = prefix + c * PST;
            double* RM = PG + (nb + 1);
            BlockSumsJob bs;
            bs.ph_plane = ph + c * plane;
            bs.M = M;
            bs.f = f;
            bs.x0 = ox + f * j0;
            bs.rem = rem;
            bs.nb = nj;
            bs.G = PG + j0 + 1;  // block sums, turned into prefix sums in place
            bs.Rm = RM + j0;
            block_sums_simd(bs);
            PG[j0] = 0;
            pg[c] = PG + j0;
          }
          running_sums(pg, nj);
          // W(i) / (2R + 1), the plain pass's Σw (every w = 1), where nearness is 1.
          BoxOutJob box;
          box.n = box_hi - box_lo + 1;
          box.nearness = nearness + box_lo;
          box.w = static_cast<float>(2 * R + 1);
          for (int c = 0; c < 4; ++c) {
            const double* PG = prefix + c * PST + box_lo;
            box.a[c] = PG + qb;
            box.b[c] = PG;
            box.c[c] = PG + (nb + 1) + qb;  // RM
            box.out[c] = t_blur.row(c, y) + box_lo;
          }
          box_out_simd(box);
        }
        std::copy_n(sc + mc0, wo, t_blur.row(4, y));

        // Near field: box scatter via a difference array over the output index.
        if (near_span != nullptr) {  // no near output yet: all +0
          near_span[2 * y] = wo;
          near_span[2 * y + 1] = -1;
        }
        if (hbox < 0 || !prep.any_near) {
          for (int c = 0; c < 5; ++c) std::fill_n(t_near.row(c, y), wo, 0.0f);
          continue;
        }
        // Sources by box half-width h: a source of half-width h adds v = α·(colour, 1) to
        // the outputs with |cx0 + f·i − x| <= h. For all sources of one h in [lo, hi] the
        // sum over output i's reach is S(min(hi, x_i + h) + 1) − S(max(lo, x_i − h)) with S
        // the prefix sum of the level's v (others count 0): O(extent + outputs) per level
        // instead of ten bin updates per source. Levels with few sources for their extent
        // keep the difference-array scatter. Both sums are double.
        std::fill_n(lvl_n, hbox + 1, 0);
        if (prep.near_hmin == prep.near_hmax) {  // one level: the set-up's statistics
          lvl_n[prep.near_hmin] = prep.near_count;
          lvl_lo[prep.near_hmin] = prep.near_first;
          lvl_hi[prep.near_hmin] = prep.near_last;
        } else {
          // By runs of equal half-width along each phase plane (neighbouring sources mostly
          // share one): a counter bumped per source would wait on its own store every step.
          for (int p = 0; p < f; ++p) {
            const int32_t* hp = nh + static_cast<std::size_t>(p) * M;
            const int m_end = (prep.near_last - p) >= 0 ? (prep.near_last - p) / f : -1;  // last m of the range
            for (int m = std::max(0, ceil_div(prep.near_first - p, f)); m <= m_end;) {
              const int h = hp[m];
              int e = m + 1;
              while (e <= m_end && hp[e] == h) ++e;
              if (h >= 0) {
                const int xl = f * m + p, xh = f * (e - 1) + p;
                if (lvl_n[h] == 0) {
                  lvl_lo[h] = xl;
                  lvl_hi[h] = xh;
                } else {
                  lvl_lo[h] = std::min(lvl_lo[h], xl);
                  lvl_hi[h] = std::max(lvl_hi[h], xh);
                }
                lvl_n[h] += e - m;
              }
              m = e;
            }
          }
        }
        const std::size_t st = wo + 2;
        bool any_scatter = false, any_level = false;
        int n_level = 0;               // levels summed by blocks
        int acc_lo = wo, acc_hi = -1;  // outputs reached by the levels
        for (int h = 0; h <= hbox; ++h) {
          const int n = lvl_n[h];
          if (n == 0) continue;
          const int ext = lvl_hi[h] - lvl_lo[h] + 1;
          // Cost model (instructions, measured order of magnitude): scatter ≈ 40 per source;
          // level ≈ 12 per pixel of the extent + 20 per output reached.
          if (12 * ext + 20 * ((ext + 2 * h) / f + 1) < 40 * n) {
            lvl_n[h] = -n;  // marks "done by level"
            any_level = true;
            ++n_level;
            acc_lo = std::min(acc_lo, std::max(0, ceil_div(lvl_lo[h] - h - cx0, f)));
            acc_hi = std::max(acc_hi, std::min(wo - 1, floor_div(lvl_hi[h] + h - cx0, f)));
          } else {
            any_scatter = true;
          }
        }
        if (any_scatter) {  // the running sum below reads every output's level sum
          acc_lo = 0;
          acc_hi = wo - 1;
        }
        // One level summed by blocks and nothing scattered (most rows): its window sums are
        // the outputs, written straight to t_near. The other rows sum the levels into acc
        // from 0: 0 + v is v bit for bit (v, a difference and sum of non-negative-zero sums,
        // is never −0), so both ways give the same bits.
        const bool direct = !any_scatter && n_level == 1 && (f == 2 || f == 4);
        if (acc_hi >= acc_lo && !direct)
          for (int c = 0; c < 5; ++c)
            std::fill_n(acc + c * static_cast<std::size_t>(wo) + acc_lo, acc_hi - acc_lo + 1, 0.0);
        for (int h = 0; h <= hbox; ++h) {
          if (lvl_n[h] >= 0) continue;
          const int ext = lvl_hi[h] - lvl_lo[h] + 1;
          const int lo = lvl_lo[h], hi = lvl_hi[h];
          const int ilo = std::max(0, ceil_div(lo - h - cx0, f));
          const int ihi = std::min(wo - 1, floor_div(hi + h - cx0, f));
          if (f == 2 || f == 4) {
            // Blocks of f sources from x0 = x_ilo − h: output i's reach [x_i − h, x_i + h]
            // (2h + 1 = f·qn + rn sources) is blocks i − ilo … i − ilo + qn − 1 plus rn
            // sources of block i − ilo + qn; sources of other levels count 0 (masked), so no
            // clamping to [lo, hi] is needed. The reach stays inside [0, P): x_i ± h with
            // R <= x_i − ox < P − R.
            const int qn = (2 * h + 1) / f, rn = (2 * h + 1) % f, nbl = ihi - ilo + qn + 1;
            LevelBlocksJob lb;
            lb.ph = ph;
            lb.M = M;
            lb.level = h;
            lb.x0 = cx0 + f * ilo - h;
            lb.f = f;
            lb.rem = rn;
            lb.nb = nbl;
            const std::size_t ls = static_cast<std::size_t>(nbl) + 1;
            for (int c = 0; c < 5; ++c) {
              lb.G[c] = lsum + 2 * c * ls + 1;  // block sums, turned into prefix sums in place
              lb.Rm[c] = lsum + (2 * c + 1) * ls;
            }
            level_blocks_simd(lb);
            double* pg[5];
            for (int c = 0; c < 5; ++c) {
              pg[c] = lsum + 2 * c * ls;
              pg[c][0] = 0;
            }
            running_sums(pg, nbl);
            // acc[i] += PG[i − ilo + qn] − PG[i − ilo] + RM[i − ilo + qn].
            for (int c = 0; c < 5; ++c) {
              if (direct) {  // acc_lo = ilo, acc_hi = ihi
                float* oc = t_near.row(c, y);
                std::fill_n(oc, ilo, 0.0f);
                window_scale_simd(oc + ilo, pg[c] + qn, pg[c], pg[c] + ls + qn, near_inv, ihi - ilo + 1);
                std::fill_n(oc + ihi + 1, wo - 1 - ihi, 0.0f);
              } else {
                window_add_simd(acc + c * static_cast<std::size_t>(wo) + ilo, pg[c] + qn, pg[c], pg[c] + ls + qn,
                                ihi - ilo + 1);
              }
            }
            continue;
          }
          const std::size_t ls = ext + 1;
          double s[5] = {0, 0, 0, 0, 0};
          for (int c = 0; c < 5; ++c) lsum[c * ls] = 0.0;
          for (int x = lo; x <= hi; ++x) {
            const std::size_t lx = x - lo + 1, ax = at(x);
            if (nh[ax] == h) {
              const float a = na[ax];
              for (int c = 0; c < 4; ++c) s[c] += static_cast<double>(a * ph[c * plane + ax]);
              s[4] += a;
            }
            for (int c = 0; c < 5; ++c) lsum[c * ls + lx] = s[c];
          }
          // Outputs i with lo − h <= cx0 + f·i <= hi + h.
          for (int i = ilo; i <= ihi; ++i) {
            const int xi = cx0 + f * i;
            const int b = std::max(lo, xi - h) - lo, e = std::min(hi, xi + h) - lo + 1;
            for (int c = 0; c < 5; ++c)
              acc[c * static_cast<std::size_t>(wo) + i] += lsum[c * ls + e] - lsum[c * ls + b];
          }
        }
        if (any_scatter) std::fill_n(bins, 5 * st, 0.0);
        // The divisions by f below are by a compile-time constant (shifts / multiplies).
        auto scatter = [&](auto fc) {
          constexpr int F = decltype(fc)::value;
          for (int x = prep.near_first; x <= prep.near_last; ++x) {
            const std::size_t ax = static_cast<std::size_t>(x % F) * M + x / F;
            const int h = nh[ax];
            if (h < 0 || lvl_n[h] < 0) continue;  // not near, or done by its level
            const float alpha = na[ax];
            if (alpha == 0.0f) continue;
            // Outputs i with |cx0 + F·i − x| <= h.
            const int lo_num = x - h - cx0, hi_num = x + h - cx0;
            int ilo = lo_num <= 0 ? -((-lo_num) / F) : (lo_num + F - 1) / F;
            int ihi = hi_num >= 0 ? hi_num / F : -((-hi_num + F - 1) / F);
            ilo = std::max(ilo, 0);
            ihi = std::min(ihi, wo - 1);
            if (ilo > ihi) continue;
            for (int c = 0; c < 4; ++c) {
              const double v = static_cast<double>(alpha * ph[c * plane + ax]);
              bins[c * st + ilo] += v;
              bins[c * st + ihi + 1] -= v;
            }
            bins[4 * st + ilo] += alpha;
            bins[4 * st + ihi + 1] -= alpha;
          }
        };
        if (any_scatter) {
          switch (f) {
            case 1:
              scatter(std::integral_constant<int, 1>{});
              break;
            case 2:
              scatter(std::integral_constant<int, 2>{});
              break;
            case 3:
              scatter(std::integral_constant<int, 3>{});
              break;
            default:
              scatter(std::integral_constant<int, 4>{});
              break;
          }
        }
        {
          float* o[5];
          for (int c = 0; c < 5; ++c) o[c] = t_near.row(c, y);
          if (near_span != nullptr && (any_scatter || any_level)) {  // outside: +0 below
            near_span[2 * y] = any_scatter ? 0 : acc_lo;
            near_span[2 * y + 1] = any_scatter ? wo - 1 : acc_hi;
          }
          if (any_scatter) {
            // Five independent running sums in one loop.
            double q[5] = {0, 0, 0, 0, 0};
            for (int i = 0; i < wo; ++i)
              for (int c = 0; c < 5; ++c) {
                q[c] += bins[c * st + i];
                const double lv = any_level ? acc[c * static_cast<std::size_t>(wo) + i] : 0.0;
                o[c][i] = static_cast<float>(q[c] + lv) * near_inv;
              }
          } else if (direct) {
            // written above
          } else if (any_level) {
            for (int c = 0; c < 5; ++c) {
              float* __restrict oc = o[c];
              const double* __restrict ac = acc + c * static_cast<std::size_t>(wo);
              std::fill_n(oc, acc_lo, 0.0f);
              scale_row_simd(oc + acc_lo, ac + acc_lo, near_inv, acc_hi - acc_lo + 1);
              std::fill_n(oc + acc_hi + 1, wo - 1 - acc_hi, 0.0f);
            }
          } else {
            for (int c = 0; c < 5; ++c) std::fill_n(o[c], wo, 0.0f);
          }
        }
      }
    }
  });
}

void blur_vertical_fast(const Image& t_blur, const Image& t_near, const Constants& k, int oy, int ho, Image& blur,
                        Image& near, Workspace& ws, const int* near_span) {
  const int W = t_blur.width(), H = t_blur.height(), R = k.r_max, f = k.f;
  const float rmax = static_cast<float>(R);
  blur.resize(W, ho, 4);
  near.resize(W, ho, 5);
  const float near_inv = near_box_inverse_norm(k);
  const int hbox = k.r_near > 0 ? std::min(R, static_cast<int>(std::ceil(k.r_near)) - 1) : -1;
  float table[16];
  load_table(k, table);

  // Per t_blur row (+ slack for vector over-reads), GatherTap's aux planes: 1/den (+∞ for a
  // near source), den (0 for a near source), |r|; and the largest reach of the far sources
  // per column block.
  const int nblk = (W + kBlock - 1) / kBlock;
  Image& aux = ws.image("mcguire.fast.v_aux", W + 64, H, 3);
  // (Rows padded to whole vectors: max_rows_simd reads a vector of blocks from each.)
  const int nblk_pad = (nblk + 15) & ~15;
  Image& reach = ws.image("mcguire.fast.v_reach", nblk_pad, H, 1);
  core::parallel_for(
      H,
      [&](int y0, int y1) {
        for (int y = y0; y < y1; ++y) {
          AuxRowJob job;
          job.s = t_blur.row(4, y);
          job.w = W;
          job.block = kBlock;
          job.rmax = rmax;
          job.dc = k.variant == Variant::book ? 0.5f : 0.8f;
          job.inv = aux.row(0, y);
          job.den = aux.row(1, y);
          job.absr = aux.row(2, y);
          job.blk_reach = reach.row(0, y);
          aux_row_simd(job);
        }
      },
      16);

  // Output rows in fixed chunks; each chunk keeps double sliding row sums of t_blur (radius R,
  // for near centres) and of t_near (radius hbox).
  // Each chunk starts its sliding sums from scratch (2R+1 rows per channel), so fewer chunks
  // read fewer rows; 16 keeps 2-4 threads balanced (8 read 6 M fewer instructions per 1080p
  // frame but were no faster at 2 threads: the chunks differ in work).
  const int nchunk = std::min(ho, 16);
  const std::size_t per_chunk = 2 * (9 * static_cast<std::size_t>(W) + 2 * (W + 64)) + 8;
  Image& scratch = ws.image("mcguire.fast.v_scratch", static_cast<int>(per_chunk), nchunk, 1);
  core::parallel_for(nchunk, [&](int c0, int c1) {
    std::vector<GatherTap> taps(2 * R + 1);
    std::vector<float> blk_reach(nblk_pad);
    for (int chunk = c0; chunk < c1; ++chunk) {
      float* fbase = scratch.row(0, chunk);
      float* r_a = fbase;
      float* nearness = r_a + W + 64;
      double* sum_b =
          reinterpret_cast<double*>(reinterpret_cast<std::uintptr_t>(nearness + W + 66) & ~std::uintptr_t(7));
      double* sum_n = sum_b + 4 * static_cast<std::size_t>(W);
      const int j0 = chunk_begin(ho, nchunk, chunk), j1 = chunk_begin(ho, nchunk, chunk + 1);
      // Columns [box_c0, box_c1] hold every near centre of the chunk's output rows: the
      // t_blur window sums (read only there) slide over those columns only.
      int box_c0 = W, box_c1 = -1;
      for (int j = j0; j < j1; ++j) {
        const float* sa = t_blur.row(4, oy + f * j);
        for (int i = 0; i < W; ++i)
          if (saturate(4.0f * (sa[i] * rmax)) == 1.0f) {
            box_c0 = std::min(box_c0, i);
            box_c1 = std::max(box_c1, i);
          }
      }
      const bool chunk_box = box_c1 >= 0;
      // Columns [near_c0, near_c1] hold every t_near value other than +0 in the rows the
      // chunk's near sums read (P2's near_span); outside them those sums are +0 and so is
      // the output, so they slide over these columns only (none: near output all +0).
      int near_c0 = 0, near_c1 = hbox >= 0 ? W - 1 : -1;
      if (near_span != nullptr && hbox >= 0) {
        near_c0 = W;
        near_c1 = -1;
        for (int b = std::max(0, oy + f * j0 - hbox); b <= std::min(H - 1, oy + f * (j1 - 1) + hbox); ++b) {
          near_c0 = std::min(near_c0, near_span[2 * b]);
          near_c1 = std::max(near_c1, near_span[2 * b + 1]);
        }
      }
      const bool chunk_near = near_c1 >= near_c0;
      const float box_w = static_cast<float>(2 * R + 1);
      for (int j = j0; j < j1; ++j) {
        const int a = oy + f * j;
        if (j == j0) {
          // Window sums from scratch, 8 rows per pass.
          auto init = [&](double* sum, const Image& img, int nc, int r, int x0, int x1) {
            for (int c = 0; c < nc; ++c) {
              double* dst = sum + c * static_cast<std::size_t>(W) + x0;
              std::fill_n(dst, x1 - x0, 0.0);
              for (int b0 = a - r; b0 <= a + r; b0 += 8) {
                SlideRowsJob job;
                job.dst = dst;
                job.n = x1 - x0;
                for (int b = b0; b <= std::min(a + r, b0 + 7); ++b)
                  job.plus[job.nplus++] = img.row(c, std::clamp(b, 0, H - 1)) + x0;
                slide_rows_simd(job);
              }
            }
          };
          if (chunk_box) init(sum_b, t_blur, 4, R, box_c0, box_c1 + 1);
          if (chunk_near) init(sum_n, t_near, 5, hbox, near_c0, near_c1 + 1);
        } else {
          // Rows entering (prev + r, a + r] and leaving [prev − r, a − r) the window, at most
          // f of each (f <= 4 <= 8), folded into one pass over the sums.
          const int prev = a - f;
          auto slide = [&](double* sum, const Image& img, int nc, int r, int x0, int x1) {
            for (int c = 0; c < nc; ++c) {
              SlideRowsJob job;
              job.dst = sum + c * static_cast<std::size_t>(W) + x0;
              job.n = x1 - x0;
              for (int b = prev + r + 1; b <= a + r; ++b)
                job.plus[job.nplus++] = img.row(c, std::clamp(b, 0, H - 1)) + x0;
              for (int b = prev - r; b <= a - r - 1; ++b)
                job.minus[job.nminus++] = img.row(c, std::clamp(b, 0, H - 1)) + x0;
              slide_rows_simd(job);
            }
          };
          if (chunk_box) slide(sum_b, t_blur, 4, R, box_c0, box_c1 + 1);
          if (chunk_near) slide(sum_n, t_near, 5, hbox, near_c0, near_c1 + 1);
        }
        // Taps of this output row: rows a + δ, clamped.
        for (int d = -R; d <= R; ++d) {
          const int b = std::clamp(a + d, 0, H - 1);
          GatherTap& t = taps[R + d];
          t.col = t_blur.row(0, b);
          t.aux = aux.row(0, b);
          t.d5 = d == 0 ? kCentreD5 : 5.0f * static_cast<float>(std::abs(d));
        }
        const float* sa = t_blur.row(4, a);
        for (int i = 0; i < W; ++i) {
          r_a[i] = sa[i] * rmax;
          nearness[i] = saturate(4.0f * r_a[i]);
        }
        // Per column block, the largest reach over the window's rows a − R … a + R (clamped
        // rows repeat the edge rows, which does not change a maximum).
        max_rows_simd(blk_reach.data(), reach.row(0, 0), nblk_pad, std::max(0, a - R), std::min(H - 1, a + R), nblk);
        for (int i0 = 0; i0 < W; i0 += kBlock) {
          const int i1 = std::min(W, i0 + kBlock), blk = i0 / kBlock;
          ScanBlockJob scan;
          scan.nearness = nearness + i0;
          scan.n = i1 - i0;
          scan_block_simd(scan);
          if (scan.any_far) {
            const int L = scan.any_frac ? R : std::min(R, static_cast<int>(blk_reach[blk]));
            far_gather_outputs(taps, t_blur.row(1, 0) - t_blur.row(0, 0), aux.row(1, 0) - aux.row(0, 0), L, r_a,
                               nearness, scan.any_frac, table, k.far_occlusion, blur, j, i0, i1);
          }
          if (scan.first_one < 0) continue;
          BoxOutJob box;
          box.n = scan.last_one - scan.first_one + 1;
          box.nearness = nearness + i0 + scan.first_one;
          box.w = box_w;
          for (int c = 0; c < 4; ++c) {
            box.a[c] = sum_b + c * static_cast<std::size_t>(W) + i0 + scan.first_one;
            box.out[c] = blur.row(c, j) + i0 + scan.first_one;
          }
          box_out_simd(box);
        }
        for (int c = 0; c < 5; ++c) {
          float* o = near.row(c, j);
          if (!chunk_near) {
            std::fill_n(o, W, 0.0f);
            continue;
          }
          const double* sn = sum_n + c * static_cast<std::size_t>(W);
          std::fill_n(o, near_c0, 0.0f);
          scale_row_simd(o + near_c0, sn + near_c0, near_inv, near_c1 - near_c0 + 1);
          std::fill_n(o + near_c1 + 1, W - 1 - near_c1, 0.0f);
        }
      }
    }
  });
}

}  // namespace dofkit::detail::mcguire
