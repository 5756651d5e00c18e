// Fast P7: the 49-tap gather, register-blocked. Same sums as gather.cpp, same order.
//
// gather.cpp accumulates tap by tap into row-length arrays: per tap and channel it loads
// 4 source values, the accumulator, and stores the accumulator back. Here one 8-texel chunk
// (exactly one 8×8 tile's row) keeps all of its channel accumulators in vector registers for
// the 49 taps, so a tap costs its 4 loads per channel and nothing else; the per-tap bilinear
// weights are broadcast once and shared by the channels. Each tap is one linear offset
// dy·pitch + dx into the padded plane, so no index is clamped and no branch is taken.
//
// Work: tile (8×8 texels) bits from tile classification select the fields per tile — a tile
// with no near texel does not run the near gather even if its neighbour does (gather.cpp
// merges runs of active tiles and computes both fields over the run). Per texel the result is
// selected as in gather.cpp: near where nearBlur_h > 0 else colour_h; far where far_h > 0
// else 0.
//
// Locality: tasks are column strips of kStripTiles tiles walked top to bottom. A row reads
// source rows y − reach … y + reach + 1; walking down a strip re-reads all but one of them,
// so they stay in L2 (at kernel reach 29 texels: 9 planes × 60 rows × 90 floats ≈ 190 kB).
#include <algorithm>
#include <cmath>
#include <cstring>

#include "core/parallel.hpp"
#include "methods/sterna/fast.hpp"

