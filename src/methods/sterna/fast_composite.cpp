// Fast P9: the composite as a vectorised row loop. Same weights, sums and blends as
// composite.cpp (bilinear near upsampling; bicubic runs the plain pass).
//
// Footprint bookkeeping. Full-res column x reads half-res columns
//   ix1(x) = clamp(⌊(x − 1)/2⌋), ix2(x) = clamp(⌊(x + 1)/2⌋)
// with x-weights (¼, ¾) for even x and (¾, ¼) for odd x (composite.cpp axis()). With the
// "doubled" row E[k] = P[clamp(⌊k/2⌋)] these are E[x − 1] and E[x + 1]: after doubling the
// two half-res rows (per plane, in chunks of kChunk pixels that stay in L1) every tap is a
// contiguous load and 8 pixels are composited at once with vector selects. Full-res rows
// 2p − 1 and 2p read the same two half-res rows and share one doubling. The ifs of composite.cpp become selects: a far tap with far_h = 0 gets
// weight 0 (adding 0·value leaves the sums unchanged — the values are finite), the far blend
// applies where far(q) > 0 and the weight sum is > 0, the near blend where its t > 0. Pixels
// composite.cpp skips as "no near texel nearby" have nearBlur = 0 at all four taps, so t = 0
// and the select keeps them too; chunks with no far pixel and no near tile around are copied.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include "core/parallel.hpp"
#include "methods/sterna/fast.hpp"

