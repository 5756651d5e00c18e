#include "core/weighted_gaussian.hpp"

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/clones.hpp"
#include "core/filters.hpp"
#include "core/parallel.hpp"
#include "core/strip.hpp"

namespace dofkit::core {

// Horizontal sweep in strips (core/strip.hpp, as in core/filters.cpp): kLanes rows
// interleaved, buf[(i + pad) · kLanes + j] = sample i of row j, i in [−pad, n + pad), moved in
// and out by the shared 8×8 transposes; the pad holds the replicated edge sample
// (clamp-to-edge). Vertical sweep: row by row over blocks of columns (box_row; the streamed form
// a few rows at a time over the whole width, box_rows), no strips.
//
// The horizontal passes are strip::strip_passes, the very function gaussian_blur_plane runs
// (core/strip.cpp, where their precision is derived); the vertical sweeps below repeat
// its arithmetic row by row (same sums, re-synchronised at the same kResync outputs), so the
// output is gaussian_blur_plane's bit for bit.

namespace weighted_gaussian_detail {

constexpr int kLanes = strip::kStripLanes;
using strip::kResync;
constexpr int kBlock = 128;  // columns per block of the vertical sweep
constexpr int kAhead = 4;    // rows prefetched ahead by the vertical sweep
// Rows per box_rows call of the streamed form (<= kResync: at most one re-synchronisation per
// call). Every ring grows by a group, and the working set of the bench frame's medium level
// (~2 MB at 1080p) is already about the L2 of the machines measured, so small groups win:
// medium level on one thread, 1080p bench frame, 4 rows 14.4 ms, 8 rows 15.0, 16 rows 15.7
// (row by row with box_row_acc: 17.0).
constexpr int kGroup = 4;
// Where the rings of kGroup rows outgrow the L2 anyway (the bench frame at 3840×2160: its medium
// level's rings are 6.8 MB, 2.2 MB at 1080p), every ring row comes from L3 whatever the group.
// On a core with a 2 MB L2 larger groups then win: fewer box_rows calls, each loading and
// storing its window and pending sums once per group (medium level + final pass at 4K,
// 1 thread: ~0.93 of the time with 32 rows). On a core with a 1 MB L2 they lose (the whole
// 4K frame 0.89 of the 32-row time with 4 rows, at 1 and at 2 threads): one 32-row group of
// the passes' output rows (4 planes × 32 rows × 3840 floats, 2 MB) no longer fits the L2 the
// next pass reads it from. So the wide group is taken only where the rings exceed
// kGroupRingBytes and the L2 is at least kWideGroupL2Bytes; 1 MB-L2 cores keep kGroup
// everywhere (docs/methods/starcraft.md, its 4K / 1080p notes). Same values: a group only
// splits the same row sequence into calls, the sums carried between them in memory.
constexpr int kWideGroup = 32;  // <= kResync: at most one re-synchronisation per call
constexpr std::size_t kGroupRingBytes = std::size_t{4} << 20;
constexpr std::size_t kWideGroupL2Bytes = std::size_t{2} << 20;
thread_local int g_group_override = 0;  // set_weighted_gaussian_group
constexpr int kMaxGroup = kGroup > kWideGroup ? kGroup : kWideGroup;

using strip::Vec8;
using strip::Vec8u;
#define WG_LOAD8(p) (*reinterpret_cast<const Vec8u*>(p))
#define WG_STORE8(p, v) (*reinterpret_cast<Vec8u*>(p) = (v))
using strip::strip_passes;

/// Per-thread strip scratch, grown on demand and kept (no allocation per frame). 64-byte
/// aligned (the vector's own storage is 16-byte aligned, an mmap'd chunk at 16 mod 64 for
/// the sizes used here), as core/filters.cpp's strip scratch: the callers lay their strips and
/// rows out at multiples of 16 floats, so that no 16-lane strip sample or row vector straddles
/// two cache lines.
float* scratch(std::size_t floats) {
  thread_local std::vector<float> buf;
  if (buf.size() < floats + 16) buf.resize(floats + 16);
  const std::size_t mis = reinterpret_cast<std::uintptr_t>(buf.data()) % 64;
  return buf.data() + (64 - mis) % 64 / sizeof(float);
}

using strip::load_rows_transposed;
using strip::store_rows_transposed;

/// One output row of one extended-box pass over nx lanes (same expression as strip_passes):
/// out = (sum + alpha·(lo + hi))·norm, then the window slides: sum += hi − out_lo.
DOFKIT_CLONES
void box_row(float* __restrict sum, const float* lo, const float* hi, const float* out_lo, float* __restrict out,
             int nx, float alpha, float norm) {
  for (int j = 0; j < nx; ++j) {
    out[j] = (sum[j] + alpha * (lo[j] + hi[j])) * norm;
    sum[j] += hi[j] - out_lo[j];
  }
}

/// Per-row steps of box_rows, in this order: the window sum is set from the pending fresh
/// sum (kFromFresh) or re-summed from `win` (kResum); the pending sum is cleared (kZeroFresh);
/// the row is computed, and its entering sample hi is added to the pending sum (kAccumulate).
enum BoxRowFlags : unsigned char { kFromFresh = 1, kResum = 2, kZeroFresh = 4, kAccumulate = 8 };

/// n consecutive output rows t = 0 … n − 1 of one extended-box pass over columns [0, nx):
/// per column the steps of need()'s former row loop — flags[t] (see BoxRowFlags), then
/// box_row's out = (sum + alpha·(lo + hi))·norm, sum += hi − out_lo, and fresh += hi where
/// kAccumulate — in the same order, so the values are box_row's bit for bit. Row t's lo (its
/// sample i − r − 1) is row t − 1's out_lo (sample i − 1 − r), so it stays in a register, as
/// do the window and pending sums down the n rows of each 32-column chunk: a row costs two
/// loads and a store per vector instead of box_row_acc's five loads and three stores.
/// lo0: row 0's lo; win: the 2r + 1 = nwin rows of the re-sum (the row flagged kResum, at
/// most one per call).
DOFKIT_CLONES
void box_rows(float* __restrict sum, float* __restrict fresh, const float* lo0, const float* const* hi,
              const float* const* out_lo, float* const* out, const unsigned char* flags, const float* const* win,
              int nwin, int n, int nx, float alpha, float norm) {
  constexpr int kV = 4;  // vectors of 8 columns per chunk: independent sums for the adders
  const Vec8 va = alpha + Vec8{}, vn = norm + Vec8{};
  int x = 0;
  for (; x + 8 * kV <= nx; x += 8 * kV) {
    Vec8 s[kV], f[kV], l[kV];
    for (int v = 0; v < kV; ++v) {
      s[v] = WG_LOAD8(sum + x + 8 * v);
      f[v] = WG_LOAD8(fresh + x + 8 * v);
      l[v] = WG_LOAD8(lo0 + x + 8 * v);
    }
    for (int t = 0; t < n; ++t) {
      const unsigned char fl = flags[t];
      if (fl & kFromFresh)
        for (int v = 0; v < kV; ++v) s[v] = f[v];
      if (fl & kResum) {
        for (int v = 0; v < kV; ++v) s[v] = Vec8{};
        for (int q = 0; q < nwin; ++q)
          for (int v = 0; v < kV; ++v) s[v] += WG_LOAD8(win[q] + x + 8 * v);
      }
      if (fl & kZeroFresh)
        for (int v = 0; v < kV; ++v) f[v] = Vec8{};
      const float* const hr = hi[t];
      const float* const orow = out_lo[t];
      float* const o = out[t];
      for (int v = 0; v < kV; ++v) {
        const Vec8 hv = WG_LOAD8(hr + x + 8 * v), ov = WG_LOAD8(orow + x + 8 * v);
        WG_STORE8(o + x + 8 * v, (s[v] + va * (l[v] + hv)) * vn);
        s[v] += hv - ov;
        if (fl & kAccumulate) f[v] += hv;
        l[v] = ov;
      }
    }
    for (int v = 0; v < kV; ++v) {
      WG_STORE8(sum + x + 8 * v, s[v]);
      WG_STORE8(fresh + x + 8 * v, f[v]);
    }
  }
  for (; x < nx; ++x) {  // the same steps, one column at a time
    float s = sum[x], f = fresh[x], l = lo0[x];
    for (int t = 0; t < n; ++t) {
      const unsigned char fl = flags[t];
      if (fl & kFromFresh) s = f;
      if (fl & kResum) {
        s = 0.0f;
        for (int q = 0; q < nwin; ++q) s += win[q][x];
      }
      if (fl & kZeroFresh) f = 0.0f;
      const float hv = hi[t][x], ov = out_lo[t][x];
      out[t][x] = (s + alpha * (l + hv)) * norm;
      s += hv - ov;
      if (fl & kAccumulate) f += hv;
      l = ov;
    }
    sum[x] = s;
    fresh[x] = f;
  }
}

/// sum = Σ rows[k] for k = 0 … n − 1, in that order (the re-synchronisation of the window).
/// 32 columns at a time stay in registers while the n rows are added, so a column costs its
/// n loads and one store (row by row, the partial sums would be loaded and stored again for
/// every row: 3n memory operations; at 4K, where the medium level's window no longer fits a
/// re-synchronisation block, that made this the biggest kernel of the level).
DOFKIT_CLONES
void sum_rows(float* __restrict sum, const float* const* rows, int n, int nx) {
  int j = 0;
  for (; j + 32 <= nx; j += 32) {
    Vec8 a0 = {}, a1 = {}, a2 = {}, a3 = {};
    for (int k = 0; k < n; ++k) {
      const float* q = rows[k] + j;
      a0 += WG_LOAD8(q);
      a1 += WG_LOAD8(q + 8);
      a2 += WG_LOAD8(q + 16);
      a3 += WG_LOAD8(q + 24);
    }
    WG_STORE8(sum + j, a0);
    WG_STORE8(sum + j + 8, a1);
    WG_STORE8(sum + j + 16, a2);
    WG_STORE8(sum + j + 24, a3);
  }
  for (; j < nx; ++j) {
    float a = 0.0f;
    for (int k = 0; k < n; ++k) a += rows[k][j];
    sum[j] = a;
  }
}

/// The division of the normalised convolution for one row segment: out = num / wt where
/// wt > tiny, else the source (no tap carried weight; read only when some pixel needs it).
DOFKIT_CLONES
void normalise_row(const float* __restrict num, const float* __restrict wt, const float* __restrict src,
                   float* __restrict out, int nx, float tiny) {
  int ok = 0;
  for (int j = 0; j < nx; ++j) ok += wt[j] > tiny ? 1 : 0;
  if (ok == nx) {
    for (int j = 0; j < nx; ++j) out[j] = num[j] / wt[j];
  } else {  // without a branch per lane: both values, then a select (vectorises)
    for (int j = 0; j < nx; ++j) {
      const float q = num[j] / std::max(wt[j], tiny);  // = num / wt wherever it is used
      const float s = src[j];
      out[j] = wt[j] > tiny ? q : s;
    }
  }
}

#undef WG_LOAD8
#undef WG_STORE8

}  // namespace weighted_gaussian_detail

using namespace weighted_gaussian_detail;

void weighted_gaussian(const float* const* src, int nplanes, const float* c, int w, int h, float sigma, int passes,
                       float tiny, float* const* dst, float* weight, bool normalise) {
  if (w <= 0 || h <= 0 || nplanes <= 0) return;
  int r = 0;
  float alpha = 0.0f;
  if (sigma > 0 && passes > 0)
    extended_box_params(sigma, passes, r, alpha);
  else
    passes = 0;
  const int pad = r + 1;

  // Horizontal sweep: strips of kLanes rows. The weights' strip is loaded once and used to
  // weight every plane as it is transposed in; it is blurred last.
  {
    const std::size_t strip = static_cast<std::size_t>(w + 2 * pad) * kLanes;
    const int strips = (h + kLanes - 1) / kLanes;
    parallel_for(strips, [&](int s0, int s1) {
      float* cb = scratch(3 * strip);
      float* a = cb + strip;
      float* b = a + strip;
      const std::size_t off = static_cast<std::size_t>(pad) * kLanes;
      for (int s = s0; s < s1; ++s) {
        const int y0 = s * kLanes, ny = std::min(kLanes, h - y0);
        const float* in[kLanes];
        float* out[kLanes];
        auto rowoff = [&](int j) { return static_cast<std::size_t>(y0 + std::min(j, ny - 1)) * w; };
        for (int j = 0; j < kLanes; ++j) in[j] = c + rowoff(j);
        load_rows_transposed(in, w, nullptr, cb + off);
        for (int k = 0; k < nplanes; ++k) {
          for (int j = 0; j < kLanes; ++j) in[j] = src[k] + rowoff(j), out[j] = dst[k] + rowoff(j);
          load_rows_transposed(in, w, cb + off, a + off);
          const float* res = passes > 0 ? strip_passes(a, b, w, pad, r, alpha, passes) : a;
          store_rows_transposed(res + off, w, out, ny);
        }
        for (int j = 0; j < kLanes; ++j) out[j] = weight + rowoff(j);
        const float* res = passes > 0 ? strip_passes(cb, a, w, pad, r, alpha, passes) : cb;
        store_rows_transposed(res + off, w, out, ny);
      }
    });
  }

  // Vertical sweep, streamed down the rows of blocks of kBlock columns so that every memory
  // access is a contiguous row segment. Pass k of the cascade produces its row i once its
  // input rows up to i + r + 1 exist, i.e. (k + 1)(r + 1) rows behind the rows read from the
  // planes; the intermediate passes keep their last 2r + 3 rows in small rings (rows past the
  // image edges are the clamped edge rows, which the ring still holds when they are needed).
  // Each output row is divided by the blurred weight as it leaves the last pass. The planes
  // are read by the first pass (in place: a row is overwritten only after its last use) and
  // written by the division. Per lane the arithmetic is strip_passes' (same sums, same
  // re-synchronisation every kResync rows), so the result equals the column-strip form.
  {
    const int np = nplanes + 1;  // the weights are plane np − 1 of the sweep
    const int ring = 2 * r + 3;
    const int delay = r + 1;
    const int blocks = (w + kBlock - 1) / kBlock;
    const float norm = static_cast<float>(1.0 / (2.0 * r + 1.0 + 2.0 * alpha));
    const std::size_t ring_floats = static_cast<std::size_t>(std::max(0, passes - 1)) * np * ring * kBlock;
    // With one pass the planes it reads in place are also the ones written, and its input row
    // i is read last for output row i + r + 1 (as its lo): the output rows wait `lag` = r + 1
    // steps in `last` (a ring of lag + 1 rows) before they are written. With two or more passes
    // the write comes (passes − 1) · delay >= delay steps after that last read anyway.
    const int lag = passes == 1 ? delay : 0;
    const std::size_t floats = ring_floats + (static_cast<std::size_t>(passes) + 1 + lag) * np * kBlock;
    parallel_for(blocks, [&](int b0, int b1) {
      float* rings = scratch(floats);
      float* sums = rings + ring_floats;                                    // [passes][np][kBlock]
      float* last = sums + static_cast<std::size_t>(passes) * np * kBlock;  // [lag + 1][np][kBlock]
      thread_local std::vector<const float*> rows;
      rows.resize(2 * static_cast<std::size_t>(r) + 1);
      auto clamp_row = [&](int y) { return y < 0 ? 0 : (y >= h ? h - 1 : y); };
      for (int bk = b0; bk < b1; ++bk) {
        const int x0 = bk * kBlock, nx = std::min(kBlock, w - x0);
        auto plane_of = [&](int p) -> float* { return p == nplanes ? weight : dst[p]; };
        // Where row y (clamped) of the input of pass k lies for sweep plane p: a plane row for
        // k = 0, else a ring slot; `at` turns that into a pointer.
        auto where = [&](int k, int y) -> std::size_t {
          y = clamp_row(y);
          return k == 0 ? static_cast<std::size_t>(y) * w + x0 : static_cast<std::size_t>(y % ring) * kBlock;
        };
        auto at = [&](int k, int p, std::size_t pos) -> const float* {
          if (k == 0) return plane_of(p) + pos;
          return rings + (static_cast<std::size_t>(k - 1) * np + p) * ring * kBlock + pos;
        };
        auto output = [&](int k, int p, int y) -> float* {
          if (k == passes - 1) return last + (static_cast<std::size_t>(y % (lag + 1)) * np + p) * kBlock;
          return rings + ((static_cast<std::size_t>(k) * np + p) * ring + y % ring) * kBlock;
        };
        for (int t = 0; t < h + passes * delay + lag; ++t) {
          // The first pass reads a new row of every plane per step, at a stride the hardware
          // prefetchers do not follow: ask for it a few rows ahead.
          if (t + kAhead < h)
            for (int p = 0; p < np; ++p) {
              const float* row = plane_of(p) + static_cast<std::size_t>(t + kAhead) * w + x0;
              for (int j = 0; j < nx; j += 16) __builtin_prefetch(row + j);
            }
          // Likewise the source rows the division may fall back to.
          if (const int ys = t - passes * delay - lag + kAhead; normalise && ys >= 0 && ys < h)
            for (int p = 0; p < nplanes; ++p) {
              const float* row = src[p] + static_cast<std::size_t>(ys) * w + x0;
              for (int j = 0; j < nx; j += 16) __builtin_prefetch(row + j);
            }
          for (int k = 0; k < passes; ++k) {
            const int i = t - (k + 1) * delay;
            if (i < 0 || i >= h) continue;
            const std::size_t lo = where(k, i - r - 1), hi = where(k, i + r + 1), out_lo = where(k, i - r);
            for (int p = 0; p < np; ++p) {
              float* sum = sums + (static_cast<std::size_t>(k) * np + p) * kBlock;
              if (i % kResync == 0) {
                for (int q = -r; q <= r; ++q) rows[q + r] = at(k, p, where(k, i + q));
                sum_rows(sum, rows.data(), 2 * r + 1, nx);
              }
              box_row(sum, at(k, p, lo), at(k, p, hi), at(k, p, out_lo), output(k, p, i), nx, alpha, norm);
            }
          }
          const int i = t - passes * delay - lag;
          if (i < 0 || i >= h) continue;
          const std::size_t o = static_cast<std::size_t>(i) * w + x0;
          float* const done = last + static_cast<std::size_t>(i % (lag + 1)) * np * kBlock;  // row i's sums
          if (passes == 0)  // no blur: the weighted planes themselves, copied so none aliases
            for (int p = 0; p < np; ++p) {
              const float* in = plane_of(p) + o;
              std::copy(in, in + nx, done + static_cast<std::size_t>(p) * kBlock);
            }
          const float* wt = done + static_cast<std::size_t>(nplanes) * kBlock;
          for (int p = 0; p < nplanes; ++p) {
            const float* num = done + static_cast<std::size_t>(p) * kBlock;
            if (normalise)
              normalise_row(num, wt, src[p] + o, dst[p] + o, nx, tiny);
            else
              std::copy(num, num + nx, dst[p] + o);
          }
          if (!normalise) std::copy(wt, wt + nx, weight + o);
        }
      }
    });
  }
}

void set_weighted_gaussian_group(int rows) { g_group_override = rows; }

// Streamed form. Every pass is a sequence of full-width rows; the horizontal passes produce
// the first sequence kLanes rows at a time (the strip technique above, written into a ring),
// each vertical pass k produces its row i once rows i + r + 1 of its input exist and keeps its
// last 2r + 3 rows in a ring (enough for the window and for the clamped edge rows, which are
// the oldest or the newest rows whenever they are referenced). A band's passes start at rows
// that are multiples of kResync, where the window sums are recomputed from scratch, so every
// row's arithmetic is that of the whole-image sweep.
void weighted_gaussian_rows(const float* const* src, int nplanes, const float* c, int w, int h, float sigma, int passes,
                            float tiny, int y0, int y1, RowSink sink, void* ctx, bool normalise) {
  y0 = std::max(y0, 0);
  y1 = std::min(y1, h);
  if (w <= 0 || h <= 0 || nplanes <= 0 || y0 >= y1) return;
  int r = 0;
  float alpha = 0.0f;
  if (sigma > 0 && passes > 0)
    extended_box_params(sigma, passes, r, alpha);
  else
    passes = 0;
  const int pad = r + 1;
  const int np = nplanes + 1;  // sweep plane np − 1 = the weights
  const float norm = static_cast<float>(1.0 / (2.0 * r + 1.0 + 2.0 * alpha));
  // Row stride of the rings and row buffers: w rounded up to 16 floats, so that every row
  // starts on a 64-byte boundary of the aligned scratch (the vertical passes' vectors then
  // never straddle two lines, nor do the transposes' row accesses: see unaligned_head).
  const std::size_t row = (static_cast<std::size_t>(w) + 15) / 16 * 16;
  // The vertical passes produce `group` rows per step (box_rows), so every ring holds a
  // pass's window (2r + 3 rows) plus one group; the horizontal output also one strip of new rows.
  auto ring0_rows = [&](int g) { return 2 * r + 3 + kLanes + g; };
  auto ring_rows = [&](int g) { return 2 * r + 3 + g; };
  auto ring_floats = [&](int g) {
    return static_cast<std::size_t>(np) * (ring0_rows(g) + std::max(0, passes - 1) * ring_rows(g)) * row;
  };
  // Rows per box_rows call: kGroup while the rings of that choice fit about an L2, else, on a
  // large-L2 core, kWideGroup (see kWideGroup; the values do not depend on it, only the memory
  // traffic).
  const int group = g_group_override == kGroup || g_group_override == kWideGroup ? g_group_override
                    : ring_floats(kGroup) * sizeof(float) > kGroupRingBytes && l2_cache_bytes() >= kWideGroupL2Bytes
                        ? kWideGroup
                        : kGroup;
  const int ring0 = ring0_rows(group);
  const int ring = ring_rows(group);
  const std::size_t strip = static_cast<std::size_t>(w + 2 * pad) * kLanes;
  const std::size_t n_ring0 = static_cast<std::size_t>(np) * ring0 * row;
  const std::size_t n_rings = static_cast<std::size_t>(std::max(0, passes - 1)) * np * ring * row;
  const std::size_t n_sums = static_cast<std::size_t>(passes) * np * row;
  const std::size_t n_last = static_cast<std::size_t>(np) * group * row;
  const std::size_t n_outs = static_cast<std::size_t>(nplanes) * row;
  float* base = scratch(n_ring0 + n_rings + 2 * n_sums + n_last + n_outs + 3 * strip);
  float* r0 = base;               // [np][ring0][w]
  float* rings = r0 + n_ring0;    // [passes − 1][np][ring][w]
  float* sums = rings + n_rings;  // [passes][np][w]
  float* last = sums + n_sums;    // [np][group][w]: the last pass's latest rows (ring)
  float* outs = last + n_last;    // [nplanes][w]: the normalised row
  float* fresh = outs + n_outs;   // [passes][np][w]: next window sums being built (see strip_passes)
  float* cb = fresh + n_sums;     // three strip buffers of the horizontal passes
  float* sa = cb + strip;
  float* sb = sa + strip;
  auto clamp_row = [&](int y) { return y < 0 ? 0 : (y >= h ? h - 1 : y); };
  auto align = [](int y) { return y - y % kResync; };

  // Row y (clamped) of the input of pass k, plane p.
  auto input = [&](int k, int p, int y) -> const float* {
    y = clamp_row(y);
    if (k == 0) return r0 + (static_cast<std::size_t>(p) * ring0 + y % ring0) * row;
    return rings + ((static_cast<std::size_t>(k - 1) * np + p) * ring + y % ring) * row;
  };
  auto output = [&](int k, int p, int y) -> float* {
    if (k == passes - 1) return last + (static_cast<std::size_t>(p) * group + y % group) * row;
    return rings + ((static_cast<std::size_t>(k) * np + p) * ring + y % ring) * row;
  };

  // First row each pass computes, walking back from the band: pass k must start at a
  // re-synchronisation row and cover the rows pass k + 1 reads.
  thread_local std::vector<int> produced, first;             // per pass: last row done, first row in this band
  produced.assign(static_cast<std::size_t>(passes) + 1, 0);  // [passes] = the horizontal passes
  first.assign(static_cast<std::size_t>(passes) + 1, 0);
  const bool carry = 2 * r + 1 <= kResync;
  const int acc_from = kResync - 2 * r - 1;  // block offset from which hi rows belong to the next window
  {
    int need_from = y0;
    for (int k = passes - 1; k >= 0; --k) {
      const int start = align(need_from);
      produced[k] = start - 1;
      first[k] = start;
      need_from = std::max(0, start - r - 1);
    }
    produced[passes] = need_from - 1;
  }
  int& h_done = produced[passes];

  // Horizontal passes for the rows after h_done, one strip of kLanes rows.
  auto horizontal_strip = [&]() {
    const int ys = h_done + 1, ny = std::min(kLanes, h - ys);
    const std::size_t off = static_cast<std::size_t>(pad) * kLanes;
    const float* in[kLanes];
    float* out[kLanes];
    auto rowoff = [&](int j) { return static_cast<std::size_t>(ys + std::min(j, ny - 1)) * w; };
    auto ring_row = [&](int p, int j) { return r0 + (static_cast<std::size_t>(p) * ring0 + (ys + j) % ring0) * row; };
    for (int j = 0; j < kLanes; ++j) in[j] = c + rowoff(j);
    load_rows_transposed(in, w, nullptr, cb + off);
    for (int p = 0; p < nplanes; ++p) {
      for (int j = 0; j < kLanes; ++j) in[j] = src[p] + rowoff(j), out[j] = ring_row(p, std::min(j, ny - 1));
      load_rows_transposed(in, w, cb + off, sa + off);
      const float* res = passes > 0 ? strip_passes(sa, sb, w, pad, r, alpha, passes) : sa;
      store_rows_transposed(res + off, w, out, ny);
    }
    for (int j = 0; j < kLanes; ++j) out[j] = ring_row(nplanes, std::min(j, ny - 1));
    const float* res = passes > 0 ? strip_passes(cb, sa, w, pad, r, alpha, passes) : cb;
    store_rows_transposed(res + off, w, out, ny);
    h_done = ys + ny - 1;
  };

  // Makes pass k (k = passes: the horizontal passes) produce rows up to j (clamped), at most
  // group rows per box_rows call. Each group first makes the input pass produce the rows its
  // windows reach (i + r + 1 for its last row i).
  thread_local std::vector<const float*> his, lows, wins;
  thread_local std::vector<float*> outp;
  his.resize(group);
  lows.resize(group);
  outp.resize(group);
  wins.resize(2 * static_cast<std::size_t>(r) + 1);
  auto need = [&](auto&& self, int k, int j) -> void {
    j = std::min(j, h - 1);
    if (k == passes) {
      while (h_done < j) horizontal_strip();
      return;
    }
    while (produced[k] < j) {
      const int i0 = produced[k] + 1, n = std::min(group, j - i0 + 1);
      self(self, k == 0 ? passes : k - 1, i0 + n - 1 + r + 1);
      unsigned char flags[kMaxGroup];
      int resum = -1;  // the row re-summed from scratch, if any
      for (int t = 0; t < n; ++t) {
        const int i = i0 + t, m = i % kResync;
        unsigned char f = 0;
        if (m == 0) {
          if (carry && i != first[k])
            f |= kFromFresh;
          else
            f |= kResum, resum = i;
        }
        if (carry && m >= acc_from) f |= (m == acc_from ? kZeroFresh : 0) | kAccumulate;
        flags[t] = f;
      }
      for (int p = 0; p < np; ++p) {
        const std::size_t sp = (static_cast<std::size_t>(k) * np + p) * row;
        for (int t = 0; t < n; ++t) {
          const int i = i0 + t;
          his[t] = input(k, p, i + r + 1);
          lows[t] = input(k, p, i - r);
          outp[t] = output(k, p, i);
        }
        if (resum >= 0)
          for (int q = -r; q <= r; ++q) wins[q + r] = input(k, p, resum + q);
        box_rows(sums + sp, fresh + sp, input(k, p, i0 - r - 1), his.data(), lows.data(), outp.data(), flags,
                 wins.data(), 2 * r + 1, n, w, alpha, norm);
      }
      produced[k] = i0 + n - 1;
    }
  };

  thread_local std::vector<const float*> out_rows, raw_rows;
  out_rows.resize(nplanes);
  raw_rows.resize(np);
  for (int p = 0; p < nplanes; ++p) out_rows[p] = outs + static_cast<std::size_t>(p) * row;
  for (int y = passes > 0 ? produced[passes - 1] + 1 : y0; y < y1; ++y) {
    if (passes > 0) {
      // The last pass runs a group ahead (its rows wait in `last`), up to the band's end.
      if (produced[passes - 1] < y) need(need, passes - 1, std::min(y + group - 1, y1 - 1));
      for (int p = 0; p < np; ++p) raw_rows[p] = output(passes - 1, p, y);
    } else {
      need(need, 0, y);  // no vertical pass: the weighted rows themselves
      for (int p = 0; p < np; ++p) {
        const float* in = input(0, p, y);
        float* o = last + static_cast<std::size_t>(p) * row;
        std::copy(in, in + w, o);
        raw_rows[p] = o;
      }
    }
    if (y < y0) continue;  // warm-up row of the band
    if (!normalise) {
      sink(ctx, y, raw_rows.data());
      continue;
    }
    const float* wt = raw_rows[nplanes];
    for (int p = 0; p < nplanes; ++p)
      normalise_row(raw_rows[p], wt, src[p] + static_cast<std::size_t>(y) * w, outs + static_cast<std::size_t>(p) * row,
                    w, tiny);
    sink(ctx, y, out_rows.data());
  }
}

// Point form. One pass maps a line v to out_m = norm · Σ_{|t| <= r + 1} w_t · v[clamp(m + t)]
// (w_t = 1 for |t| <= r, alpha at |t| = r + 1): a matrix B with entries >= 0, so output i of
// the cascade B_P ⋯ B_1 is the row e_iᵀ B_P ⋯ B_1, found by applying the transposes to e_i
// (g ← Bᵀ g scatters g_m · norm · w_t onto clamp(m + t)); its support lies in [i − R, i + R],
// R = P (r + 1), clamped to the line. Both axes' rows are non-negative, so the double sums
// below add terms of one sign per plane for the weights and have no cancellation beyond the
// signs of the colour itself: the bound stated in the header (contrast the running sums,
// whose error is a residue of values that have left the window).
namespace {

/// Weights of output i of the P-pass cascade on a line of n samples: k[j − lo] for source
/// sample j in [lo, lo + size).
void cascade_row(int n, int i, int r, double alpha, int passes, std::vector<double>& k, std::vector<double>& t,
                 int& lo) {
  const int reach = passes * (r + 1);
  lo = std::max(0, i - reach);
  const int hi = std::min(n - 1, i + reach);
  const int size = hi - lo + 1;
  k.assign(static_cast<std::size_t>(size), 0.0);
  t.assign(static_cast<std::size_t>(size), 0.0);
  const double norm = 1.0 / (2.0 * r + 1.0 + 2.0 * alpha);
  k[static_cast<std::size_t>(i - lo)] = 1.0;
  // g's support before the transpose of pass q (counted from the last): i ± q (r + 1).
  for (int q = 0; q < passes; ++q) {
    const int m0 = std::max(0, i - q * (r + 1)), m1 = std::min(n - 1, i + q * (r + 1));
    std::fill(t.begin(), t.end(), 0.0);
    for (int m = m0; m <= m1; ++m) {
      const double g = k[static_cast<std::size_t>(m - lo)] * norm;
      if (g == 0.0) continue;
      for (int d = -r - 1; d <= r + 1; ++d) {
        const double wt = (d == -r - 1 || d == r + 1) ? alpha : 1.0;
        if (wt == 0.0) continue;
        const int j = m + d < 0 ? 0 : (m + d >= n ? n - 1 : m + d);
        t[static_cast<std::size_t>(j - lo)] += g * wt;
      }
    }
    std::swap(k, t);
  }
}

}  // namespace

void weighted_gaussian_at(const float* const* src, int nplanes, const float* c, int w, int h, float sigma, int passes,
                          int x, int y, double* out) {
  for (int k = 0; k <= nplanes; ++k) out[k] = 0.0;
  const std::size_t at = static_cast<std::size_t>(y) * w + x;
  if (!(sigma > 0) || passes <= 0) {  // no blur: the weighted sample itself
    for (int k = 0; k < nplanes; ++k) out[k] = static_cast<float>(c[at] * src[k][at]);
    out[nplanes] = c[at];
    return;
  }
  int r = 0;
  float alpha = 0.0f;
  extended_box_params(sigma, passes, r, alpha);
  thread_local std::vector<double> kx, ky, tmp, row;
  int x0 = 0, y0 = 0;
  cascade_row(w, x, r, alpha, passes, kx, tmp, x0);
  cascade_row(h, y, r, alpha, passes, ky, tmp, y0);
  row.assign(static_cast<std::size_t>(nplanes) + 1, 0.0);
  for (std::size_t j = 0; j < ky.size(); ++j) {
    const std::size_t o = (static_cast<std::size_t>(y0) + j) * w + x0;
    const float* cr = c + o;
    std::fill(row.begin(), row.end(), 0.0);
    for (std::size_t i = 0; i < kx.size(); ++i) {
      const double wx = kx[i];
      row[nplanes] += wx * cr[i];
      for (int k = 0; k < nplanes; ++k) row[k] += wx * static_cast<float>(cr[i] * src[k][o + i]);
    }
    for (int k = 0; k <= nplanes; ++k) out[k] += ky[j] * row[k];
  }
}

}  // namespace dofkit::core
