// C5 — the final pass, per full-resolution pixel (chapter Listing 2, docs/methods/starcraft.md):
//  1. own level c_own (C1, full resolution — the quarter-res one would not match the pixel);
//  2. depth test (rule 3): if the blurred neighbourhood lies behind the pixel (blurred 1/z
//     <= own 1/z) keep c_own, otherwise take the blurred CoC (rule 2), so blurry foreground
//     spreads over its surroundings but blurry background never spreads over foreground;
//  3. small level from four bilinear taps at (0.5,−1.5), (−1.5,−0.5), (−0.5,1.5), (1.5,0.5)
//     px, 4/17 each. Each tap lies on a pixel corner, so it is the mean of a 2×2 block and the
//     four taps cover 16 pixels in a pinwheel around the centre, each with weight 1/17;
//  4. level weights (source, small, medium, large) from c;
//  5. rgba = y'·small + z'·medium + w·large, alpha = (16/17)·y' + z' + w, blended over the
//     source as out = rgba + (1 − alpha)·source: the source term carries both the source
//     level and the small blur's missing centre tap (1/17 of y').
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <vector>

#include "core/clones.hpp"
#include "core/parallel.hpp"
#include "core/weighted_gaussian.hpp"
#include "methods/starcraft/final_simd.hpp"
#include "methods/starcraft/starcraft.hpp"

