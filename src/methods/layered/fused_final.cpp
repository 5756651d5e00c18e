// Final composite of the fused stack (oracle: final_composite, i.e. composite.cpp's two
// "over"s, with the focus layer from matting.cpp and inpaint.cpp; tests/layered compare whole
// renders with impl=plain bit for bit). Inputs: the focus layer's generator (or none) and the
// far (B) and near (F) accumulators at whatever resolution they hold; output: I = F over
// L_focus over B at full resolution. Bands of 4 rows, column block by column block, so the
// horizontally up-sampled coarse rows of B, F and the focus layer's fill are computed once per
// band (HCache), not twice per fine row.
#include <algorithm>
#include <memory>

#include "core/parallel.hpp"
#include "methods/layered/fused_passes.hpp"
#include "methods/layered/fused_simd.hpp"

namespace dofkit::detail::layered {

namespace {

struct FinalScratch {
  float fb[4][kBlock], bb[4][kBlock];
  float cur[4][kBlock];
};

// Caches per column block (nb of each), kept across the bands of a task (as in composite_pass).
struct FinalCaches {
  HCache* focus;
  HCache* back;
  HCache* front;
};

// The focus layer's row y of block x0 into cur (zeros without a focus layer).
void focus_row(const FusedLayer* Lf, int y, int x0, int n, HCache& cache, float (*cur)[kBlock]) {
  if (Lf && (!Lf->fill || Lf->l1))
    fused_row(*Lf, {y, x0, n}, cache, AccInput(), true, cur);
  else if (Lf)
    Lf->get(y, x0, n, cur, &cache);
  else
    for (int c = 0; c < 4; ++c) std::fill(cur[c], cur[c] + n, 0.0f);
}

// Both accumulators reduced (or absent): cur over B, then F over that, with their
// up-sampling's vertical lerp in the same kernel (final_row_simd; rows of +0 where a zero map
// says so).
void final_row_reduced(const AccRows& BR, const AccRows& FR, int y, int x0, int n, HCache& bcache, HCache& fcache,
                       const float (*cur)[kBlock], float* const* o) {
  FinalRow fr;
  fr.c = cur[0];  // cur, the caches' rows and kZeroRows: channels kRowStride apart
  auto side = [&](const AccRows& R, HCache& cache, int& mode, const float*& top, const float*& bot, float& ty) {
    ty = 0.0f;
    mode = R.present() ? 1 : 0;
    const float* const* a = kZeroRows;
    const float* const* b = kZeroRows;
    if (R.present() && !R.zero(y, y, x0)) {
      if (cache.img != R.half || cache.x0 != x0) cache.reset(R.half, R.factor, x0, R.zm);
      cache.rows(y, n, a, b, ty);
      mode = 2;
    }
    top = a[0];
    bot = b[0];
  };
  side(BR, bcache, fr.bm, fr.bt, fr.bb, fr.bty);
  side(FR, fcache, fr.fm, fr.ft, fr.fb, fr.fty);
  fr.exact = (fr.bm == 2 && BR.tiny(y, y, x0)) || (fr.fm == 2 && FR.tiny(y, y, x0));
  final_row_simd(fr, n, o);
}

// An accumulator at full resolution: cur over B, then F over that (rows of +0 where a zero map
// says so), channel by channel.
void final_row_general(const AccRows& BR, const AccRows& FR, int y, int x0, int n, HCache& bcache, HCache& fcache,
                       FinalScratch& s, float* const* o) {
  const float* back[4] = {kZeroRow, kZeroRow, kZeroRow, kZeroRow};
  const float* front[4] = {kZeroRow, kZeroRow, kZeroRow, kZeroRow};
  if (BR.present() && !BR.zero(y, y, x0)) BR.get(y, x0, n, s.bb, back, &bcache);
  if (FR.present() && !FR.zero(y, y, x0)) FR.get(y, x0, n, s.fb, front, &fcache);
  float t[kBlock], u[kBlock];
  kern::one_minus(s.cur[3], n, t);
  if (FR.present()) kern::one_minus(front[3], n, u);
  for (int c = 0; c < 4; ++c)
    kern::final_channel(s.cur[c], t, BR.present() ? back[c] : nullptr, u, FR.present() ? front[c] : nullptr, n, o[c]);
}

}  // namespace

void final_pass(const FusedLayer* Lf, const AccRows& BR, const AccRows& FR, Image& out) {
  const int w = out.width(), h = out.height();
  const int nbf = (w + kBlock - 1) / kBlock;
  core::parallel_for((h + 3) / 4,
                     [&](int b0, int b1) {
                       std::unique_ptr<FinalScratch> sp(new FinalScratch);  // default-initialised (see composite_pass)
                       std::unique_ptr<HCache[]> caches(new HCache[3 * nbf]);
                       const FinalCaches fc{caches.get(), caches.get() + nbf, caches.get() + 2 * nbf};
                       FinalScratch& s = *sp;
                       for (int b = b0; b < b1; ++b)
                         for (int x0 = 0; x0 < w; x0 += kBlock)
                           for (int y = 4 * b; y < std::min(h, 4 * b + 4); ++y) {
                             const int n = std::min(kBlock, w - x0);
                             const int bi = x0 / kBlock;
                             focus_row(Lf, y, x0, n, fc.focus[bi], s.cur);
                             float* o[4];
                             for (int c = 0; c < 4; ++c) o[c] = out.row(c, y) + x0;
                             if (!BR.full && !FR.full)
                               final_row_reduced(BR, FR, y, x0, n, fc.back[bi], fc.front[bi], s.cur, o);
                             else
                               final_row_general(BR, FR, y, x0, n, fc.back[bi], fc.front[bi], s, o);
                           }
                     },
                     1);
}

}  // namespace dofkit::detail::layered
