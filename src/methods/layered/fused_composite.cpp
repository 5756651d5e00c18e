// Composite pass of the fused stack: one per non-empty layer (oracle: composite.cpp's
// Accumulator — over(), then the 2×2 / 4×4 box of reduce_and_blur — with the layer from
// matting.cpp and inpaint.cpp; tests/layered compare whole renders with impl=plain bit for
// bit). Inputs: the layer generator (FusedLayer), the accumulator so far (AccRows: full
// resolution or reduced, up-sampled on the fly); output: C = L over A (or A over L) at the
// resolution of the blur that follows, and the next layer's push-pull levels 1 and 2 pulled
// from the same input rows (NextPull).
#include <algorithm>
#include <atomic>
#include <memory>

#include "core/parallel.hpp"
#include "methods/layered/fast_push_pull.hpp"
#include "methods/layered/fused_passes.hpp"
#include "methods/layered/fused_simd.hpp"

namespace dofkit::detail::layered {

namespace {
// Band blocks of composite passes written as +0 without computing them (see zero_block).
std::atomic<std::uint64_t> zero_blocks{0};
}  // namespace

std::uint64_t zero_block_count() { return zero_blocks.load(); }

void fused_row(const FusedLayer& L, RowBlock rb, HCache& fill_cache, const AccInput& acc, bool front,
               float (*c)[kBlock]) {
  const int y = rb.y, x0 = rb.x0, n = rb.n;
  const int k = L.k;
  const std::size_t bi = static_cast<std::size_t>(y) * L.nb + x0 / kBlock;
  const std::size_t base = static_cast<std::size_t>(y) * L.w + x0;
  CrowRow r;
  r.code = L.code + base;
  r.w0 = L.w0 + base;
  for (int ch = 0; ch < 4; ++ch) r.in[ch] = L.color->row(ch, y) + x0;
  r.k = k;
  const std::pair<int, int> sp = L.span(y, x0, n);
  int a0 = n, a1 = 0;
  if (L.fill) {
    const int hmin = static_cast<int>(L.bhk[bi] & 255u), hmax = static_cast<int>(L.bhk[bi] >> 8);
    if (k >= hmax) {
      a0 = 0;
      a1 = n;
    } else if (k >= hmin) {
      const std::uint32_t hs = L.bhole[16 * bi + static_cast<std::size_t>(k)];
      a0 = static_cast<int>(hs & 0xffffu);
      a1 = static_cast<int>(hs >> 16);
    }
  }
  const float* const* ft = kZeroRows;
  const float* const* fb = kZeroRows;
  r.fty = 0.0f;
  if (a1 > a0) {
    if (fill_cache.img != L.l1 || fill_cache.x0 != x0) fill_cache.reset(L.l1, 2, x0);
    fill_cache.rows(y, n, ft, fb, r.fty);
  }
  r.opaque = L.opaque;
  r.under = L.under;
  const float* const* at = kZeroRows;
  const float* const* ab = kZeroRows;
  r.aty = 0.0f;
  r.am = acc.mode;
  if (acc.mode == 2) {
    HCache& cache = *acc.cache;
    if (cache.img != acc.half || cache.x0 != x0) cache.reset(acc.half, acc.factor, x0, acc.zm);
    cache.rows(y, n, at, ab, r.aty);
  }
  // Rows of the HCaches or kZeroRows: channel ch at + ch·kRowStride, as crow_row_simd reads them.
  r.ft = ft[0];
  r.fb = fb[0];
  r.at = at[0];
  r.ab = ab[0];
  r.front = front;
  crow_row_simd(r, n, sp.first, sp.second, a0, a1, c);
}

namespace {

// A band task's buffers.
struct Scratch {
  float rows[4][4][kBlock];
  float tmp[4][kBlock];
  float pr[2][4][kBlock];
  std::uint8_t phb[2][kBlock];
  float qacc[4 * (kBlock / 4)];  // lerp_quads_acc_simd's partial 4×4 sums
  HCache* acc;                   // nbc caches of A's rows, one per column block
  HCache* fill;                  // nbc caches of the fill's pyramid level
};

// One composite pass, band by band: bands of 4 full-resolution rows, column block by column
// block, each block one of three cases (zero_block, reduced_only_block, general_block); then
// the next layer's coarse rows 2b, 2b + 1 from the same input rows (pull_next).
class CompositeBands {
 public:
  explicit CompositeBands(const CompositeStep& step)
      : L(step.layer),
        A(step.acc),
        front(step.layer_in_front),
        dst(step.dst),
        next(step.next),
        w(L.w),
        h(L.h),
        hh((h + 1) / 2) {}

