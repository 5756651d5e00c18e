// Fast P4 of the McGuire method (impl=fast): the arithmetic of composite() in the same
// order, organised by rows. The bilinear lookup there is top + (bot − top)·w_y with
// top/bot the horizontal lerps of two low-res rows; every output row between two low-res
// rows reuses the same two horizontally interpolated rows, so each chunk of output rows
// keeps them (9 channels: near 5 + blurry 4) and only redoes one when the low-res row
// changes. The per-pixel composite then runs in SIMD over contiguous arrays
// (composite_row_simd, selects instead of branches).
#include <algorithm>
#include <cmath>
#include <vector>

#include "core/parallel.hpp"
#include "methods/mcguire/blur_weights.hpp"
#include "methods/mcguire/fast.hpp"
#include "methods/mcguire/gather.hpp"

namespace dofkit::detail::mcguire {

namespace {

// Bilinear taps of composite.cpp (texel coordinate x/f, or (x+0.5)/f − 0.5 without the fix).
void fill_taps(int n_out, int n_low, int f, bool fix, int* i0, int* i1, float* w1) {
  for (int x = 0; x < n_out; ++x) {
    const double t = fix ? static_cast<double>(x) / f : (x + 0.5) / f - 0.5;
    const double fl = std::floor(t);
    const int i = static_cast<int>(fl);
    i0[x] = std::clamp(i, 0, n_low - 1);
    i1[x] = std::clamp(i + 1, 0, n_low - 1);
    w1[x] = static_cast<float>(t - fl);
  }
}

// One low-res row (9 channels: near 5, blurry 4) interpolated to w columns.
void h_interp(const Image& blur, const Image& near, int row, int w, const int* i0, const int* i1, const float* w1,
              int f_pattern, float* dst) {
  InterpRowJob job;
  job.f_pattern = f_pattern;
  job.n_low = blur.width();
  job.nc = 9;
  job.w = w;
  for (int c = 0; c < 9; ++c) job.src[c] = c < 5 ? near.row(c, row) : blur.row(c - 5, row);
  job.dst = dst;
  job.i0 = i0;
  job.i1 = i1;
  job.w1 = w1;
  interp_row_simd(job);
}

}  // namespace

void composite_fast(const Image& colour, const Image& coc, const Rect& src, int ox, int oy, const Image& blur,
                    const Image& near, const Constants& k, const Rect& inner, Image& out, Workspace& ws) {
  const int w = inner.w, h = inner.h;
  // Tap indices (x0, x1, y0, y1) and weights (x, y), each max(w, h) long.
  const std::size_t nt = static_cast<std::size_t>(std::max(w, h));
  int* tx0 = ws.plane<int>("mcguire.fast.c_tap_index", 4 * nt);
  int* tx1 = tx0 + nt;
  int* ty0 = tx1 + nt;
  int* ty1 = ty0 + nt;
  float* wx = ws.plane<float>("mcguire.fast.c_tap_weight", 2 * nt);
  float* wyv = wx + nt;
  fill_taps(w, blur.width(), k.f, k.lowres_offset_fix, tx0, tx1, wx);
  fill_taps(h, blur.height(), k.f, k.lowres_offset_fix, ty0, ty1, wyv);
  // With the offset fix the horizontal taps are x / f and x / f + 1 (see fill_taps).
  const int fpat = k.lowres_offset_fix ? k.f : 0;
  // 32 chunks: each starts by interpolating its first two low-res rows again (64 chunks:
  // 334 row interpolations per 1080p frame for 270 low-res rows; 32: 302).
  const int nchunk = std::min(h, 32);
  // Non-temporal output stores (composite_row_simd): the output is not read again by the
  // method, and streaming it saves the read of every output line into the cache before it is
  // written (P4 on one thread measured 0.57 of its time with cached stores; on AMD Zen about
  // even; docs/performance_mcguire.md).
  constexpr bool stream = true;
  core::parallel_for(nchunk, [&](int c0, int c1) {
    // The two interpolated rows per thread, not per chunk: a thread's chunks reuse the same
    // 138 KB (at 1080p), which stays in its L2; per-chunk rows of one workspace image (64 ×
    // 138 KB) were written cold by every chunk. Each chunk interpolates the rows it reads, so
    // the bits do not depend on it. Grown once, reused by later frames.
    thread_local std::vector<float> rows;
    if (rows.size() < 18 * static_cast<std::size_t>(w)) rows.resize(18 * static_cast<std::size_t>(w));
    for (int chunk = c0; chunk < c1; ++chunk) {
      float* row_a = rows.data();
      float* row_b = rows.data() + 9 * static_cast<std::size_t>(w);
      int have_a = -1, have_b = -1;
      const int y0 = static_cast<int>(static_cast<long long>(h) * chunk / nchunk);
      const int y1 = static_cast<int>(static_cast<long long>(h) * (chunk + 1) / nchunk);
      for (int y = y0; y < y1; ++y) {
        const int r0 = ty0[y], r1 = ty1[y];
        // Keep whichever cached row is still needed; refill the other(s).
        if (have_a != r0 && have_b == r0) {
          std::swap(row_a, row_b);
          std::swap(have_a, have_b);
        }
        if (have_a != r0) {
          h_interp(blur, near, r0, w, tx0, tx1, wx, fpat, row_a);
          have_a = r0;
        }
        if (have_b != r1) {
          if (r1 == r0) {
            std::copy_n(row_a, 9 * static_cast<std::size_t>(w), row_b);
          } else {
            h_interp(blur, near, r1, w, tx0, tx1, wx, fpat, row_b);
          }
          have_b = r1;
        }
        CompositeRowJob job;
        job.top = row_a;
        job.bot = row_b;
        job.wy = wyv[y];
        job.w = w;
        const int sy = src.y + oy + y, sx = src.x + ox;
        for (int c = 0; c < 4; ++c) {
          job.col[c] = colour.row(c, sy) + sx;
          job.out[c] = out.row(c, inner.y + y) + inner.x;
        }
        job.coc = coc.row(0, sy) + sx;
        job.inv_rmax = k.r_max > 0 ? 1.0f / static_cast<float>(k.r_max) : 0.0f;
        job.focus_px = k.focus_px;
        job.far_rescale = k.far_rescale;
        job.coverage_boost = k.coverage_boost;
        job.g3d = k.variant == Variant::g3d;
        job.double_coc = k.double_coc;
        job.stream = stream;
        composite_row_simd(job);
      }
    }
    if (stream) composite_flush_streams();
  });
}

}  // namespace dofkit::detail::mcguire
