// SIMD (Highway, run-time dispatch) and plain versions of the disc-scatter band loop; see
// scatter_band.hpp and disc_scatter.cpp for the maths. Per receiver both compute
//   cov = sat(ρ_q − |p − q| + 0.5),  w = cov · wscale_q,
//   rel = (u_q − u_p)·isu_p,  front = sat(rel),  behind = sat(−rel),
//   pass = min(sharp_p / sharp_q, 1),  w *= 1 − behind·(1 − pass),
// and add w·front to F and w·(1 − front) to B.
#include "methods/reference/scatter_band.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "methods/reference/scatter_band.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace dofkit::detail {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// Receiver-major inside a block: the sources of one block (kSourceBlock consecutive pixels
// of a row) that reach receiver row py are collected first; then every receiver vector of
// their joint span loads its ten accumulators once, adds the block's sources in order and
// stores them once. Per (source, receiver vector) pair that leaves ~26 vector operations and
// one table load (|p − q| comes from a table: the offsets are integers), instead of ten
// accumulator loads and stores per pair. Each receiver still adds its sources in the order of
// the plain loop (row by row, left to right), so the sums differ from it only by rounding.
// kGeneral: an aperture other than the circle (job.model): the table holds the model's gauge per
// field (or an aperture image's rasters come from job.bank), spans use the bounding circle
// |p| < lim (the gauge is >= |p|), and the cat's eye (job.eye_x) clips each footprint by its
// second circle.
template <bool kDepthOrder, bool kGeneral>
void ScatterBandT(const BandJob& job) {
  const hn::ScalableTag<float> d;
  const int lanes = static_cast<int>(hn::Lanes(d));
  constexpr int S = kSourceBlock;
  const int w = job.w;
  const int nblk = (w + S - 1) / S;
  const auto zero = hn::Zero(d), one = hn::Set(d, 1.0f), neg_one = hn::Set(d, -1.0f);
  const float front_scale = (1.0f + job.softness) * (1.0f + 4e-6f);
  const int sy0 = std::max(0, job.y0 - job.reach), sy1 = std::min(job.h, job.y1 + job.reach);
  // The sources of the current block that reach the band, and their spans on the current
  // receiver row (lo > hi: not on this row).
  constexpr int kNever = 1 << 29;  // an empty span: lo = kNever, hi = −kNever
  const hn::RebindToSigned<decltype(d)> di;
  HWY_ALIGN float s_lim[S] = {}, s_ws[S] = {}, s_uq[S] = {}, s_isq[S] = {}, s_c0[S] = {}, s_c1[S] = {}, s_c2[S] = {},
                  s_c3[S] = {};
  HWY_ALIGN int32_t s_qx[S] = {}, s_ext[S] = {}, s_off[S] = {}, s_lo[S] = {}, s_hi[S] = {}, s_ilo[S] = {},
                    s_ihi[S] = {};
  // kGeneral: span radius (the model's bounding circle), interior radius (< 0: none), field,
  // bucket, cat's-eye offset and rho + 0.5; per row: the table row and (dy − oy)².
  HWY_ALIGN float s_out[S] = {}, s_in[S] = {}, s_ox[S] = {}, s_oy[S] = {}, s_r5[S] = {}, s_ey2[S] = {};
  int s_field[S] = {}, s_bk[S] = {};
  const float* s_tab[S] = {};
  const core::ApertureModel* model = job.model;
  const bool image = kGeneral && job.bank != nullptr;
  const bool eye = kGeneral && job.eye_x != nullptr;
  const float inv_inner = kGeneral ? 1.0f / model->inner_scale() : 1.0f;
  const auto vratio = hn::Set(d, kGeneral ? static_cast<float>(model->shape().anamorphic) : 1.0f);
  const auto iota_i = hn::Iota(di, 0);
  const std::size_t field_rows = static_cast<std::size_t>(2 * job.reach + 1);
  static_assert(S <= 64, "source bits are kept in 64-bit masks");
  const auto mask_bits = [](auto tag, auto mask) {
    std::uint8_t bytes[8] = {};
    hn::StoreMaskBits(tag, mask, bytes);
    std::uint64_t v = 0;
    for (int k = 7; k >= 0; --k) v = (v << 8) | bytes[k];
    return v;
  };
  for (int qy = sy0; qy < sy1; ++qy) {
    const int* bext = job.block_ext + static_cast<std::size_t>(qy) * nblk;
    for (int b = 0; b < nblk; ++b) {
      const int e = bext[b];
      const int pyA = std::max(job.y0, qy - e), pyB = std::min(job.y1 - 1, qy + e);
      if (pyA > pyB) continue;  // no source of this block reaches the band
      const int qx0 = b * S, qx1 = std::min(w, qx0 + S);
      int m = 0;
      for (int qx = qx0; qx < qx1; ++qx) {
        const std::size_t q = static_cast<std::size_t>(qy) * w + qx;
        const int ex = job.ext[q];
        if (qy + ex < job.y0 || qy - ex >= job.y1) continue;
        s_qx[m] = qx;
        s_ext[m] = ex;
        s_off[m] = job.dist_half - qx;
        s_lim[m] = job.rho[q] + 0.5f;
        s_ws[m] = job.wscale[q];
        s_uq[m] = job.inv_z[q];
        const float sq = job.sharp[q];
        s_isq[m] = sq > 0 ? 1.0f / sq : 1e30f;
        s_c0[m] = job.colour[0][q];
        s_c1[m] = job.colour[1][q];
        s_c2[m] = job.colour[2][q];
        s_c3[m] = job.colour[3][q];
        if constexpr (kGeneral) {
          const float rq = job.rho[q];
          s_lim[m] = model->lim(rq);  // T >= |p|: the footprint lies in |p| < lim
          s_out[m] = s_lim[m] + 1e-3f;
          s_in[m] = image || eye ? -1.0f : (s_lim[m] - 1.001f) * inv_inner;
          s_field[m] = static_cast<int>(core::field_of(job.coc[q]));
          if (image) s_bk[m] = job.bucket[q];
          if (eye) {
            s_ox[m] = job.eye_x[q];
            s_oy[m] = job.eye_y[q];
            s_r5[m] = rq + 0.5f;
          }
        }
        ++m;
      }
      for (int i = m; i < S; ++i) {  // unused slots: never active
        s_ext[i] = -1;
        s_qx[i] = 0;
        s_lim[i] = 0.0f;
        s_out[i] = 0.0f;
        s_in[i] = -1.0f;
      }
      for (int py = pyA; py <= pyB; ++py) {
        const int dy = py - qy, ady = dy < 0 ? -dy : dy;
        // Spans of all slots on this row, a vector of slots at a time (as the plain loop:
        // half-width floor(sqrt(max(0, lim² − dy²)))).
        const auto vady = hn::Set(di, ady);
        const auto vdy2 = hn::Set(d, static_cast<float>(dy * dy));
        const auto never = hn::Set(di, kNever), neg_never = hn::Set(di, -kNever), wlast = hn::Set(di, w - 1);
        auto vlo = never, vhi = neg_never;
        for (int i = 0; i < m; i += lanes) {
          const auto lim = hn::Load(d, (kGeneral ? s_out : s_lim) + i);
          const auto hw = hn::ConvertTo(di, hn::Sqrt(hn::Max(hn::Sub(hn::Mul(lim, lim), vdy2), zero)));
          const auto qx = hn::Load(di, s_qx + i);
          const auto active = hn::Not(hn::Lt(hn::Load(di, s_ext + i), vady));
          const auto slo = hn::IfThenElse(active, hn::Max(hn::Sub(qx, hw), hn::Zero(di)), never);
          const auto shi = hn::IfThenElse(active, hn::Min(hn::Add(qx, hw), wlast), neg_never);
          hn::Store(slo, di, s_lo + i);
          hn::Store(shi, di, s_hi + i);
          // Interior [ilo, ihi], where the coverage is exactly 1: |dx| ≤ floor(sqrt(li² − dy²))
          // with li = lim − 1.001. The float error of li² − dy² moves a lattice point's
          // distance by at most ~li·1e-7 px, far inside the 1e-3 px margin, so lim − |p − q| ≥ 1
          // holds in float there. ihi = kNever where the interior reaches the row end (the
          // lanes past it are padding).
          const auto li = kGeneral ? hn::Load(d, s_in + i) : hn::Sub(lim, hn::Set(d, 1.001f));
          const auto inner = hn::And(active, hn::RebindMask(di, hn::Gt(li, hn::ConvertTo(d, vady))));
          const auto hwi = hn::ConvertTo(di, hn::Sqrt(hn::Max(hn::Sub(hn::Mul(li, li), vdy2), zero)));
          const auto ihi = hn::Add(qx, hwi);
          hn::Store(hn::IfThenElse(inner, hn::Max(hn::Sub(qx, hwi), hn::Zero(di)), never), di, s_ilo + i);
          hn::Store(hn::IfThenElse(inner, hn::IfThenElse(hn::Lt(ihi, wlast), ihi, never), neg_never), di, s_ihi + i);
          vlo = hn::Min(vlo, slo);
          vhi = hn::Max(vhi, shi);
        }
        int lo = hn::GetLane(hn::MinOfLanes(di, vlo)), hi = hn::GetLane(hn::MaxOfLanes(di, vhi));
        if constexpr (kGeneral) {
          if (image)
            for (int i = m; i < S; ++i) {  // unused slots (read by the vector loops below): never active
              s_lo[i] = s_ilo[i] = kNever;
              s_hi[i] = s_ihi[i] = -kNever;
            }
          if (image) {
            // The rasters' exact row extents replace the bounding circle's.
            lo = kNever;
            hi = -kNever;
            for (int i = 0; i < m; ++i) {
              const core::Span sp =
                  ady > s_ext[i] ? core::Span{} : job.bank->row_span(s_bk[i], core::Field(s_field[i]), dy);
              if (sp.empty() || s_qx[i] + sp.x1 < 0 || s_qx[i] + sp.x0 > w - 1) {
                s_lo[i] = kNever;
                s_hi[i] = -kNever;
                continue;
              }
              s_lo[i] = std::max(s_qx[i] + sp.x0, 0);
              s_hi[i] = std::min(s_qx[i] + sp.x1, w - 1);
              lo = std::min(lo, s_lo[i]);
              hi = std::max(hi, s_hi[i]);
            }
          }
          if (lo > hi) continue;
          for (int i = 0; i < m; ++i) {
            const core::Field f = core::Field(s_field[i]);
            if (image) {
              const int b = s_bk[i], r = job.bank->reach(b);
              s_tab[i] = ady > r ? nullptr
                                 : job.bank->raster(b, f) + static_cast<std::ptrdiff_t>(dy + r) * job.bank->pitch(b) +
                                       r - s_qx[i];
            } else {
              s_tab[i] = job.dist +
                         (static_cast<std::size_t>(dy + job.reach) + static_cast<std::size_t>(f) * field_rows) *
                             job.dist_stride +
                         job.dist_half - s_qx[i];
            }
            if (eye) {
              const float ey = static_cast<float>(dy) - s_oy[i];
              s_ey2[i] = ey * ey;
            }
          }
        }
        if (lo > hi) continue;
        const int n = m;
        const float* trow = kGeneral ? nullptr : job.dist + static_cast<std::size_t>(ady) * job.dist_stride;
        const std::size_t prow = static_cast<std::size_t>(py) * w;
        float* a[10];
        for (int k = 0; k < 10; ++k)
          a[k] = job.acc + (static_cast<std::size_t>(k) * job.band + (py - job.y0)) * job.stride;
        // Lanes outside a source's disc get cov = 0; lanes past the row end land in the
        // accumulators' padding, so no lane needs masking.
        for (int px = lo; px <= hi; px += lanes) {
          const int pxe = px + lanes - 1;
          const auto up = hn::LoadU(d, job.inv_z + prow + px);
          const auto isu = hn::LoadU(d, job.isu + prow + px);
          const auto sp = hn::LoadU(d, job.sharp + prow + px);
          auto f0 = hn::LoadU(d, a[0] + px), f1 = hn::LoadU(d, a[1] + px), f2 = hn::LoadU(d, a[2] + px);
          auto f3 = hn::LoadU(d, a[3] + px), fw = hn::LoadU(d, a[4] + px);
          auto b0 = hn::LoadU(d, a[5] + px), b1 = hn::LoadU(d, a[6] + px), b2 = hn::LoadU(d, a[7] + px);
          auto b3 = hn::LoadU(d, a[8] + px), bw = hn::LoadU(d, a[9] + px);
          // The depth relation of a source to the whole vector is often uniform (a surface
          // of one depth per row, a sky at infinity, a near bar in front of everything):
          //   u_q ≤ min u_p and (u_q ≥ max u_p or sharp_p ≥ sharp_q everywhere): rel ≤ 0
          //     and nothing is blocked (or rel = 0), so the whole weight goes to B;
          //   u_q > max u_p·(1 + softness) (slightly raised): rel ≥ 1, all of it goes to F.
          // Those pairs skip the depth terms and the other sum (which they would add 0 to).
          // Lanes past the row end only make the bounds tighter.
          float up_min = 0, up_max = 0, sp_min = 0, front_above = 0;
          if (kDepthOrder) {
            up_min = hn::GetLane(hn::MinOfLanes(d, up));
            up_max = hn::GetLane(hn::MaxOfLanes(d, up));
            sp_min = hn::GetLane(hn::MinOfLanes(d, sp));
            // 1/isu_p = softness·u_p; receivers at infinity (u_p = 0, isu_p = 1e30) need u_q ≥ 1e-30.
            front_above = std::max(up_max * front_scale, 1e-29f);
          }
          // Bit j: block source j reaches this vector (act), and which of the shortcuts
          // applies to it (tested a vector of sources at a time). Each class is then added in
          // a loop of its own, which leaves the loops free of data-dependent branches; a
          // receiver's sum thus takes its sources in class order (the plain loop: row order).
          std::uint64_t act = 0, inside = 0, all_b = 0, all_f = 0, no_behind = 0, no_front = 0;
          const auto vpx = hn::Set(di, px), vpxe = hn::Set(di, pxe);
          for (int i = 0; i < n; i += lanes) {
            const auto reach =
                hn::And(hn::Not(hn::Lt(hn::Load(di, s_hi + i), vpx)), hn::Not(hn::Gt(hn::Load(di, s_lo + i), vpxe)));
            act |= mask_bits(di, reach) << i;
            inside |= mask_bits(di, hn::And(hn::Not(hn::Gt(hn::Load(di, s_ilo + i), vpx)),
                                            hn::Not(hn::Lt(hn::Load(di, s_ihi + i), vpxe))))
                      << i;
            if (kDepthOrder) {
              const auto uq = hn::Load(d, s_uq + i);
              const auto le_min = hn::Le(uq, hn::Set(d, up_min)), ge_max = hn::Ge(uq, hn::Set(d, up_max));
              const auto passes = hn::Ge(hn::Mul(hn::Set(d, sp_min), hn::Load(d, s_isq + i)), one);
              all_b |= mask_bits(d, hn::And(le_min, hn::Or(ge_max, passes))) << i;
              all_f |= mask_bits(d, hn::Gt(uq, hn::Set(d, front_above))) << i;
              no_behind |= mask_bits(d, ge_max) << i;
              no_front |= mask_bits(d, le_min) << i;
            }
          }
          const auto weight = [&](int j) {
            if constexpr (kGeneral) {
              const auto t = hn::LoadU(d, s_tab[j] + px);
              auto cov = image ? t : hn::Min(hn::Max(hn::Sub(hn::Set(d, s_lim[j]), t), zero), one);
              if (eye) {
                // As ApertureModel::eye_coverage: ex = (dx − ox)·anamorphic, sat(rho + 0.5 − |(ex, ey)|).
                const auto dxv = hn::ConvertTo(d, hn::Add(hn::Set(di, px - s_qx[j]), iota_i));
                const auto ex = hn::Mul(hn::Sub(dxv, hn::Set(d, s_ox[j])), vratio);
                const auto dist = hn::Sqrt(hn::Add(hn::Mul(ex, ex), hn::Set(d, s_ey2[j])));
                cov = hn::Min(cov, hn::Min(hn::Max(hn::Sub(hn::Set(d, s_r5[j]), dist), zero), one));
              }
              return hn::Mul(cov, hn::Set(d, s_ws[j]));
            } else {
              const auto dist = hn::LoadU(d, trow + (px + s_off[j]));
              const auto cov = hn::Min(hn::Max(hn::Sub(hn::Set(d, s_lim[j]), dist), zero), one);
              return hn::Mul(cov, hn::Set(d, s_ws[j]));
            }
          };
          // wt·(colour, 1) into the B or the F sums.
          const auto add_b = [&](auto wt, int j) {
            b0 = hn::MulAdd(wt, hn::Set(d, s_c0[j]), b0);
            b1 = hn::MulAdd(wt, hn::Set(d, s_c1[j]), b1);
            b2 = hn::MulAdd(wt, hn::Set(d, s_c2[j]), b2);
            b3 = hn::MulAdd(wt, hn::Set(d, s_c3[j]), b3);
            bw = hn::Add(bw, wt);
          };
          const auto add_f = [&](auto wt, int j) {
            f0 = hn::MulAdd(wt, hn::Set(d, s_c0[j]), f0);
            f1 = hn::MulAdd(wt, hn::Set(d, s_c1[j]), f1);
            f2 = hn::MulAdd(wt, hn::Set(d, s_c2[j]), f2);
            f3 = hn::MulAdd(wt, hn::Set(d, s_c3[j]), f3);
            fw = hn::Add(fw, wt);
          };
          // Sources of `whole` that go wholly to one sum (`add`): those whose disc interior
          // covers the whole receiver vector (coverage 1, weight s_ws) first, then the rim.
          const auto add_whole = [&](std::uint64_t whole, const auto& add) {
            for (std::uint64_t in = whole & inside; in; in &= in - 1) {
              const int j = std::countr_zero(in);
              add(hn::Set(d, s_ws[j]), j);
            }
            for (std::uint64_t rim = whole & ~inside; rim; rim &= rim - 1) {
              const int j = std::countr_zero(rim);
              add(weight(j), j);
            }
          };
          std::uint64_t bits = kDepthOrder ? act & all_b : act;
          act &= ~bits;
          add_whole(bits, add_b);  // all to B
          bits = act & all_f;
          act &= ~bits;
          add_whole(bits, add_f);  // all to F
          bits = act & no_behind;
          act &= ~bits;
          for (; bits; bits &= bits - 1) {  // rel ≥ 0: nothing blocked
            const int j = std::countr_zero(bits);
            const auto wt = weight(j);
            const auto rel = hn::Mul(hn::Sub(hn::Set(d, s_uq[j]), up), isu);
            const auto wf = hn::Mul(wt, hn::Min(rel, one)), wb = hn::Sub(wt, wf);
            add_f(wf, j);
            add_b(wb, j);
          }
          bits = act & no_front;
          act &= ~bits;
          for (; bits; bits &= bits - 1) {  // rel ≤ 0: nothing in front
            const int j = std::countr_zero(bits);
            const auto rel = hn::Mul(hn::Sub(hn::Set(d, s_uq[j]), up), isu);
            // 1 − pass = 1 − min(sharp_p / sharp_q, 1)
            const auto blocked = hn::Max(hn::NegMulAdd(sp, hn::Set(d, s_isq[j]), one), zero);
            const auto wt = hn::Mul(weight(j), hn::MulAdd(hn::Max(rel, neg_one), blocked, one));
            add_b(wt, j);
          }
          for (bits = act; bits; bits &= bits - 1) {  // the general case
            const int j = std::countr_zero(bits);
            const auto rel = hn::Mul(hn::Sub(hn::Set(d, s_uq[j]), up), isu);
            const auto blocked = hn::Max(hn::NegMulAdd(sp, hn::Set(d, s_isq[j]), one), zero);
            const auto front = hn::Min(hn::Max(rel, zero), one);
            const auto minus_behind = hn::Max(hn::Min(rel, zero), neg_one);
            const auto wt = hn::Mul(weight(j), hn::MulAdd(minus_behind, blocked, one));
            const auto wf = hn::Mul(wt, front), wb = hn::Sub(wt, wf);
            add_f(wf, j);
            add_b(wb, j);
          }
          hn::StoreU(f0, d, a[0] + px);
          hn::StoreU(f1, d, a[1] + px);
          hn::StoreU(f2, d, a[2] + px);
          hn::StoreU(f3, d, a[3] + px);
          hn::StoreU(fw, d, a[4] + px);
          hn::StoreU(b0, d, a[5] + px);
          hn::StoreU(b1, d, a[6] + px);
          hn::StoreU(b2, d, a[7] + px);
          hn::StoreU(b3, d, a[8] + px);
          hn::StoreU(bw, d, a[9] + px);
        }
      }
    }
  }
}

