// Fast P9: the composite as a vectorised loop over row pairs. Same weights, sums and blends as
// composite.cpp, for both near upsamplings (bilinear, and the cubic B-spline of
// near_upsample=bicubic: see taps4).
//
// Footprint bookkeeping. Full-res column x reads half-res columns
//   ix1(x) = clamp(⌊(x − 1)/2⌋), ix2(x) = clamp(⌊(x + 1)/2⌋)
// with x-weights (¼, ¾) for even x and (¾, ¼) for odd x (composite.cpp axis()). For 8 pixels
// from an even x = 2m the two taps are, lane by lane,
//   tap 0: P[m−1] P[m] P[m] P[m+1] | P[m+1] P[m+2] P[m+2] P[m+3]
//   tap 1: P[m]   P[m+1] P[m+1] P[m+2] | P[m+2] P[m+3] P[m+3] P[m+4]
// i.e. one in-lane shuffle each of X = (P[m−1..m+2] | P[m+1..m+4]) — two 4-float loads, no
// doubled copy of the half-res rows (an earlier version wrote one per chunk). Border groups
// read a clamped copy of the six texels instead.
//
// Full-res rows 2p − 1 and 2p read the same two half-res rows (p − 1, p) (composite.cpp
// axis(): i0 = p − 1 for both) with y-weights (¾, ¼) and (¼, ¾), so they are computed
// together and every tap vector serves both rows.
//
// The ifs of composite.cpp become selects: a far tap with far_h = 0 gets weight 0 (adding
// 0·value leaves the sums unchanged — the values are finite), the far blend applies where
// far(q) > 0 and the weight sum is > 0, the near blend where its t > 0. A part whose blend is
// off in every lane of both rows (no far pixel; all four near taps' CoC 0) leaves the colour
// as its selects would and is skipped; chunks with no far pixel and no near tile around are
// copied.
//
// Order inside a group of 8 pixels × 2 rows: all eight colour vectors are loaded
// first, then the far and near weights (shared by the channels), then channel by channel the
// two blends and the stores. The x·y products of the bilinear weights are per row pair
// constants (Pair::wxy). Loading the colour first matters more than the instruction count:
// the planes of a 1080p frame lie a multiple of 4 kB apart, so a load of colour plane c + 1
// right after a store to output plane c at the same x has the same address bits 0–11 and is
// held back behind the store (4k aliasing); the channel-by-channel version with the load
// inside the loop ran no faster than the old code despite 14 % fewer instructions, the
// loads-first one 1.1–1.4 ms (≈ 9 %) faster per 1080p frame.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include "core/parallel.hpp"
#include "core/row_scan.hpp"
#include "methods/sterna/fast.hpp"
#include "methods/sterna/v8.hpp"

