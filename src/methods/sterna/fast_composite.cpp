// Fast P9: the composite as a vectorised row loop. Same weights, sums and blends as
// composite.cpp (bilinear near upsampling; bicubic runs the plain pass).
//
// Footprint bookkeeping. Full-res column x reads half-res columns
//   ix1(x) = clamp(⌊(x − 1)/2⌋), ix2(x) = clamp(⌊(x + 1)/2⌋)
// with x-weights (¼, ¾) for even x and (¾, ¼) for odd x (composite.cpp axis()). With the
// "doubled" row E[k] = P[clamp(⌊k/2⌋)] these are E[x − 1] and E[x + 1]: after doubling the
// two half-res rows of a full-res row (per plane, in chunks of kChunk pixels that stay in L1)
// every tap is a contiguous load and the per-pixel loop has no index arithmetic, no branch
// and vectorises. The ifs of composite.cpp become selects: a far tap with far_h = 0 gets
// weight 0 (adding 0·value leaves the sums unchanged — the values are finite), the far blend
// applies where far(q) > 0 and the weight sum is > 0, the near blend where its t > 0. Pixels
// composite.cpp skips as "no near texel nearby" have nearBlur = 0 at all four taps, so t = 0
// and the select keeps them too; chunks with no far pixel and no near tile around are copied.
#include <algorithm>
#include <cmath>
#include <vector>

#include "core/parallel.hpp"
#include "methods/sterna/fast.hpp"

namespace dofkit::detail::sterna::fast {

namespace {

constexpr int kChunk = 256;  // full-res pixels per chunk (even)
constexpr int kPlanes = 10;  // far_fill ×4, far_h, near_fill ×4, near_blur
constexpr int kEPitch = kChunk + 4;

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

struct Row {
  // Doubled rows: [b][plane] for the two half-res rows j1 (b = 0) and j2 (b = 1); element
  // e = x − xa + 1 holds E[x]; taps are e − 1 (a = 0) and e + 1 (a = 1).
  const float* E[2][kPlanes];
  const float* col[4];
  float* out[4];
  const float* fq;  // far(q), full-res row
  float by0, by1, blend;
};

STERNA_SIMD void composite_chunk(const Row& R, int xa, int n) {
  const float by[2] = {R.by0, R.by1};
  for (int i = 0; i < n; ++i) {
    const int x = xa + i;
    const int e = i + 1;
    const float bx[2] = {(x & 1) ? 0.75f : 0.25f, (x & 1) ? 0.25f : 0.75f};
    const float fq = R.fq[i];
    float res[4];
    for (int c = 0; c < 4; ++c) res[c] = R.col[c][i];
    // Far: CoC-bilateral bilinear.
    float wsum = 0.0f, acc[4] = {0, 0, 0, 0};
    for (int b = 0; b < 2; ++b)
      for (int a = 0; a < 2; ++a) {
        const int k = e - 1 + 2 * a;
        const float fk = R.E[b][4][k];
        const float wraw = bx[a] * by[b] / (std::abs(fq - fk) + 0.001f);
        const float wk = fk > 0.0f ? wraw : 0.0f;
        wsum += wk;
        for (int c = 0; c < 4; ++c) acc[c] += wk * R.E[b][c][k];
      }
    const float tf = R.blend * fq;
    const bool far_on = fq > 0.0f && wsum > 0.0f;
    for (int c = 0; c < 4; ++c) {
      const float blended = res[c] + (acc[c] / wsum - res[c]) * tf;
      res[c] = far_on ? blended : res[c];
    }
    // Near: bilinear field and dilated CoC.
    float nb = 0.0f, nf[4] = {0, 0, 0, 0};
    for (int b = 0; b < 2; ++b)
      for (int a = 0; a < 2; ++a) {
        const int k = e - 1 + 2 * a;
        const float wk = bx[a] * by[b];
        nb += wk * R.E[b][9][k];
        for (int c = 0; c < 4; ++c) nf[c] += wk * R.E[b][5 + c][k];
      }
    const float tn = R.blend * std::min(nb, 1.0f);
    for (int c = 0; c < 4; ++c) {
      const float blended = res[c] + (nf[c] - res[c]) * tn;
      R.out[c][i] = tn > 0.0f ? blended : res[c];
    }
  }
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
  core::parallel_for(H, [&](int y0, int y1) {
    float* fq = scratch(0, W).data();
    float* ebuf = scratch(1, static_cast<std::size_t>(2) * kPlanes * kEPitch).data();
    for (int y = y0; y < y1; ++y) {
      // composite.cpp axis(): rows i[1], i[2] with weights (¼, ¾) / (¾, ¼).
      const int i0 = (y % 2 == 0) ? y / 2 - 1 : y / 2;
      const float t = (y % 2 == 0) ? 0.75f : 0.25f;
      const int j[2] = {clampi(i0, 0, h - 1), clampi(i0 + 1, 0, h - 1)};
      blend(y, nullptr, fq);
      const int ty = std::min(y / 2, h - 1) / kTile;
      Row R;
      R.by0 = 1.0f - t;
      R.by1 = t;
      R.blend = cblend;
      for (int xa = 0; xa < W; xa += kChunk) {
        const int n = std::min(kChunk, W - xa);
        // Early-out: no far pixel in the chunk and no near tile within one tile of it.
        bool work = false;
        for (int i = 0; i < n && !work; ++i) work = fq[xa + i] > 0.0f;
        if (!work) {
          const int ta = std::max(0, std::min(xa / 2, w - 1) / kTile - 1);
          const int tb = std::min(b.tiles_x - 1, std::min((xa + n - 1) / 2, w - 1) / kTile + 1);
          for (int tj = std::max(ty - 1, 0); tj <= std::min(ty + 1, b.tiles_y - 1) && !work; ++tj)
            for (int ti = ta; ti <= tb && !work; ++ti)
              work = ((*b.tiles)[static_cast<std::size_t>(tj) * b.tiles_x + ti] & 1) != 0;
        }
        if (!work || cblend <= 0.0f) {
          for (int c = 0; c < 4; ++c) std::copy(color.row(c, y) + xa, color.row(c, y) + xa + n, out.row(c, y) + xa);
          continue;
        }
        for (int bb = 0; bb < 2; ++bb) {
          const float* planes[kPlanes] = {b.far_fill->row(0, j[bb]), b.far_fill->row(1, j[bb]),
                                          b.far_fill->row(2, j[bb]), b.far_fill->row(3, j[bb]),
                                          b.far_h_row(j[bb]),        b.near_fill->row(0, j[bb]),
                                          b.near_fill->row(1, j[bb]), b.near_fill->row(2, j[bb]),
                                          b.near_fill->row(3, j[bb]), b.near_blur->row(0, j[bb])};
          for (int p = 0; p < kPlanes; ++p) {
            float* E = ebuf + (static_cast<std::size_t>(bb) * kPlanes + p) * kEPitch;
            double_row(planes[p], w, xa - 1, n + 2, E);
            R.E[bb][p] = E;
          }
        }
        for (int c = 0; c < 4; ++c) {
          R.col[c] = color.row(c, y) + xa;
          R.out[c] = out.row(c, y) + xa;
        }
        R.fq = fq + xa;
        composite_chunk(R, xa, n);
      }
    }
  }, 8);
}

}  // namespace dofkit::detail::sterna::fast