// Hidden-background samples of a vector of receivers at a time (gathers); per receiver the
// same operations in the same order as the scalar loop in disc_scatter.cpp.
void HiddenRows(const HiddenJob& job, int y0, int y1) {
  const hn::ScalableTag<float> d;
  const hn::RebindToSigned<decltype(d)> di;
  const int lanes = static_cast<int>(hn::Lanes(d));
  const int w = job.w;
  const auto zero = hn::Zero(d), one = hn::Set(d, 1.0f), half = hn::Set(d, 0.5f);
  const auto wlast = hn::Set(d, static_cast<float>(w - 1)), hlast = hn::Set(d, static_cast<float>(job.h - 1));
  const auto keep = hn::Set(d, job.keep), zmin = hn::Set(d, job.min_inv_z);
  const auto vw = hn::Set(di, w);
  // clamp(lround(v), 0, last): 0 below 0.5, else trunc(v + 0.5) capped at last (see round_clamp).
  const auto round_clamp = [&](decltype(zero) v, decltype(zero) last) {
    const auto r = hn::ConvertTo(di, hn::Min(hn::Add(v, half), last));
    return hn::IfThenElseZero(hn::RebindMask(di, hn::Ge(v, half)), r);
  };
  HWY_ALIGN float out[5][64];
  for (int y = y0; y < y1; ++y) {
    const auto fy = hn::Set(d, static_cast<float>(y));
    for (int x0 = 0; x0 < w; x0 += lanes) {
      const std::size_t p = static_cast<std::size_t>(y) * w + x0;
      const int nl = std::min(lanes, w - x0);
      const auto rho = hn::LoadU(d, job.rho + p);
      const auto limit = hn::Mul(hn::LoadU(d, job.inv_z + p), keep);
      const auto active = hn::And(hn::Gt(hn::LoadU(d, job.sharp + p), zero), hn::Gt(limit, zmin));
      float* hp = job.hidden + p * 4;
      if (hn::AllFalse(d, active)) {
        for (int i = 0; i < nl; ++i) hp[i * 4 + 3] = -1.0f;
        continue;
      }
      const auto fx = hn::Add(hn::Set(d, static_cast<float>(x0)), hn::Iota(d, 0.0f));
      auto s0 = zero, s1 = zero, s2 = zero, s3 = zero, count = zero;
      for (int k = 0; k < job.samples; ++k) {
        const auto qx = round_clamp(hn::Add(fx, hn::Mul(hn::Set(d, job.ox[k]), rho)), wlast);
        const auto qy = round_clamp(hn::Add(fy, hn::Mul(hn::Set(d, job.oy[k]), rho)), hlast);
        const auto idx = hn::Add(hn::Mul(qy, vw), qx);
        const auto behind = hn::And(hn::Lt(hn::GatherIndex(d, job.inv_z, idx), limit), active);
        s0 = hn::Add(s0, hn::IfThenElseZero(behind, hn::GatherIndex(d, job.colour[0], idx)));
        s1 = hn::Add(s1, hn::IfThenElseZero(behind, hn::GatherIndex(d, job.colour[1], idx)));
        s2 = hn::Add(s2, hn::IfThenElseZero(behind, hn::GatherIndex(d, job.colour[2], idx)));
        s3 = hn::Add(s3, hn::IfThenElseZero(behind, hn::GatherIndex(d, job.colour[3], idx)));
        count = hn::Add(count, hn::IfThenElseZero(behind, one));
      }
      hn::Store(s0, d, out[0]);
      hn::Store(s1, d, out[1]);
      hn::Store(s2, d, out[2]);
      hn::Store(s3, d, out[3]);
      hn::Store(count, d, out[4]);
      for (int i = 0; i < nl; ++i) {
        if (out[4][i] == 0.0f) {
          hp[i * 4 + 3] = -1.0f;
          continue;
        }
        for (int c = 0; c < 4; ++c) hp[i * 4 + c] = out[c][i] / out[4][i];
      }
    }
  }
}

