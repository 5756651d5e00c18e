// Pass 4 — Highway row kernels of the smart Gaussian blur (blur.cpp is the oracle and the
// driver). One output pixel per lane; the taps are summed from −r to r with the oracle's float
// operations in the oracle's order (no FMA: -ffp-contract=off), so the values are equal bit
// for bit. Horizontal: only columns whose taps all lie in the row (the driver finishes the
// borders with the oracle). Vertical: any column; rows outside the image are skipped for
// every lane alike.
#include <cstddef>
#include <limits>

#include "effects/ssao/ssao.hpp"

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "effects/ssao/blur_simd.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace dofkit::detail::ao {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

int BlurH(const float* z, const float* const n[3], const float* in, float* out, const float* taps, int r, float depth_t,
          float normal_t, int x0, int x1) {
  const hn::ScalableTag<float> d;
  const int lanes = static_cast<int>(hn::Lanes(d));
  const auto zero = hn::Zero(d), one = hn::Set(d, 1.0f);
  const auto inf = hn::Set(d, std::numeric_limits<float>::infinity());
  const auto dt = hn::Set(d, depth_t), nt = hn::Set(d, normal_t);
  int x = x0;
  for (; x + lanes <= x1; x += lanes) {
    const auto zc = hn::LoadU(d, z + x);
    const auto c0 = hn::LoadU(d, n[0] + x), c1 = hn::LoadU(d, n[1] + x), c2 = hn::LoadU(d, n[2] + x);
    const auto limit = hn::Mul(dt, zc);
    auto sw = zero, s = zero;
    for (int k = -r; k <= r; ++k) {
      const auto g = hn::Set(d, taps[k < 0 ? -k : k]);
      const auto v = hn::LoadU(d, in + x + k);
      if (k == 0) {
        sw = hn::Add(sw, g);
        s = hn::Add(s, hn::Mul(g, v));
        continue;
      }
      const auto zt = hn::LoadU(d, z + x + k);
      const auto dot =
          hn::Add(hn::Add(hn::Mul(hn::LoadU(d, n[0] + x + k), c0), hn::Mul(hn::LoadU(d, n[1] + x + k), c1)),
                  hn::Mul(hn::LoadU(d, n[2] + x + k), c2));
      const auto keep = hn::And(hn::Le(hn::Abs(hn::Sub(zt, zc)), limit), hn::Ge(dot, nt));
      sw = hn::IfThenElse(keep, hn::Add(sw, g), sw);
      s = hn::IfThenElse(keep, hn::Add(s, hn::Mul(g, v)), s);
    }
    hn::StoreU(hn::IfThenElse(hn::Lt(zc, inf), hn::Div(s, sw), one), d, out + x);
  }
  return x;
}

int BlurV(const VRows& rows, int r, const float* taps, float depth_t, float normal_t, float* out, int x0, int x1) {
  const hn::ScalableTag<float> d;
  const int lanes = static_cast<int>(hn::Lanes(d));
  const auto zero = hn::Zero(d), one = hn::Set(d, 1.0f);
  const auto inf = hn::Set(d, std::numeric_limits<float>::infinity());
  const auto dt = hn::Set(d, depth_t), nt = hn::Set(d, normal_t);
  int x = x0;
  for (; x + lanes <= x1; x += lanes) {
    const auto zc = hn::LoadU(d, rows.z[r] + x);
    const auto c0 = hn::LoadU(d, rows.n0[r] + x), c1 = hn::LoadU(d, rows.n1[r] + x), c2 = hn::LoadU(d, rows.n2[r] + x);
    const auto limit = hn::Mul(dt, zc);
    auto sw = zero, s = zero;
    for (int k = -r; k <= r; ++k) {
      const int i = k + r;
      if (!rows.z[i]) continue;
      const auto g = hn::Set(d, taps[k < 0 ? -k : k]);
      const auto v = hn::LoadU(d, rows.in[i] + x);
      if (k == 0) {
        sw = hn::Add(sw, g);
        s = hn::Add(s, hn::Mul(g, v));
        continue;
      }
      const auto zt = hn::LoadU(d, rows.z[i] + x);
      const auto dot =
          hn::Add(hn::Add(hn::Mul(hn::LoadU(d, rows.n0[i] + x), c0), hn::Mul(hn::LoadU(d, rows.n1[i] + x), c1)),
                  hn::Mul(hn::LoadU(d, rows.n2[i] + x), c2));
      const auto keep = hn::And(hn::Le(hn::Abs(hn::Sub(zt, zc)), limit), hn::Ge(dot, nt));
      sw = hn::IfThenElse(keep, hn::Add(sw, g), sw);
      s = hn::IfThenElse(keep, hn::Add(s, hn::Mul(g, v)), s);
    }
    hn::StoreU(hn::IfThenElse(hn::Lt(zc, inf), hn::Div(s, sw), one), d, out + x);
  }
  return x;
}

}  // namespace HWY_NAMESPACE
}  // namespace dofkit::detail::ao
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace dofkit::detail::ao {

HWY_EXPORT(BlurH);
HWY_EXPORT(BlurV);

int blur_h_row_simd(const float* z, const float* const n[3], const float* in, float* out, const float* taps, int r,
                    float depth_t, float normal_t, int x0, int x1) {
  return HWY_DYNAMIC_DISPATCH(BlurH)(z, n, in, out, taps, r, depth_t, normal_t, x0, x1);
}

int blur_v_row_simd(const VRows& rows, int r, const float* taps, float depth_t, float normal_t, float* out, int x0,
                    int x1) {
  return HWY_DYNAMIC_DISPATCH(BlurV)(rows, r, taps, depth_t, normal_t, out, x0, x1);
}

}  // namespace dofkit::detail::ao
#endif  // HWY_ONCE