  // Band b (rows 4b … 4b + 3, clamped to the image), every column block; counts the blocks
  // written as +0 into zero_count.
  void band(int b, Scratch& s, std::uint64_t& zero_count) const {
    int ys[4];
    for (int dy = 0; dy < 4; ++dy) ys[dy] = std::min(4 * b + dy, h - 1);
    for (int x0 = 0; x0 < w; x0 += kBlock) {
      const int n = std::min(kBlock, w - x0);
      const bool azero = A.present() && A.zero(ys[0], ys[3], x0);
      const bool layer_empty = empty(ys[0], x0) && empty(ys[1], x0) && empty(ys[2], x0) && empty(ys[3], x0);
      if ((!A.present() || azero) && layer_empty) {
        ++zero_count;
        zero_block(b, x0, n);
      } else if (A.half && !azero && !dst.full && n % (dst.quarter ? 4 : 2) == 0 && layer_empty) {
        reduced_only_block(b, ys, x0, n, s);
      } else {
        general_block(b, ys, x0, n, s, azero);
      }
    }
    if (next.L) pull_next(b, s);
  }

 private:
  // Layer k is 0 in row y of block x0 (known empty, or all holes without a fill).
  bool empty(int y, int x0) const {
    const FusedLayer::Cls cl = L.cls(y, x0);
    return cl == FusedLayer::kEmptyKnown || (cl == FusedLayer::kEmptyHole && !L.fill);
  }

  // A row of a block where layer k is not known empty, in one kernel (fused_row).
  void crow_fused(int y, int x0, int n, float (*c)[kBlock], Scratch& s, bool azero) const {
    AccInput acc;
    acc.mode = !A.present() ? 0 : (azero ? 1 : 2);
    acc.cache = &s.acc[x0 / kBlock];
    acc.half = A.half;
    acc.factor = A.factor;
    acc.zm = A.zm;
    fused_row(L, {y, x0, n}, s.fill[x0 / kBlock], acc, front, c);
  }

  // Row y of the composite C into c. azero: A's rows here are known to be +0 (ZeroMap): they
  // are taken as rows of +0 instead of being up-sampled (the same values, see ZeroMap).
  void crow(int y, int x0, int n, float (*c)[kBlock], Scratch& s, bool azero) const {
    if (empty(y, x0)) {
      // L = 0 here: 0 over A = A and A over 0 = A (exactly, up to the sign of a zero).
      if (!A.present() || azero) {
        for (int ch = 0; ch < 4; ++ch) std::fill(c[ch], c[ch] + n, 0.0f);
        return;
      }
      const float* a[4];
      A.get(y, x0, n, c, a, &s.acc[x0 / kBlock]);
      for (int ch = 0; ch < 4; ++ch)
        if (a[ch] != c[ch]) std::copy(a[ch], a[ch] + n, c[ch]);
      return;
    }
    if (!A.full && (!L.fill || L.l1)) {  // the fused row (kern::crow_row), same values
      crow_fused(y, x0, n, c, s, azero);
      return;
    }
    L.get(y, x0, n, c, &s.fill[x0 / kBlock]);
    if (!A.present()) return;
    if (azero) {
      kern::over_rows(c, kZeroRows, front, n);
      return;
    }
    const float* a[4];
    A.get(y, x0, n, s.tmp, a, &s.acc[x0 / kBlock]);
    kern::over_rows(c, a, front, n);
  }