namespace dofkit::detail::starcraft {

namespace {

inline int clampi(int v, int lo, int hi) { return v < lo ? lo : (v > hi ? hi : v); }

/// Bilinear footprint of a full-res pixel centre on the quarter-res grid.
struct Bilerp {
  std::size_t i00, i01, i10, i11;
  float w00, w01, w10, w11;
  float at(const float* p) const { return w00 * p[i00] + w01 * p[i01] + w10 * p[i10] + w11 * p[i11]; }
};

Bilerp quarter_bilerp(int x, int y, int lw, int lh) {
  const float fx = (x + 0.5f) / kDown - 0.5f, fy = (y + 0.5f) / kDown - 0.5f;
  const float x0f = std::floor(fx), y0f = std::floor(fy);
  const float tx = fx - x0f, ty = fy - y0f;
  const int x0 = static_cast<int>(x0f), y0 = static_cast<int>(y0f);
  const std::size_t xa = clampi(x0, 0, lw - 1), xb = clampi(x0 + 1, 0, lw - 1);
  const std::size_t ya = clampi(y0, 0, lh - 1), yb = clampi(y0 + 1, 0, lh - 1);
  return {ya * lw + xa,        ya * lw + xb,  yb * lw + xa,  yb * lw + xb,
          (1 - tx) * (1 - ty), tx * (1 - ty), (1 - tx) * ty, tx * ty};
}

// Top-left pixel of the 2×2 block each small tap averages (tap offset − (0.5, 0.5), floored).
constexpr int kTapBlock[4][2] = {{0, -2}, {-2, -1}, {-1, 1}, {1, 0}};

}  // namespace

void final_pass_plain(const Image& color, const Image& depth, const Image& level, const Image& medium,
                      const Image& large, const Image& inv_depth, bool keep_own_blur, Image& out,
                      const FinalDebug& dbg) {
  const int w = color.width(), h = color.height();
  const int lw = large.width(), lh = large.height();
  out.resize(w, h, 4);
  if (dbg.used_level) dbg.used_level->resize(w, h, 1);
  if (dbg.small) dbg.small->resize(w, h, 4);
  if (dbg.weights) dbg.weights->resize(w, h, 4);
  const float* lnum[4] = {large.plane(0), large.plane(1), large.plane(2), large.plane(3)};
  const float* lden = large.plane(4);
  const float* lz = inv_depth.plane(0);
  constexpr float kTiny = 1e-6f;
  constexpr float kTieTolerance = 1e-5f;

  core::parallel_for(
      h,
      [&](int y0, int y1) {
        for (int y = y0; y < y1; ++y) {
          const float* cown = level.row(0, y);
          const float* z = depth.row(0, y);
          for (int x = 0; x < w; ++x) {
            const Bilerp b = quarter_bilerp(x, y, lw, lh);
            const float inv_own = 1.0f / z[x];
            const float inv_blur = b.at(lz);
            const float c_blur = b.at(lden);
            float c = inv_blur <= inv_own * (1.0f + kTieTolerance) ? cown[x] : c_blur;
            if (keep_own_blur) c = std::max(c, cown[x]);
            const LevelWeights lwt = level_weights(c);
            const float alpha = (16.0f / 17.0f) * lwt.small + lwt.medium + lwt.large;
            if (dbg.used_level) dbg.used_level->row(0, y)[x] = c;
            if (dbg.weights) {
              dbg.weights->row(0, y)[x] = lwt.source;
              dbg.weights->row(1, y)[x] = lwt.small;
              dbg.weights->row(2, y)[x] = lwt.medium;
              dbg.weights->row(3, y)[x] = lwt.large;
            }
            for (int ch = 0; ch < 4; ++ch) {
              const float src = color.row(ch, y)[x];
              if (alpha == 0.0f && !dbg.small) {  // in focus: the source, bit for bit
                out.row(ch, y)[x] = src;
                continue;
              }
              float small = 0;
              for (const auto& t : kTapBlock) {
                const int xa = clampi(x + t[0], 0, w - 1), xb = clampi(x + t[0] + 1, 0, w - 1);
                const float* ra = color.row(ch, clampi(y + t[1], 0, h - 1));
                const float* rb = color.row(ch, clampi(y + t[1] + 1, 0, h - 1));
                small += ra[xa] + ra[xb] + rb[xa] + rb[xb];
              }
              small *= 1.0f / 17.0f;  // 4/17 per tap × mean of 4 pixels
              const float med = medium.row(ch, y)[x];
              const float lg = c_blur > kTiny ? b.at(lnum[ch]) / c_blur : med;
              const float mixed = lwt.small * small + lwt.medium * med + lwt.large * lg;
              out.row(ch, y)[x] = alpha == 0.0f ? src : mixed + (1.0f - alpha) * src;
              if (dbg.small) dbg.small->row(ch, y)[x] = small + src / 17.0f;
            }
          }
        }
      },
      8);
}

// The same pass organised by rows for speed (the plain version above is its test oracle):
// the quarter-res planes are interpolated vertically once per row and horizontally into
// full-width rows, the per-pixel level decision is made once for all channels, and the
// small blur reads the five source rows around y in place. The interior of each row runs in
// the Highway kernels of final_simd.cpp (run-time dispatch: AVX-512, AVX2, SSE4, ...); the
// two columns at each border, where the small blur's taps are clamped, and the tails use the
// scalar form below, which has the same arithmetic.
namespace {

/// v[i] = a[i] + (b[i] − a[i]) · t (the vertical quarter-res lerp of final_row), in clones
/// for wider vectors than the baseline's; multiply and add stay separate (no FMA in these
/// targets), so the values are the baseline's.
DOFKIT_CLONES
void vertical_lerp(const float* __restrict a, const float* __restrict b, float* __restrict v, int n, float t) {
  for (int i = 0; i < n; ++i) v[i] = a[i] + (b[i] - a[i]) * t;
}

/// 2×2 block sums of one source row pair: b[x] = ((r0[x] + r0[x+1]) + r1[x]) + r1[x+1] for
/// x < n, the small blur's block sum in the plain pass's order (so the values are the same).
DOFKIT_CLONES
void block_sums(const float* __restrict r0, const float* __restrict r1, float* __restrict b, int n) {
  for (int x = 0; x < n; ++x) b[x] = ((r0[x] + r0[x + 1]) + r1[x]) + r1[x + 1];
}

struct RowScratch {
  std::vector<float> vrow, hrow, ws, wm, wl, wsrc;
  std::vector<float> exact;  // the medium rows (4) and weight row with exact sums (MediumExact)
  // The small blur's 2×2 block sums of the source row pairs (j, j + 1), kept for the four
  // output rows that read them: slot (channel, j mod 4), tagged with the pass and j.
  std::vector<float> blocks;
  std::uint64_t block_pass[4][4] = {};
  int block_row[4][4] = {};
};

struct FinalGeometry {
  int w, h, lw, lh;
};

/// Scalar weights of pixel x (same operations as FinalWeights).
inline bool weights_scalar(const WeightRow& r, int x) {
  constexpr float kTieTolerance = 1e-5f;
  float c = r.inv_blur[x] <= (1.0f / r.z[x]) * (1.0f + kTieTolerance) ? r.cown[x] : r.cb[x];
  if (r.keep_own_blur) c = std::max(c, r.cown[x]);
  const LevelWeights lwt = level_weights(c);
  r.ws[x] = lwt.small;
  r.wm[x] = lwt.medium;
  r.wl[x] = lwt.large;
  const float alpha = (16.0f / 17.0f) * lwt.small + lwt.medium + lwt.large;
  r.wsrc[x] = 1.0f - alpha;
  if (r.alpha_out) {  // mix_scalar's alpha on an opaque frame (see FinalWeights)
    const float wsrc = r.wsrc[x];
    r.alpha_out[x] = wsrc == 1.0f ? 1.0f : lwt.small * (16.0f * (1.0f / 17.0f)) + lwt.medium + lwt.large + wsrc;
  }
  return alpha != 0.0f;
}

/// Scalar mix of pixel x, the small blur's columns clamped to [0, w − 1].
inline void mix_scalar(const MixRow& r, int x, int w) {
  constexpr float kTiny = 1e-6f;
  if (r.wsrc[x] == 1.0f) {
    r.out[x] = r.src[x];
    return;
  }
  auto at = [&](int k, int dx) { return r.rows[k][clampi(x + dx, 0, w - 1)]; };
  const float small = ((at(0, 0) + at(0, 1) + at(1, 0) + at(1, 1)) + (at(1, -2) + at(1, -1) + at(2, -2) + at(2, -1)) +
                       (at(3, -1) + at(3, 0) + at(4, -1) + at(4, 0)) + (at(2, 1) + at(2, 2) + at(3, 1) + at(3, 2))) *
                      (1.0f / 17.0f);
  const float med = r.mwt ? (r.mwt[x] > kTiny ? r.med[x] / r.mwt[x] : r.src[x]) : r.med[x];
  const float lg = r.cb[x] > kTiny ? r.num[x] / r.cb[x] : med;
  r.out[x] = r.ws[x] * small + r.wm[x] * med + r.wl[x] * lg + r.wsrc[x] * r.src[x];
}

/// Where the row mixes the medium level (wm > 0) at a weight below kExactMediumBelow, the
/// medium sums and weight with core::weighted_gaussian_at's exact ones: med and med_wt are
/// pointed at copies of the rows in sc.exact (only if some pixel needs it; the rest of the
/// row keeps the fast sums bit for bit). med[3] may be med_wt itself (alpha left out).
/// Whether some pixel of the row mixes the medium level in at a weight below
/// kExactMediumBelow: a branch-free reduction (vectorises), so a row without one costs a
/// compare pair per pixel.
DOFKIT_CLONES
bool any_small_weight(const float* __restrict wm, const float* __restrict wt, int n) {
  int any = 0;
  for (int x = 0; x < n; ++x) any |= (wm[x] > 0.0f) & (wt[x] < kExactMediumBelow);
  return any != 0;
}

void exact_medium(const MediumExact& e, const float* wm, int y, RowScratch& sc, const float* med[4],
                  const float*& med_wt) {
  const int w = e.w;
  if (!any_small_weight(wm, med_wt, w)) return;
  float* rows[5] = {};  // the copies: medium planes 0-3, weight (null until a pixel needs them)
  for (int x = 0; x < w; ++x) {
    if (!(wm[x] > 0.0f) || !(med_wt[x] < kExactMediumBelow)) continue;
    if (!rows[4]) {
      sc.exact.resize(static_cast<std::size_t>(5) * w);
      for (int k = 0; k < 5; ++k) rows[k] = sc.exact.data() + static_cast<std::size_t>(k) * w;
      std::copy(med_wt, med_wt + w, rows[4]);
      for (int ch = 0; ch < 4; ++ch) {
        if (med[ch] == med_wt)
          rows[ch] = rows[4];
        else
          std::copy(med[ch], med[ch] + w, rows[ch]);
        med[ch] = rows[ch];
      }
      med_wt = rows[4];
    }
    double sums[5];
    core::weighted_gaussian_at(e.src, e.nplanes, e.c, e.w, e.h, e.sigma, e.boxes, x, y, sums);
    for (int k = 0; k < e.nplanes; ++k) rows[k][x] = static_cast<float>(sums[k]);
    rows[4][x] = static_cast<float>(sums[e.nplanes]);
  }
}

// final_pass_row's work; opaque: v.opaque where it applies (see FinalPassViews).
void final_row(const FinalPassViews& v, const float* const med_in[4], const float* med_wt, const FinalGeometry& g,
               RowScratch& sc, int y, bool opaque) {
  const Image& color = v.color;
  const Image& depth = v.depth;
  const Image& level = v.level;
  const Image& large = v.large;
  const Image& inv_depth = v.inv_depth;
  const bool keep_own_blur = v.keep_own_blur;
  Image& out = v.out;
  const std::uint64_t pass = v.pass;
  const MediumExact* exact = v.exact;
  const float* med[4] = {med_in[0], med_in[1], med_in[2], med_in[3]};
  const int w = g.w, h = g.h, lw = g.lw, lh = g.lh;
  // Vertical lerp of the quarter-res rows around this row, then horizontal lerp to full res:
  // planes 0-3 numerators, 4 the blurred level (normaliser), 5 the blurred inverse depth.
  // Column x = 4i + k sits at quarter-res coordinate i + (2k − 3)/8, so the horizontal
  // footprint repeats every 4 columns: k = 0, 1 lerp cells (i − 1, i) at 5/8, 7/8 and
  // k = 2, 3 lerp cells (i, i + 1) at 1/8, 3/8, with indices clamped to the grid.
  const float fy = (y + 0.5f) / kDown - 0.5f;
  const float y0f = std::floor(fy);
  const float ty = fy - y0f;
  const int ya = clampi(static_cast<int>(y0f), 0, lh - 1), yb = clampi(static_cast<int>(y0f) + 1, 0, lh - 1);
  for (int p = 0; p < 6; ++p) {
    if (opaque && p == 3) continue;  // the alpha numerator: not read on opaque frames (below)
    const Image& img = p < 5 ? large : inv_depth;
    const int pl = p < 5 ? p : 0;
    const float* ra = img.row(pl, ya);
    const float* rb = img.row(pl, yb);
    if (p == 5) {
      // The blurred 1/z feeds the depth test, a hard threshold: it takes the plain pass's
      // bilinear weights and sums (quarter_bilerp), so that the test sees the oracle's value
      // bit for bit (C4 blurs in the oracle's arithmetic too, see depth_blur.cpp); the
      // separable lerp below rounds differently (1080p bench frame: 2 pixels decided the
      // other way). The other planes enter the mix continuously and keep the cheaper lerp.
      // Scalar cells: quarter_bilerp's footprint of column 4i + k (x0 = i − 1 for k < 2, else
      // i; tx as in final_bilerp_simd), its weights and its sum, with the indices clamped.
      float* hr = sc.hrow.data() + static_cast<std::size_t>(5) * w;
      auto cell = [&](int i) {
        constexpr float kTx[4] = {0.625f, 0.875f, 0.125f, 0.375f};
        for (int k = 0; k < 4 && 4 * i + k < w; ++k) {
          const float tx = kTx[k];
          const int x0 = k < 2 ? i - 1 : i;
          const int xa = clampi(x0, 0, lw - 1), xb = clampi(x0 + 1, 0, lw - 1);
          const float w00 = (1 - tx) * (1 - ty), w01 = tx * (1 - ty), w10 = (1 - tx) * ty, w11 = tx * ty;
          hr[4 * i + k] = w00 * ra[xa] + w01 * ra[xb] + w10 * rb[xa] + w11 * rb[xb];
        }
      };
      cell(0);
      for (int i = lw > 2 ? final_bilerp_simd(ra, rb, hr, 1, lw - 1, ty) : 1; i < lw; ++i) cell(i);
      continue;
    }
    float* v = sc.vrow.data() + static_cast<std::size_t>(p) * lw;
    vertical_lerp(ra, rb, v, lw, ty);
    float* hr = sc.hrow.data() + static_cast<std::size_t>(p) * w;
    auto cell = [&](int i) {
      const float vl = v[i > 0 ? i - 1 : 0], vc = v[i], vr = v[i + 1 < lw ? i + 1 : lw - 1];
      const float e[4] = {vl + (vc - vl) * 0.625f, vl + (vc - vl) * 0.875f, vc + (vr - vc) * 0.125f,
                          vc + (vr - vc) * 0.375f};
      const int n = std::min(4, w - 4 * i);
      for (int k = 0; k < n; ++k) hr[4 * i + k] = e[k];
    };
    cell(0);
    // Cells 1 … lw − 2 have both neighbours and all four columns inside the row.
    for (int i = lw > 2 ? final_hlerp_simd(v, hr, 1, lw - 1) : 1; i < lw; ++i) cell(i);
  }
  const float* cb = sc.hrow.data() + static_cast<std::size_t>(4) * w;
  // Level decision and weights, once per pixel.
  // Opaque frame: every source alpha is 1, so each level's alpha is too — small: 16 ones times
  // 1/17; medium: its numerator is its weight (medium_and_final), w / w = 1, or the source's 1;
  // large: its alpha plane is its weight plane bit for bit (large_blur), num / cb = 1, or the
  // medium's 1 — and the mix's alpha is a function of the weights alone, ((ws·small + wm·1) +
  // wl·1) + wsrc·1, or the source's 1 in focus. The weights pass writes it (alpha_out), and
  // channel 3 reads no source row, block sum or level row.
  const WeightRow wr{level.row(0, y),
                     depth.row(0, y),
                     sc.hrow.data() + static_cast<std::size_t>(5) * w,
                     cb,
                     keep_own_blur,
                     sc.ws.data(),
                     sc.wm.data(),
                     sc.wl.data(),
                     sc.wsrc.data(),
                     opaque ? out.row(3, y) : nullptr};
  bool any = false;
  // The alpha row (opaque frames) is written once and not read again: the vector part starts
  // where it is 64-byte aligned, so that FinalWeights can stream it (the planes of an Image
  // start at 16 mod 64); the columns before take the scalar form.
  int x = 0;
  if (wr.alpha_out)
    for (; x < w && reinterpret_cast<std::uintptr_t>(wr.alpha_out + x) % 64 != 0; ++x) any |= weights_scalar(wr, x);
  for (x = final_weights_simd(wr, x, w, any); x < w; ++x) any |= weights_scalar(wr, x);
  if (any && exact && med_wt) exact_medium(*exact, wr.wm, y, sc, med, med_wt);
  for (int ch = 0; ch < (opaque ? 3 : 4); ++ch) {
    const float* src = color.row(ch, y);
    float* o = out.row(ch, y);
    if (!any) {  // whole row in focus: the source, bit for bit
      std::copy(src, src + w, o);
      continue;
    }
    MixRow mr{{},    {},      med[ch], med_wt, sc.hrow.data() + static_cast<std::size_t>(ch) * w, cb, wr.ws, wr.wm,
              wr.wl, wr.wsrc, src,     o};
    for (int k = 0; k < 5; ++k) mr.rows[k] = color.row(ch, clampi(y + k - 2, 0, h - 1));
    // Block sums of the row pairs starting at y − 2, y − 1, y + 1 and y (the pinwheel's taps
    // t0 … t3), each computed once per pass and reused by the next output rows.
    if (w >= 2) {
      const int pairs[4] = {y - 2, y - 1, y + 1, y};
      for (int t = 0; t < 4; ++t) {
        const int j = pairs[t], slot = ((j % 4) + 4) % 4;
        float* b = sc.blocks.data() + (static_cast<std::size_t>(ch) * 4 + slot) * w;
        if (sc.block_pass[ch][slot] != pass || sc.block_row[ch][slot] != j) {
          block_sums(color.row(ch, clampi(j, 0, h - 1)), color.row(ch, clampi(j + 1, 0, h - 1)), b, w - 1);
          sc.block_pass[ch][slot] = pass;
          sc.block_row[ch][slot] = j;
        }
        mr.blocks[t] = b;
      }
    }
    // Columns 2 … w − 3 read x − 2 … x + 2 without clamping. The vector part starts on a
    // 64-byte boundary of the output row (whole vectors for every target, so the kernel can
    // use non-temporal stores); the columns before it take the scalar form.
    int lo = std::min(2, w);
    while (lo < w && reinterpret_cast<std::uintptr_t>(o + lo) % 64 != 0) ++lo;
    const int hi = std::max(lo, w - 2);
    for (int x = 0; x < lo; ++x) mix_scalar(mr, x, w);
    for (int x = final_mix_simd(mr, lo, hi); x < w; ++x) mix_scalar(mr, x, w);
  }
}

}  // namespace

void final_pass(const Image& color, const Image& depth, const Image& level, const Image& medium, const Image& large,
                const Image& inv_depth, bool keep_own_blur, Image& out, const FinalDebug& dbg) {
  if (dbg.used_level || dbg.small || dbg.weights) {
    final_pass_plain(color, depth, level, medium, large, inv_depth, keep_own_blur, out, dbg);
    return;
  }
  const int w = color.width(), h = color.height();
  out.resize(w, h, 4);
  const FinalPassViews views{color, depth, level, large, inv_depth, keep_own_blur, out, new_final_pass_id()};
  core::parallel_for(
      h,
      [&](int y0, int y1) {
        for (int y = y0; y < y1; ++y) {
          const float* med[4] = {medium.row(0, y), medium.row(1, y), medium.row(2, y), medium.row(3, y)};
          final_pass_row(views, med, y);
        }
        flush_streams();  // the mix's non-temporal stores are globally visible before the task ends
      },
      8);
}

std::uint64_t new_final_pass_id() {
  static std::atomic<std::uint64_t> last{0};
  return ++last;
}

void final_pass_row(const FinalPassViews& v, const float* const med[4], int y, const float* med_wt) {
  const Image& color = v.color;
  const Image& large = v.large;
  const int w = color.width(), h = color.height();
  const FinalGeometry g{w, h, large.width(), large.height()};
  thread_local RowScratch sc;  // per worker, kept between frames
  sc.vrow.resize(static_cast<std::size_t>(g.lw) * 6);
  sc.hrow.resize(static_cast<std::size_t>(w) * 6);
  for (auto* v : {&sc.ws, &sc.wm, &sc.wl, &sc.wsrc}) v->resize(w);
  // (A pass id is never reused, so slots filled by an earlier pass, of any width, never match.)
  if (sc.blocks.size() < static_cast<std::size_t>(16) * w) sc.blocks.resize(static_cast<std::size_t>(16) * w);
  final_row(v, med, med_wt, g, sc, y, v.opaque && med_wt && med[3] == med_wt);
}

}  // namespace dofkit::detail::starcraft