namespace dofkit::detail::sterna::fast {

namespace {

constexpr int kChunk = 256;  // full-res pixels per chunk (even)
constexpr int kPlanes = 10;  // far_fill ×4, far_h, near_fill ×4, near_blur

typedef float V4 __attribute__((vector_size(16)));

__attribute__((always_inline)) inline V4 load4(const float* p) {
  V4 v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

// The two x-taps of 8 pixels from x = 2m on half-res row P (w texels), see the top.
__attribute__((always_inline)) inline void taps(const float* P, int m, int w, bool inner, V8& t0, V8& t1) {
  V4 lo, hi;
  if (inner) {
    lo = load4(P + m - 1);
    hi = load4(P + m + 1);
  } else {
    float tmp[6];
    for (int k = 0; k < 6; ++k) tmp[k] = P[clampi(m - 1 + k, 0, w - 1)];
    lo = load4(tmp);
    hi = load4(tmp + 2);
  }
  const V8 x = __builtin_shufflevector(lo, hi, 0, 1, 2, 3, 4, 5, 6, 7);
  t0 = __builtin_shufflevector(x, x, 0, 1, 1, 2, 4, 5, 5, 6);
  t1 = __builtin_shufflevector(x, x, 1, 2, 2, 3, 5, 6, 6, 7);
}

// The four x-taps of the cubic B-spline for 8 pixels from x = 2m (composite.cpp's i[0 … 3]):
// even x = 2(m + q) has i0 = m + q − 1, odd x = 2(m + q) + 1 has i0 = m + q, and tap k reads
// texel i0 − 1 + k, so with X = P[m − 2 … m + 5] tap k is X[k + (0 1 1 2 2 3 3 4)].
__attribute__((always_inline)) inline void taps4(const float* P, int m, int w, bool inner, V8* t) {
  V8 x;
  if (inner) {
    x = load8(P + m - 2);
  } else {
    float tmp[8];
    for (int k = 0; k < 8; ++k) tmp[k] = P[clampi(m - 2 + k, 0, w - 1)];
    x = load8(tmp);
  }
  t[0] = __builtin_shufflevector(x, x, 0, 1, 1, 2, 2, 3, 3, 4);
  t[1] = __builtin_shufflevector(x, x, 1, 2, 2, 3, 3, 4, 4, 5);
  t[2] = __builtin_shufflevector(x, x, 2, 3, 3, 4, 4, 5, 5, 6);
  t[3] = __builtin_shufflevector(x, x, 3, 4, 4, 5, 5, 6, 6, 7);
}

struct Pair {
  const float* P[2][kPlanes];  // half-res rows j1 (b = 0) and j2 (b = 1) of every plane
  int w = 0;
  int nrows = 0;           // full-res rows of this pair (1 at the top/bottom border)
  const float* col[2][4];  // colour rows, from the chunk start
  float* out[2][4];
  const float* fq[2];  // far(q) rows, from the chunk start
  float by[2][2];      // y-weights [row][b]
  V8 wxy[2][2][2];     // bilinear weights [row][b][a] = x-weight a · y-weight b (composite.cpp
                       // X.b[a] · Y.b[b]), lanes alternating even / odd x
  // near_upsample=bicubic: half-res rows i[0 … 3] (composite.cpp) of near_fill ×4 and
  // near_blur, and the cubic weights [row][b][a] = x-weight a · y-weight b (X.c[a] · Y.c[b]).
  const float* Q[4][5];
  V8 wc[2][4][4];
  float blend = 1;
  // per_pixel_scale: the far blend is blend · min(1, far(q) · radius_per_far / 2) (composite.cpp).
  bool per_pixel = false;
  float radius_per_far = 0;
  bool far = false, near = false;  // parts some pixel of the chunk needs
};

// 8 pixels (n valid) from chunk offset i, full-res x = xa + i (even), both rows. Per row and
// lane the operations and their order are composite.cpp's.
template <int kRows, bool kCubic>
__attribute__((always_inline)) inline void group(const Pair& R, int xa, int i, int n) {
  const int m = (xa + i) >> 1;
  const bool inner = m >= 1 && m + 4 <= R.w - 1;   // the six texels of taps() need no clamp
  const bool inner4 = m >= 2 && m + 5 <= R.w - 1;  // nor the eight of taps4()
  const V8 zero = splat(0.0f);
  constexpr int nr = kRows;
  V8 fq[2];
  for (int r = 0; r < nr; ++r) {
    if (n == 8) {
      fq[r] = load8(R.fq[r] + i);
    } else {  // tail: through a zero-padded copy
      float tmp[8] = {};
      std::copy(R.fq[r] + i, R.fq[r] + i + n, tmp);
      fq[r] = load8(tmp);
    }
  }
  // Far weights (CoC-bilateral bilinear) and blend masks, shared by the four channels.
  bool far_here = false;
  if (R.far)
    for (int r = 0; r < nr; ++r) far_here = far_here || any(fq[r] > zero);
  V8 wf[2][2][2];  // [b][row][a]
  V8 wsum[2] = {zero, zero}, tf[2];
  I8 far_on[2];
  if (far_here) {
    for (int b = 0; b < 2; ++b) {
      V8 fk[2];
      taps(R.P[b][4], m, R.w, inner, fk[0], fk[1]);
      for (int r = 0; r < nr; ++r)
        for (int a = 0; a < 2; ++a) {
          const V8 wraw = R.wxy[r][b][a] / (vabs(fq[r] - fk[a]) + splat(0.001f));
          wf[b][r][a] = fk[a] > zero ? wraw : zero;
          wsum[r] += wf[b][r][a];
        }
    }
    for (int r = 0; r < nr; ++r) {
      if (R.per_pixel) {  // std::min(1.0f, v) = v < 1 ? v : 1
        const V8 one = splat(1.0f), v = fq[r] * splat(R.radius_per_far) / splat(2.0f);
        tf[r] = splat(R.blend) * (v < one ? v : one);
      } else {
        tf[r] = splat(R.blend) * fq[r];
      }
      far_on[r] = (fq[r] > zero) & (wsum[r] > zero);
    }
  }
  // Near: bilinear (or cubic) dilated CoC → blend factor; skipped where all the footprint's
  // CoCs are 0.
  bool near_here = false;
  V8 nb[2] = {zero, zero}, tn[2];
  I8 near_on[2];
  if (R.near && kCubic) {  // 4 × 4 footprint
    V8 nbk[4][4];          // [b][a]
    I8 some = splat_i(0);
    for (int b = 0; b < 4; ++b) {
      taps4(R.Q[b][4], m, R.w, inner4, nbk[b]);
      for (int a = 0; a < 4; ++a) some |= nbk[b][a] > zero;
    }
    near_here = any(some);
    if (near_here)
      for (int b = 0; b < 4; ++b)
        for (int r = 0; r < nr; ++r)
          for (int a = 0; a < 4; ++a) nb[r] += R.wc[r][b][a] * nbk[b][a];
  } else if (R.near) {  // 2 × 2
    V8 nbk[2][2];       // [b][a]
    I8 some = splat_i(0);
    for (int b = 0; b < 2; ++b) {
      taps(R.P[b][9], m, R.w, inner, nbk[b][0], nbk[b][1]);
      some |= (nbk[b][0] > zero) | (nbk[b][1] > zero);
    }
    near_here = any(some);
    if (near_here)
      for (int b = 0; b < 2; ++b)
        for (int r = 0; r < nr; ++r)
          for (int a = 0; a < 2; ++a) nb[r] += R.wxy[r][b][a] * nbk[b][a];
  }
  if (near_here) {
    const V8 one = splat(1.0f);
    for (int r = 0; r < nr; ++r) {
      tn[r] = splat(R.blend) * (one < nb[r] ? one : nb[r]);  // std::min(nb, 1)
      near_on[r] = tn[r] > zero;
    }
  }
  // Per channel: colour, far blend, near blend, store (few live vectors: no spills).
  V8 colv[4][2];
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < nr; ++r) {
      if (n == 8) {
        colv[c][r] = load8(R.col[r][c] + i);
      } else {
        float tmp[8] = {};
        std::copy(R.col[r][c] + i, R.col[r][c] + i + n, tmp);
        colv[c][r] = load8(tmp);
      }
    }
  for (int c = 0; c < 4; ++c) {
    V8 res[2] = {colv[c][0], colv[c][1]};
    if (far_here) {
      V8 acc[2] = {zero, zero};
      for (int b = 0; b < 2; ++b) {
        V8 t[2];
        taps(R.P[b][c], m, R.w, inner, t[0], t[1]);
        for (int r = 0; r < nr; ++r)
          for (int a = 0; a < 2; ++a) acc[r] += wf[b][r][a] * t[a];
      }
      for (int r = 0; r < nr; ++r) res[r] = far_on[r] ? res[r] + (acc[r] / wsum[r] - res[r]) * tf[r] : res[r];
    }
    if (near_here) {
      V8 nf[2] = {zero, zero};
      if constexpr (kCubic) {
        for (int b = 0; b < 4; ++b) {
          V8 t[4];
          taps4(R.Q[b][c], m, R.w, inner4, t);
          for (int r = 0; r < nr; ++r)
            for (int a = 0; a < 4; ++a) nf[r] += R.wc[r][b][a] * t[a];
        }
      } else {
        for (int b = 0; b < 2; ++b) {
          V8 t[2];
          taps(R.P[b][5 + c], m, R.w, inner, t[0], t[1]);
          for (int r = 0; r < nr; ++r)
            for (int a = 0; a < 2; ++a) nf[r] += R.wxy[r][b][a] * t[a];
        }
      }
      for (int r = 0; r < nr; ++r) res[r] = near_on[r] ? res[r] + (nf[r] - res[r]) * tn[r] : res[r];
    }
    for (int r = 0; r < nr; ++r) {
      if (n == 8) {
        store8(R.out[r][c] + i, res[r]);
      } else {
        float o[8];
        store8(o, res[r]);
        std::copy(o, o + n, R.out[r][c] + i);
      }
    }
  }
}

template <int kRows, bool kCubic>
__attribute__((always_inline)) inline void chunk_t(const Pair& R, int xa, int n) {
  for (int i = 0; i < n; i += 8) group<kRows, kCubic>(R, xa, i, std::min(8, n - i));
}

STERNA_SIMD void composite_chunk(const Pair& R, int xa, int n, bool cubic) {
  // (nrows is a loop bound inside group(); two copies make it a constant.)
  if (cubic) {
    if (R.nrows == 2)
      chunk_t<2, true>(R, xa, n);
    else
      chunk_t<1, true>(R, xa, n);
  } else if (R.nrows == 2) {
    chunk_t<2, false>(R, xa, n);
  } else {
    chunk_t<1, false>(R, xa, n);
  }
}

// Output goes straight to the output planes with ordinary stores, copied (in-focus) chunks
// by memcpy. Non-temporal stores (computed chunks through an L1 staging block) pay on AMD
// Zen 3 / Zen 4 cores (an all-copy 1080p frame 8.0 → 6.3 ms CPU), but on Intel cores with a
// 2 MB L2 and a large shared L3 they were the composite's hottest instructions: ordinary
// stores measured ≈ 0.88 of their time there (1 thread, 1080p), and on a Zen 2 core whose
// frame does not fit the L3 the two are even; docs/performance_sterna.md.
std::vector<float>& scratch(int slot, std::size_t n) {
  thread_local std::vector<float> bufs[2];
  if (bufs[slot].size() < n) bufs[slot].resize(n);
  return bufs[slot];
}

}  // namespace

void composite(const MethodContext& ctx, const Settings& s, const BlendRow& blend, const Buffers& b, Image& out) {
  const Image& color = ctx.frame.color;
  const int W = b.W, H = b.H, w = b.w, h = b.h;
  const float cblend = s.composite_blend;
  const int pairs = H / 2 + 1;
  core::parallel_for(
      pairs,
      [&](int p0, int p1) {
        float* fqbuf = scratch(0, 2 * static_cast<std::size_t>(W)).data();
        // P8 rows: slots of 8 filled planes (near ×4, far ×4), each holding one half-res row;
        // pair p needs rows p − 1 and p (bicubic near: p − 2 … p + 1), so consecutive pairs
        // compute one new row each. Slots start empty in every task (rows from another task or
        // frame are never reused).
        const bool cubic = s.bicubic_near;
        const int nslots = cubic ? 4 : 2;
        const std::size_t wpad = (static_cast<std::size_t>(w) + 15) / 16 * 16;
        float* fillbuf = scratch(1, 32 * wpad).data();
        int slot_row[4] = {-1, -1, -1, -1};
        auto slot_plane = [&](int slot, int k) { return fillbuf + (static_cast<std::size_t>(slot) * 8 + k) * wpad; };
        // slot[k] ← the slot holding rows[k] (n rows, possibly repeated at the borders); rows not
        // held yet are filled into slots no row of the list holds.
        auto fill_slots = [&](const int* rows, int n, int* slot) {
          bool keep[4] = {};
          for (int k = 0; k < n; ++k) {
            slot[k] = -1;
            for (int sl = 0; sl < nslots; ++sl)
              if (slot_row[sl] == rows[k]) slot[k] = sl, keep[sl] = true;
          }
          for (int k = 0; k < n; ++k) {
            for (int q = 0; q < k && slot[k] < 0; ++q)
              if (rows[q] == rows[k]) slot[k] = slot[q];
            if (slot[k] >= 0) continue;
            int sl = 0;
            while (keep[sl]) ++sl;  // (n ≤ nslots distinct rows: one is free)
            float* near_out[4];
            float* far_out[4];
            for (int c = 0; c < 4; ++c) {
              near_out[c] = slot_plane(sl, c);
              far_out[c] = slot_plane(sl, 4 + c);
            }
            fill_rows(s, b, rows[k], near_out, far_out);
            slot_row[sl] = rows[k];
            keep[sl] = true;
            slot[k] = sl;
          }
        };
        for (int p = p0; p < p1; ++p) {
          // Half-res rows: j = (p − 1, p) for the far field and the bilinear near field,
          // jq = (p − 2 … p + 1) for the cubic near field (composite.cpp's i[0 … 3]), clamped.
          const int jq[4] = {clampi(p - 2, 0, h - 1), clampi(p - 1, 0, h - 1), clampi(p, 0, h - 1),
                             clampi(p + 1, 0, h - 1)};
          const int* j = jq + 1;
          int slots[4];
          fill_slots(cubic ? jq : j, nslots, slots);
          const int* slot = cubic ? slots + 1 : slots;
          int ys[2], nrows = 0;
          if (2 * p - 1 >= 0) ys[nrows++] = 2 * p - 1;
          if (2 * p <= H - 1) ys[nrows++] = 2 * p;
          for (int r = 0; r < nrows; ++r) blend(ys[r], nullptr, fqbuf + static_cast<std::size_t>(r) * W);
          Pair R;
          R.w = w;
          R.nrows = nrows;
          R.blend = cblend;
          R.per_pixel = s.per_pixel_scale;
          R.radius_per_far = 2.0f * kOuterRadius * s.kernel_scale;  // composite.cpp: full-res px at far = 1
          for (int bb = 0; bb < 2; ++bb) {
            for (int c = 0; c < 4; ++c) {
              R.P[bb][c] = slot_plane(slot[bb], 4 + c);
              R.P[bb][5 + c] = slot_plane(slot[bb], c);
            }
            R.P[bb][4] = b.far_h_row(j[bb]);
            R.P[bb][9] = b.near_blur->row(0, j[bb]);
          }
          if (cubic)
            for (int bb = 0; bb < 4; ++bb) {
              for (int c = 0; c < 4; ++c) R.Q[bb][c] = slot_plane(slots[bb], c);
              R.Q[bb][4] = b.near_blur->row(0, jq[bb]);
            }
          for (int r = 0; r < nrows; ++r) {
            const float t = (ys[r] % 2 == 0) ? 0.75f : 0.25f;  // composite.cpp axis()
            R.by[r][0] = 1.0f - t;
            R.by[r][1] = t;
            // x-weights (composite.cpp axis()): even x (¼, ¾), odd x (¾, ¼).
            const V8 bx[2] = {V8{0.25f, 0.75f, 0.25f, 0.75f, 0.25f, 0.75f, 0.25f, 0.75f},
                              V8{0.75f, 0.25f, 0.75f, 0.25f, 0.75f, 0.25f, 0.75f, 0.25f}};
            for (int bb = 0; bb < 2; ++bb)
              for (int a = 0; a < 2; ++a) R.wxy[r][bb][a] = bx[a] * splat(R.by[r][bb]);
            if (cubic) {  // composite.cpp's X.c[a] · Y.c[b], lanes alternating even / odd x
              const UpsampleAxis ye = upsample_axis(ys[r], h), xe = upsample_axis(0, w), xo = upsample_axis(1, w);
              for (int a = 0; a < 4; ++a) {
                const V8 cx = {xe.c[a], xo.c[a], xe.c[a], xo.c[a], xe.c[a], xo.c[a], xe.c[a], xo.c[a]};
                for (int bb = 0; bb < 4; ++bb) R.wc[r][bb][a] = cx * splat(ye.c[bb]);
              }
            }
          }
          for (int xa = 0; xa < W; xa += kChunk) {
            const int n = std::min(kChunk, W - xa);
            // The far part where some far(q) > 0 in the chunk, the near part where a near tile
            // lies within one tile of it; neither → copy.
            bool wfar = false, wnear = false;
            for (int r = 0; r < nrows; ++r) {
              const float* fq = fqbuf + static_cast<std::size_t>(r) * W + xa;
              wfar = wfar || core::any_positive(fq, n);  // (vectorised: the scalar scan was ≈ 10 M Ir per frame)
              const int ty = std::min(ys[r] / 2, h - 1) / kTile;
              const int ta = std::max(0, std::min(xa / 2, w - 1) / kTile - 1);
              const int tb = std::min(b.tiles_x - 1, std::min((xa + n - 1) / 2, w - 1) / kTile + 1);
              for (int tj = std::max(ty - 1, 0); tj <= std::min(ty + 1, b.tiles_y - 1) && !wnear; ++tj)
                for (int ti = ta; ti <= tb && !wnear; ++ti)
                  wnear = ((*b.tiles)[static_cast<std::size_t>(tj) * b.tiles_x + ti] & 1) != 0;
            }
            R.far = wfar && cblend > 0.0f;
            R.near = wnear && cblend > 0.0f;
            if (!R.far && !R.near) {
              for (int r = 0; r < nrows; ++r)
                for (int c = 0; c < 4; ++c)
                  std::memcpy(out.row(c, ys[r]) + xa, color.row(c, ys[r]) + xa,
                              static_cast<std::size_t>(n) * sizeof(float));
              continue;
            }
            for (int r = 0; r < nrows; ++r) {
              for (int c = 0; c < 4; ++c) {
                R.col[r][c] = color.row(c, ys[r]) + xa;
                R.out[r][c] = out.row(c, ys[r]) + xa;
              }
              R.fq[r] = fqbuf + static_cast<std::size_t>(r) * W + xa;
            }
            composite_chunk(R, xa, n, cubic);
          }
        }
      },
      4);
}

}  // namespace dofkit::detail::sterna::fast