namespace dofkit::detail::sterna::fast {

namespace {

constexpr std::uint8_t kNearBit = 1, kFarBit = 2;
constexpr int kStripTiles = 4;
static_assert(kTile == 8, "one tile row is one 8-lane chunk");

typedef float V8 __attribute__((vector_size(32)));
typedef int I8 __attribute__((vector_size(32)));

__attribute__((always_inline)) inline V8 load8(const float* p) {
  V8 v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
__attribute__((always_inline)) inline void store8(float* p, V8 v) { std::memcpy(p, &v, sizeof v); }
__attribute__((always_inline)) inline V8 splat(float f) { return V8{f, f, f, f, f, f, f, f}; }

struct Tap {
  std::ptrdiff_t off;        // dy·pitch + dx, floats
  float w00, w10, w01, w11;  // bilinear weights (gather.cpp split())
};

// gather.cpp's split(): integer part and bilinear weights of an offset.
Tap split(float ox, float oy, int pitch) {
  const float fx0 = std::floor(ox), fy0 = std::floor(oy);
  const float fx = ox - fx0, fy = oy - fy0;
  return {static_cast<std::ptrdiff_t>(fy0) * pitch + static_cast<std::ptrdiff_t>(fx0), (1 - fx) * (1 - fy),
          fx * (1 - fy), (1 - fx) * fy, fx * fy};
}

// Σ_taps bilinear(src_c) for 8 texels starting at base[c] (kC channels), into acc.
template <int kC>
__attribute__((always_inline)) inline void gather8(const float* const* base, const Tap* taps, int ntaps,
                                                   std::ptrdiff_t pitch, V8* acc) {
  for (int c = 0; c < kC; ++c) acc[c] = splat(0.0f);
  for (int t = 0; t < ntaps; ++t) {
    const V8 w00 = splat(taps[t].w00), w10 = splat(taps[t].w10), w01 = splat(taps[t].w01),
             w11 = splat(taps[t].w11);
    const std::ptrdiff_t o = taps[t].off;
    for (int c = 0; c < kC; ++c) {
      const float* r0 = base[c] + o;
      const float* r1 = r0 + pitch;
      acc[c] += w00 * load8(r0) + w10 * load8(r0 + 1) + w01 * load8(r1) + w11 * load8(r1 + 1);
    }
  }
}

struct Job {
  const Buffers* b;
  const Tap* taps;
  int ntaps;
  float inv_taps;
};

// One strip of tiles [tx0, tx1) over all rows.
STERNA_SIMD void gather_strip(const Job& job, int tx0, int tx1) {
  const Buffers& b = *job.b;
  const int w = b.w, h = b.h;
  const std::ptrdiff_t pitch = b.near_src->width();
  const V8 inv_taps = splat(job.inv_taps);
  const V8 zero = splat(0.0f);
  for (int y = 0; y < h; ++y) {
    const std::uint8_t* tiles = b.tiles->data() + static_cast<std::size_t>(y / kTile) * b.tiles_x;
    const float* nbr = b.near_blur->row(0, y);
    const float* frr = b.far_h_row(y);
    for (int tx = tx0; tx < tx1; ++tx) {
      const int x0 = tx * kTile, n = std::min(kTile, w - x0);
      const std::uint8_t bits = tiles[tx];
      float nbuf[4][kTile], fbuf[4][kTile];
      // Near field.
      {
        V8 res[4];
        if (bits & kNearBit) {
          const float* base[4];
          for (int c = 0; c < 4; ++c) base[c] = b.src_row(*b.near_src, c, y) + x0;
          V8 acc[4];
          gather8<4>(base, job.taps, job.ntaps, pitch, acc);
          // near_blur is unpadded: the last tile of a row may be partial.
          float nbv[kTile] = {0, 0, 0, 0, 0, 0, 0, 0};
          std::copy(nbr + x0, nbr + x0 + n, nbv);
          const I8 m = load8(nbv) > zero;
          for (int c = 0; c < 4; ++c) res[c] = m ? acc[c] * inv_taps : load8(base[c]);
        } else {
          for (int c = 0; c < 4; ++c) res[c] = load8(b.src_row(*b.near_src, c, y) + x0);
        }
        for (int c = 0; c < 4; ++c) {
          if (n == kTile) store8(b.dof_near->row(c, y) + x0, res[c]);
          else {
            store8(nbuf[c], res[c]);
            std::copy(nbuf[c], nbuf[c] + n, b.dof_near->row(c, y) + x0);
          }
        }
      }
      // Far field.
      {
        V8 res[4];
        if (bits & kFarBit) {
          const float* base[5];
          for (int c = 0; c < 5; ++c) base[c] = b.src_row(*b.far_src, c, y) + x0;
          V8 acc[5];
          gather8<5>(base, job.taps, job.ntaps, pitch, acc);
          const V8 inv = 1.0f / acc[4];
          const I8 m = load8(frr + x0) > zero;
          for (int c = 0; c < 4; ++c) res[c] = m ? acc[c] * inv : zero;
        } else {
          for (int c = 0; c < 4; ++c) res[c] = zero;
        }
        for (int c = 0; c < 4; ++c) {
          if (n == kTile) store8(b.dof_far->row(c, y) + x0, res[c]);
          else {
            store8(fbuf[c], res[c]);
            std::copy(fbuf[c], fbuf[c] + n, b.dof_far->row(c, y) + x0);
          }
        }
      }
    }
  }
}

STERNA_SIMD void classify_row(const float* __restrict nb, const float* __restrict fr, std::uint8_t* tiles, int w) {
  for (int x0 = 0, t = 0; x0 < w; x0 += kTile, ++t) {
    const int x1 = std::min(w, x0 + kTile);
    bool nn = false, ff = false;
    for (int x = x0; x < x1; ++x) {
      nn |= nb[x] > 0.0f;
      ff |= fr[x] > 0.0f;
    }
    tiles[t] |= (nn ? kNearBit : 0) | (ff ? kFarBit : 0);
  }
}

}  // namespace

void gather(const Settings& s, Buffers& b) {
  const int w = b.w, h = b.h;
  b.tiles_x = (w + kTile - 1) / kTile;
  b.tiles_y = (h + kTile - 1) / kTile;
  b.tiles->assign(static_cast<std::size_t>(b.tiles_x) * b.tiles_y, 0);
  core::parallel_for(b.tiles_y, [&](int t0, int t1) {
    for (int ty = t0; ty < t1; ++ty)
      for (int y = ty * kTile; y < std::min(h, (ty + 1) * kTile); ++y)
        classify_row(b.near_blur->row(0, y), b.far_h_row(y), b.tiles->data() + static_cast<std::size_t>(ty) * b.tiles_x,
                     w);
  });

  const int pitch = b.near_src->width();
  Tap taps[kTaps];
  const int ntaps = static_cast<int>(std::min<std::size_t>(s.offsets.size(), kTaps));
  for (int t = 0; t < ntaps; ++t)
    taps[t] = split(s.offsets[t].x * s.kernel_scale, s.offsets[t].y * s.kernel_scale, pitch);
  const Job job{&b, taps, ntaps, 1.0f / static_cast<float>(s.offsets.size())};
  const int strips = (b.tiles_x + kStripTiles - 1) / kStripTiles;
  core::parallel_for(strips, [&](int s0, int s1) {
    for (int st = s0; st < s1; ++st)
      gather_strip(job, st * kStripTiles, std::min(b.tiles_x, (st + 1) * kStripTiles));
  });
}

}  // namespace dofkit::detail::sterna::fast