void ScatterBand(const BandJob& job) {
  if (job.model) {
    if (job.depth_order)
      ScatterBandT<true, true>(job);
    else
      ScatterBandT<false, true>(job);
  } else if (job.depth_order) {
    ScatterBandT<true, false>(job);
  } else {
    ScatterBandT<false, false>(job);
  }
}

}  // namespace HWY_NAMESPACE
}  // namespace dofkit::detail
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace dofkit::detail {

HWY_EXPORT(ScatterBand);
HWY_EXPORT(HiddenRows);

void hidden_rows_simd(const HiddenJob& job, int y0, int y1) { HWY_DYNAMIC_DISPATCH(HiddenRows)(job, y0, y1); }

void scatter_band_simd(const BandJob& job) { HWY_DYNAMIC_DISPATCH(ScatterBand)(job); }

void scatter_band_plain(const BandJob& job) {
  const int w = job.w;
  const int sy0 = std::max(0, job.y0 - job.reach), sy1 = std::min(job.h, job.y1 + job.reach);
  for (int qy = sy0; qy < sy1; ++qy) {
    for (int qx = 0; qx < w; ++qx) {
      const std::size_t q = static_cast<std::size_t>(qy) * w + qx;
      const float rq = job.rho[q];
      const core::ApertureModel* model = job.model;
      const core::Field field = model ? core::field_of(job.coc[q]) : core::Field::far;
      const float sx = qx + 0.5f, sy = qy + 0.5f;
      const int ext = model ? model->reach(rq) : static_cast<int>(std::ceil(rq + 0.5f)) - 1;
      const int py0 = std::max(job.y0, qy - ext), py1 = std::min(job.y1 - 1, qy + ext);
      if (py0 > py1) continue;
      const float c[4] = {job.colour[0][q], job.colour[1][q], job.colour[2][q], job.colour[3][q]};
      const float ws = job.wscale[q], uq = job.inv_z[q], sq = job.sharp[q];
      const float inv_sq = sq > 0 ? 1.0f / sq : 1e30f;
      const float lim = rq + 0.5f;
      for (int py = py0; py <= py1; ++py) {
        const float dy = static_cast<float>(py - qy);
        int px0, px1;
        if (model) {
          const core::Span sp = model->row_span(py - qy, rq, field, sx, sy);
          px0 = std::max(0, qx + sp.x0);
          px1 = std::min(w - 1, qx + sp.x1);
        } else {
          const int hw = static_cast<int>(std::sqrt(std::max(0.0f, lim * lim - dy * dy)));
          px0 = std::max(0, qx - hw);
          px1 = std::min(w - 1, qx + hw);
        }
        const std::size_t prow = static_cast<std::size_t>(py) * w;
        float* a[10];
        for (int k = 0; k < 10; ++k)
          a[k] = job.acc + (static_cast<std::size_t>(k) * job.band + (py - job.y0)) * job.stride;
        for (int px = px0; px <= px1; ++px) {
          const float dx = static_cast<float>(px - qx);
          const float cov = model ? model->coverage(px - qx, py - qy, rq, field, sx, sy, job.channel)
                                  : std::min(std::max(rq - std::sqrt(dx * dx + dy * dy) + 0.5f, 0.0f), 1.0f);
          float wt = cov * ws;
          float front = 0.0f;
          if (job.depth_order) {
            const float rel = (uq - job.inv_z[prow + px]) * job.isu[prow + px];
            front = std::min(std::max(rel, 0.0f), 1.0f);
            const float behind = std::min(std::max(-rel, 0.0f), 1.0f);
            const float pass = std::min(job.sharp[prow + px] * inv_sq, 1.0f);
            wt *= 1.0f - behind * (1.0f - pass);
          }
          const float wf = wt * front, wb = wt - wf;
          for (int ch = 0; ch < 4; ++ch) {
            a[ch][px] += wf * c[ch];
            a[5 + ch][px] += wb * c[ch];
          }
          a[4][px] += wf;
          a[9][px] += wb;
        }
      }
    }
  }
}

}  // namespace dofkit::detail
#endif  // HWY_ONCE
