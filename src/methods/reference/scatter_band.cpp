// SIMD (Highway, run-time dispatch) and plain versions of the disc-scatter band loop; see
// scatter_band.hpp and disc_scatter.cpp for the maths. Per receiver both compute
//   cov = sat(ρ_q − |p − q| + 0.5),  w = cov · wscale_q,
//   rel = (u_q − u_p)·isu_p,  front = sat(rel),  behind = sat(−rel),
//   pass = min(sharp_p / sharp_q, 1),  w *= 1 − behind·(1 − pass),
// and add w·front to F and w·(1 − front) to B.
#include "methods/reference/scatter_band.hpp"

#include <algorithm>
#include <cmath>

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "methods/reference/scatter_band.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace dofkit::detail {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

void ScatterBand(const BandJob& job) {
  const hn::ScalableTag<float> d;
  const int lanes = static_cast<int>(hn::Lanes(d));
  const int w = job.w;
  const auto zero = hn::Zero(d), one = hn::Set(d, 1.0f), half = hn::Set(d, 0.5f);
  const auto iota = hn::Iota(d, 0.0f);
  const int sy0 = std::max(0, job.y0 - job.reach), sy1 = std::min(job.h, job.y1 + job.reach);
  for (int qy = sy0; qy < sy1; ++qy) {
    for (int qx = 0; qx < w; ++qx) {
      const std::size_t q = static_cast<std::size_t>(qy) * w + qx;
      const float rq = job.rho[q];
      const int ext = static_cast<int>(std::ceil(rq + 0.5f)) - 1;
      const int py0 = std::max(job.y0, qy - ext), py1 = std::min(job.y1 - 1, qy + ext);
      if (py0 > py1) continue;
      const auto c0 = hn::Set(d, job.colour[0][q]), c1 = hn::Set(d, job.colour[1][q]);
      const auto c2 = hn::Set(d, job.colour[2][q]), c3 = hn::Set(d, job.colour[3][q]);
      const auto vrq = hn::Set(d, rq), vws = hn::Set(d, job.wscale[q]), vuq = hn::Set(d, job.inv_z[q]);
      const float sq = job.sharp[q];
      const auto vinv_sq = hn::Set(d, sq > 0 ? 1.0f / sq : 1e30f);
      const float lim = rq + 0.5f;
      for (int py = py0; py <= py1; ++py) {
        const float dy = static_cast<float>(py - qy);
        const int hw = static_cast<int>(std::sqrt(std::max(0.0f, lim * lim - dy * dy)));
        const int px0 = std::max(0, qx - hw), px1 = std::min(w - 1, qx + hw);
        const auto vdy2 = hn::Set(d, dy * dy);
        const std::size_t prow = static_cast<std::size_t>(py) * w;
        float* a[10];
        for (int k = 0; k < 10; ++k) a[k] = job.acc + (static_cast<std::size_t>(k) * job.band + (py - job.y0)) * job.stride;
        // Lanes past px1 lie outside the disc (cov = 0) or past the row end (padding), so the
        // loop needs no tail handling.
        for (int px = px0; px <= px1; px += lanes) {
          const auto dx = hn::Add(iota, hn::Set(d, static_cast<float>(px - qx)));
          const auto dist = hn::Sqrt(hn::MulAdd(dx, dx, vdy2));
          const auto cov = hn::Min(hn::Max(hn::Add(hn::Sub(vrq, dist), half), zero), one);
          auto wt = hn::Mul(cov, vws);
          auto front = zero;
          if (job.depth_order) {
            const auto rel = hn::Mul(hn::Sub(vuq, hn::LoadU(d, job.inv_z + prow + px)), hn::LoadU(d, job.isu + prow + px));
            front = hn::Min(hn::Max(rel, zero), one);
            const auto behind = hn::Min(hn::Max(hn::Neg(rel), zero), one);
            const auto pass = hn::Min(hn::Mul(hn::LoadU(d, job.sharp + prow + px), vinv_sq), one);
            wt = hn::Mul(wt, hn::Sub(one, hn::Mul(behind, hn::Sub(one, pass))));
          }
          const auto wf = hn::Mul(wt, front), wb = hn::Sub(wt, wf);
          hn::StoreU(hn::MulAdd(wf, c0, hn::LoadU(d, a[0] + px)), d, a[0] + px);
          hn::StoreU(hn::MulAdd(wf, c1, hn::LoadU(d, a[1] + px)), d, a[1] + px);
          hn::StoreU(hn::MulAdd(wf, c2, hn::LoadU(d, a[2] + px)), d, a[2] + px);
          hn::StoreU(hn::MulAdd(wf, c3, hn::LoadU(d, a[3] + px)), d, a[3] + px);
          hn::StoreU(hn::Add(wf, hn::LoadU(d, a[4] + px)), d, a[4] + px);
          hn::StoreU(hn::MulAdd(wb, c0, hn::LoadU(d, a[5] + px)), d, a[5] + px);
          hn::StoreU(hn::MulAdd(wb, c1, hn::LoadU(d, a[6] + px)), d, a[6] + px);
          hn::StoreU(hn::MulAdd(wb, c2, hn::LoadU(d, a[7] + px)), d, a[7] + px);
          hn::StoreU(hn::MulAdd(wb, c3, hn::LoadU(d, a[8] + px)), d, a[8] + px);
          hn::StoreU(hn::Add(wb, hn::LoadU(d, a[9] + px)), d, a[9] + px);
        }
      }
    }
  }
}

}  // namespace HWY_NAMESPACE
}  // namespace dofkit::detail
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace dofkit::detail {

HWY_EXPORT(ScatterBand);

void scatter_band_simd(const BandJob& job) { HWY_DYNAMIC_DISPATCH(ScatterBand)(job); }

void scatter_band_plain(const BandJob& job) {
  const int w = job.w;
  const int sy0 = std::max(0, job.y0 - job.reach), sy1 = std::min(job.h, job.y1 + job.reach);
  for (int qy = sy0; qy < sy1; ++qy) {
    for (int qx = 0; qx < w; ++qx) {
      const std::size_t q = static_cast<std::size_t>(qy) * w + qx;
      const float rq = job.rho[q];
      const int ext = static_cast<int>(std::ceil(rq + 0.5f)) - 1;
      const int py0 = std::max(job.y0, qy - ext), py1 = std::min(job.y1 - 1, qy + ext);
      if (py0 > py1) continue;
      const float c[4] = {job.colour[0][q], job.colour[1][q], job.colour[2][q], job.colour[3][q]};
      const float ws = job.wscale[q], uq = job.inv_z[q], sq = job.sharp[q];
      const float inv_sq = sq > 0 ? 1.0f / sq : 1e30f;
      const float lim = rq + 0.5f;
      for (int py = py0; py <= py1; ++py) {
        const float dy = static_cast<float>(py - qy);
        const int hw = static_cast<int>(std::sqrt(std::max(0.0f, lim * lim - dy * dy)));
        const int px0 = std::max(0, qx - hw), px1 = std::min(w - 1, qx + hw);
        const std::size_t prow = static_cast<std::size_t>(py) * w;
        float* a[10];
        for (int k = 0; k < 10; ++k) a[k] = job.acc + (static_cast<std::size_t>(k) * job.band + (py - job.y0)) * job.stride;
        for (int px = px0; px <= px1; ++px) {
          const float dx = static_cast<float>(px - qx);
          const float cov = std::min(std::max(rq - std::sqrt(dx * dx + dy * dy) + 0.5f, 0.0f), 1.0f);
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