  // An empty layer over (or under) +0: the composite is +0, and so are its 2×2 and 4×4 box
  // means (0.25 · (+0 + … + +0) = +0).
  void zero_block(int b, int x0, int n) const {
    float* d[4];
    if (dst.full) {
      for (int dy = 0; dy < 4 && 4 * b + dy < h; ++dy) {
        for (int ch = 0; ch < 4; ++ch) d[ch] = dst.full->row(ch, 4 * b + dy) + x0;
        kern::fill_rows(d, 4, n, 0.0f);
      }
    } else if (dst.quarter) {
      for (int ch = 0; ch < 4; ++ch) d[ch] = dst.quarter->row(ch, b) + x0 / 4;
      kern::fill_rows(d, 4, (x0 + n + 3) / 4 - x0 / 4, 0.0f);
    } else {
      for (int yh = 2 * b; yh < std::min(2 * b + 2, hh); ++yh) {
        for (int ch = 0; ch < 4; ++ch) d[ch] = dst.half->row(ch, yh) + x0 / 2;
        kern::fill_rows(d, 4, (x0 + n + 1) / 2 - x0 / 2, 0.0f);
      }
    }
  }

  // An empty layer over a reduced accumulator that is not +0 here (a quarter of the band
  // blocks on the bench frame): every row is A's up-sampling (crow's A.get, the vertical lerp
  // of the cached rows), and the 2×2 / 4×4 box reads it straight from the lerps in the same
  // kernel (lerp_quads_acc_simd / lerp_pairs_box_simd: the same lerps and the same sums in the
  // same order as lerp_rows4 then down_quads_simd / down_pairs), instead of storing the four
  // rows first. The caller ensures n is a multiple of the box width, so there is no clamped
  // last output (general_block takes the rest).
  void reduced_only_block(int b, const int ys[4], int x0, int n, Scratch& s) const {
    HCache& ac = s.acc[x0 / kBlock];
    if (ac.img != A.half || ac.x0 != x0) ac.reset(A.half, A.factor, x0, A.zm);
    const bool exact = A.tiny(ys[0], ys[3], x0);
    if (dst.quarter) {
      const int m = n / 4;
      for (int dy = 0; dy < 4; ++dy) {  // rows in order: the sums' order (see lerp_quads_acc_simd)
        const float* const* top;
        const float* const* bot;
        float ty;
        ac.rows(ys[dy], n, top, bot, ty);
        lerp_quads_acc_simd(top[0], bot[0], ty, m, dy == 0, s.qacc, exact);
      }
      for (int ch = 0; ch < 4; ++ch) {
        float* d = dst.quarter->row(ch, b) + x0 / 4;
        const float* q = s.qacc + (kBlock / 4) * ch;
        for (int x = 0; x < m; ++x) d[x] = 0.0625f * q[x];
      }
      return;
    }
    for (int yh = 2 * b; yh < std::min(2 * b + 2, hh); ++yh) {
      const int da = 2 * (yh - 2 * b);  // rows 2yh and min(2yh + 1, h − 1) of the band
      const float* const* ta;
      const float* const* ba;
      const float* const* tb;
      const float* const* bb;
      float tya, tyb;
      // The second row's cache lookup may replace an entry, not the first row's
      // (HCache::row: rows asked in increasing order; the pointers are read before).
      ac.rows(ys[da], n, ta, ba, tya);
      const float* a0 = ta[0];
      const float* a1 = ba[0];
      ac.rows(ys[da + 1], n, tb, bb, tyb);
      float* d[4];
      for (int ch = 0; ch < 4; ++ch) d[ch] = dst.half->row(ch, yh) + x0 / 2;
      lerp_pairs_box_simd(a0, a1, tya, tb[0], bb[0], tyb, n / 2, d, exact);
    }
  }

  // The general case: the composite of the band's rows (crow; a row repeated at the bottom
  // edge is computed once), then stored at the destination's resolution.
  void general_block(int b, const int ys[4], int x0, int n, Scratch& s, bool azero) const {
    int src[4];  // which of s.rows holds band row dy
    for (int dy = 0; dy < 4; ++dy) {
      src[dy] = dy;
      if (dy > 0 && ys[dy] == ys[dy - 1])
        src[dy] = src[dy - 1];
      else
        crow(ys[dy], x0, n, s.rows[dy], s, azero);
    }
    if (dst.full)
      store_full(b, x0, n, s);
    else if (dst.quarter)
      box_quarter(b, x0, n, s, src);
    else
      box_half(b, x0, n, s, src);
  }

  void store_full(int b, int x0, int n, const Scratch& s) const {
    for (int dy = 0; dy < 4 && 4 * b + dy < h; ++dy)
      for (int ch = 0; ch < 4; ++ch) std::copy(s.rows[dy][ch], s.rows[dy][ch] + n, dst.full->row(ch, 4 * b + dy) + x0);
  }