namespace dofkit::detail::sterna::fast {

namespace {

constexpr int kChunk = 256;  // full-res pixels per chunk (even)
constexpr int kPlanes = 10;  // far_fill ×4, far_h, near_fill ×4, near_blur
constexpr int kEPitch = kChunk + 16;  // ≥ chunk + 2 taps + a vector of slack

// E[k − k0] = P[clamp(⌊k/2⌋, 0, w − 1)] for k in [k0, k0 + n).
STERNA_SIMD void double_row(const float* __restrict P, int w, int k0, int n, float* __restrict E) {
  int k = k0;
  const int k1 = k0 + n;
  for (; k < k1 && (k < 0 || (k & 1)); ++k) E[k - k0] = P[clampi(k >> 1, 0, w - 1)];
  // Interior: pairs (2m, 2m + 1) with 0 <= m < w.
  const int m0 = k >> 1;
  const int m1 = std::min(w, k1 >> 1);
  float* e = E + (k - k0);
  for (int m = m0; m < m1; ++m) {
    e[2 * (m - m0)] = P[m];
    e[2 * (m - m0) + 1] = P[m];
  }
  if (m1 > m0) k = 2 * m1;
  for (; k < k1; ++k) E[k - k0] = P[clampi(k >> 1, 0, w - 1)];
}

typedef float V8 __attribute__((vector_size(32)));
typedef int I8 __attribute__((vector_size(32)));

__attribute__((always_inline)) inline V8 load8(const float* p) {
  V8 v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
__attribute__((always_inline)) inline void store8(float* p, V8 v) { std::memcpy(p, &v, sizeof v); }
__attribute__((always_inline)) inline V8 splat(float f) { return V8{f, f, f, f, f, f, f, f}; }
__attribute__((always_inline)) inline I8 splat_i(int v) { return I8{v, v, v, v, v, v, v, v}; }
// |v| by clearing the sign bit, exactly what std::abs does to a float.
__attribute__((always_inline)) inline V8 vabs(V8 v) {
  return reinterpret_cast<V8>(reinterpret_cast<I8>(v) & splat_i(0x7fffffff));
}

struct Row {
  // Doubled rows: [b][plane] for the two half-res rows j1 (b = 0) and j2 (b = 1); element
  // i of E holds E[xa − 1 + i], so pixel xa + i taps elements i (a = 0) and i + 2 (a = 1).
  // Each holds kEPitch floats (whole vectors are readable past the chunk).
  const float* E[2][kPlanes];
  const float* col[4];
  float* out[4];
  const float* fq;  // far(q), full-res row from xa
  float by0, by1, blend;
};

// Whether any lane of a comparison mask is set.
__attribute__((always_inline)) inline bool any(I8 m) {
  std::uint64_t q[4];
  std::memcpy(q, &m, sizeof q);
  return (q[0] | q[1] | q[2] | q[3]) != 0;
}

// 8 pixels from xa + i (xa + i even). Same operations and order as composite.cpp per pixel.
// A part whose blend is off in all 8 lanes (no far pixel; all four near taps' CoC 0) leaves
// res = col, as its selects would, and is skipped; the far (near) part is only called with
// far (near) planes doubled.
template <bool kFar, bool kNear>
__attribute__((always_inline)) inline void composite8(const Row& R, int i, const V8* col, V8 fq, V8* res) {
  const V8 by[2] = {splat(R.by0), splat(R.by1)};
  // x-weights (composite.cpp axis()): even x (¼, ¾), odd x (¾, ¼).
  const V8 bx[2] = {V8{0.25f, 0.75f, 0.25f, 0.75f, 0.25f, 0.75f, 0.25f, 0.75f},
                    V8{0.75f, 0.25f, 0.75f, 0.25f, 0.75f, 0.25f, 0.75f, 0.25f}};
  const V8 zero = splat(0.0f);
  for (int c = 0; c < 4; ++c) res[c] = col[c];
  if (kFar && any(fq > zero)) {
  // Far: CoC-bilateral bilinear.
  V8 wsum = zero, acc[4] = {zero, zero, zero, zero};
  for (int b = 0; b < 2; ++b)
    for (int a = 0; a < 2; ++a) {
      const int k = i + 2 * a;
      const V8 fk = load8(R.E[b][4] + k);
      const V8 wraw = bx[a] * by[b] / (vabs(fq - fk) + splat(0.001f));
      const V8 wk = fk > zero ? wraw : zero;
      wsum += wk;
      for (int c = 0; c < 4; ++c) acc[c] += wk * load8(R.E[b][c] + k);
    }
  const V8 tf = splat(R.blend) * fq;
  const I8 far_on = (fq > zero) & (wsum > zero);
  for (int c = 0; c < 4; ++c) res[c] = far_on ? res[c] + (acc[c] / wsum - res[c]) * tf : res[c];
  }
  if (!kNear) return;
  // Near: bilinear field and dilated CoC.
  V8 nbk[2][2];
  I8 some = I8{0, 0, 0, 0, 0, 0, 0, 0};
  for (int b = 0; b < 2; ++b)
    for (int a = 0; a < 2; ++a) {
      nbk[b][a] = load8(R.E[b][9] + i + 2 * a);
      some |= nbk[b][a] > zero;
    }
  if (!any(some)) return;
  V8 nb = zero, nf[4] = {zero, zero, zero, zero};
  for (int b = 0; b < 2; ++b)
    for (int a = 0; a < 2; ++a) {
      const int k = i + 2 * a;
      const V8 wk = bx[a] * by[b];
      nb += wk * nbk[b][a];
      for (int c = 0; c < 4; ++c) nf[c] += wk * load8(R.E[b][5 + c] + k);
    }
  const V8 one = splat(1.0f);
  const V8 tn = splat(R.blend) * (one < nb ? one : nb);  // std::min(nb, 1)
  const I8 near_on = tn > zero;
  for (int c = 0; c < 4; ++c) res[c] = near_on ? res[c] + (nf[c] - res[c]) * tn : res[c];
}

template <bool kFar, bool kNear>
__attribute__((always_inline)) inline void composite_chunk_t(const Row& R, int n) {
  V8 col[4], res[4];
  int i = 0;
  for (; i + 8 <= n; i += 8) {
    for (int c = 0; c < 4; ++c) col[c] = load8(R.col[c] + i);
    composite8<kFar, kNear>(R, i, col, load8(R.fq + i), res);
    for (int c = 0; c < 4; ++c) store8(R.out[c] + i, res[c]);
  }
  if (i < n) {  // tail: through a zero-padded copy
    float tmp[4][8] = {}, fqt[8] = {}, o[8];
    for (int c = 0; c < 4; ++c) std::copy(R.col[c] + i, R.col[c] + n, tmp[c]);
    std::copy(R.fq + i, R.fq + n, fqt);
    for (int c = 0; c < 4; ++c) col[c] = load8(tmp[c]);
    composite8<kFar, kNear>(R, i, col, load8(fqt), res);
    for (int c = 0; c < 4; ++c) {
      store8(o, res[c]);
      std::copy(o, o + (n - i), R.out[c] + i);
    }
  }
}

STERNA_SIMD void composite_chunk(const Row& R, int n, bool far, bool near) {
  if (far && near)
    composite_chunk_t<true, true>(R, n);
  else if (far)
    composite_chunk_t<true, false>(R, n);
  else
    composite_chunk_t<false, true>(R, n);
}

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
  // Full-res rows 2p − 1 and 2p both read half-res rows (p − 1, p) (composite.cpp axis():
  // i0 = p − 1 for both), with y-weights (¾, ¼) and (¼, ¾): they are done together so each
  // pair of half-res rows is doubled once.
  const int pairs = H / 2 + 1;
  core::parallel_for(pairs, [&](int p0, int p1) {
    float* fqbuf = scratch(0, 2 * static_cast<std::size_t>(W)).data();
    float* ebuf = scratch(1, static_cast<std::size_t>(2) * kPlanes * kEPitch).data();
    for (int p = p0; p < p1; ++p) {
      const int j[2] = {clampi(p - 1, 0, h - 1), clampi(p, 0, h - 1)};
      int ys[2], nrows = 0;
      if (2 * p - 1 >= 0) ys[nrows++] = 2 * p - 1;
      if (2 * p <= H - 1) ys[nrows++] = 2 * p;
      for (int r = 0; r < nrows; ++r) blend(ys[r], nullptr, fqbuf + static_cast<std::size_t>(r) * W);
      for (int xa = 0; xa < W; xa += kChunk) {
        const int n = std::min(kChunk, W - xa);
        // Per row: the far part where some far(q) > 0 in the chunk, the near part where a near
        // tile lies within one tile; neither → copy.
        bool wfar[2] = {false, false}, wnear[2] = {false, false}, work[2] = {false, false};
        for (int r = 0; r < nrows; ++r) {
          const float* fq = fqbuf + static_cast<std::size_t>(r) * W + xa;
          for (int i = 0; i < n && !wfar[r]; ++i) wfar[r] = fq[i] > 0.0f;
          const int ty = std::min(ys[r] / 2, h - 1) / kTile;
          const int ta = std::max(0, std::min(xa / 2, w - 1) / kTile - 1);
          const int tb = std::min(b.tiles_x - 1, std::min((xa + n - 1) / 2, w - 1) / kTile + 1);
          for (int tj = std::max(ty - 1, 0); tj <= std::min(ty + 1, b.tiles_y - 1) && !wnear[r]; ++tj)
            for (int ti = ta; ti <= tb && !wnear[r]; ++ti)
              wnear[r] = ((*b.tiles)[static_cast<std::size_t>(tj) * b.tiles_x + ti] & 1) != 0;
          wfar[r] = wfar[r] && cblend > 0.0f;
          wnear[r] = wnear[r] && cblend > 0.0f;
          work[r] = wfar[r] || wnear[r];
        }
        Row R;
        R.blend = cblend;
        const bool dfar = wfar[0] || wfar[1], dnear = wnear[0] || wnear[1];
        if (dfar || dnear)
          for (int bb = 0; bb < 2; ++bb) {
            const float* planes[kPlanes] = {b.far_fill->row(0, j[bb]),  b.far_fill->row(1, j[bb]),
                                            b.far_fill->row(2, j[bb]),  b.far_fill->row(3, j[bb]),
                                            b.far_h_row(j[bb]),         b.near_fill->row(0, j[bb]),
                                            b.near_fill->row(1, j[bb]), b.near_fill->row(2, j[bb]),
                                            b.near_fill->row(3, j[bb]), b.near_blur->row(0, j[bb])};
            for (int q = dfar ? 0 : 5; q < (dnear ? kPlanes : 5); ++q) {
              float* E = ebuf + (static_cast<std::size_t>(bb) * kPlanes + q) * kEPitch;
              double_row(planes[q], w, xa - 1, n + 2, E);
              R.E[bb][q] = E;
            }
          }
        for (int r = 0; r < nrows; ++r) {
          const int y = ys[r];
          if (!work[r]) {
            for (int c = 0; c < 4; ++c) std::copy(color.row(c, y) + xa, color.row(c, y) + xa + n, out.row(c, y) + xa);
            continue;
          }
          const float t = (y % 2 == 0) ? 0.75f : 0.25f;  // composite.cpp axis()
          R.by0 = 1.0f - t;
          R.by1 = t;
          for (int c = 0; c < 4; ++c) {
            R.col[c] = color.row(c, y) + xa;
            R.out[c] = out.row(c, y) + xa;
          }
          R.fq = fqbuf + static_cast<std::size_t>(r) * W + xa;
          composite_chunk(R, n, wfar[r], wnear[r]);
        }
      }
    }
  }, 4);
}

}  // namespace dofkit::detail::sterna::fast