  // composite.cpp's 4×4 box of the band's rows into quarter row b.
  void box_quarter(int b, int x0, int n, const Scratch& s, const int src[4]) const {
    Image& q = *dst.quarter;
    const int m = n / 4;  // quads inside the block (x0 is a multiple of 4)
    for (int ch = 0; ch < 4; ++ch) {
      const float* r[4];
      for (int dy = 0; dy < 4; ++dy) r[dy] = s.rows[src[dy]][ch];
      float* d = q.row(ch, b);
      down_quads_simd(r[0], r[1], r[2], r[3], m, d + x0 / 4);
      for (int xq = x0 / 4 + m; xq < (x0 + n + 3) / 4; ++xq) {
        float sum = 0.0f;
        for (int dy = 0; dy < 4; ++dy)
          for (int dx = 0; dx < 4; ++dx) sum += r[dy][std::min(4 * xq + dx, w - 1) - x0];
        d[xq] = 0.0625f * sum;
      }
    }
  }

  // composite.cpp's 2×2 box of the band's rows into half rows 2b, 2b + 1.
  void box_half(int b, int x0, int n, const Scratch& s, const int src[4]) const {
    Image& half = *dst.half;
    for (int yh = 2 * b; yh < std::min(2 * b + 2, hh); ++yh) {
      const int da = 2 * (yh - 2 * b);  // rows 2yh and min(2yh + 1, h − 1) of the band
      for (int ch = 0; ch < 4; ++ch) {
        const float* pa = s.rows[src[da]][ch];
        const float* pb = s.rows[src[da + 1]][ch];
        float* d = half.row(ch, yh);
        const int m = n / 2;  // pairs inside the block (x0 is even)
        kern::down_pairs(pa, pb, m, d + x0 / 2);
        for (int xh = x0 / 2 + m; xh < (x0 + n + 1) / 2; ++xh) {
          const int xa = 2 * xh - x0, xb = std::min(2 * xh + 1, w - 1) - x0;
          d[xh] = 0.25f * (pa[xa] + pa[xb] + pb[xa] + pb[xb]);
        }
      }
    }
  }

  // The next layer's pyramid rows that this band's input rows feed.
  void pull_next(int b, Scratch& s) const {
    for (int yc = 2 * b; yc < std::min(2 * b + 2, hh); ++yc)
      pull_row(*next.L, yc, *next.cv, *next.cwt, s.pr, s.phb, next.cv2 != nullptr);
    // Level 2's row b reads level 1's rows 2b, 2b + 1: those just written (level 2 has
    // (hh + 1) / 2 = bands rows).
    if (next.cv2) pull_upper_row(*next.cv, *next.cwt, *next.cv2, *next.cwt2, b);
  }

  const FusedLayer& L;
  const AccRows& A;
  bool front;  // layer in front of the accumulator (L over A)
  CompositeTarget dst;
  NextPull next;
  int w, h, hh;
};

}  // namespace

void composite_pass(const CompositeStep& step) {
  const CompositeBands pass(step);
  // Per column block, caches of the horizontally up-sampled coarse rows of A and of the
  // fill's pyramid level: kept across the bands of a task, so a coarse row shared by
  // neighbouring bands is up-sampled once per task (was once per band: 2–3 times).
  const int nbc = (step.layer.w + kBlock - 1) / kBlock;
  const int bands = (step.layer.h + 3) / 4;
  core::parallel_for(
      bands,
      [&](int b0, int b1) {
        // Default-initialised (new T, not make_unique): only the caches set their keys; the
        // buffers are written before they are read; zeroing ~60 KB per band task cost ~36 M
        // instructions per 1080p render.
        std::unique_ptr<Scratch> sp(new Scratch);
        Scratch& s = *sp;
        std::unique_ptr<HCache[]> caches(new HCache[2 * nbc]);
        s.acc = caches.get();
        s.fill = caches.get() + nbc;
        // Counted per task and added once (an atomic add per block bounced the counter's cache
        // line between the two cores).
        std::uint64_t task_zero_blocks = 0;
        for (int b = b0; b < b1; ++b) pass.band(b, s, task_zero_blocks);
        if (task_zero_blocks) zero_blocks.fetch_add(task_zero_blocks, std::memory_order_relaxed);
      },
      1);
}

}  // namespace dofkit::detail::layered
