// Pass 3 (gtao) — Highway kernels with run-time dispatch of gtao.cpp's horizon / sector
// search and slice integral, one pixel per lane. The arithmetic is the oracle's operation for
// operation (no FMA: -ffp-contract=off; the same arc-cosine polynomial, gtao_math.hpp), with
// the depth samples, the camera tables, the noise tables and the sector masks fetched by
// gathers, so the values are equal bit for bit. The row tail that does not fill a vector is
// left to gtao_span_plain.
#include <cstddef>
#include <cstdint>
#include <limits>

#include "effects/ssao/gtao_math.hpp"
#include "effects/ssao/ssao.hpp"

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "effects/ssao/gtao_simd.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace dofkit::detail::ao {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

template <class D, class V>
HWY_INLINE V AcosPoly(D d, V x) {
  const V a = hn::Abs(x);
  const V p = hn::Add(
      hn::Mul(hn::Add(hn::Mul(hn::Add(hn::Mul(hn::Set(d, kAcos3), a), hn::Set(d, kAcos2)), a), hn::Set(d, kAcos1)), a),
      hn::Set(d, kAcos0));
  const V r = hn::Mul(hn::Sqrt(hn::Sub(hn::Set(d, 1.0f), a)), p);
  return hn::IfThenElse(hn::Lt(x, hn::Zero(d)), hn::Sub(hn::Set(d, kPiF), r), r);
}

template <class D, class V>
HWY_INLINE V Clamp1(D d, V v) {
  return hn::Min(hn::Max(v, hn::Set(d, -1.0f)), hn::Set(d, 1.0f));
}

int GtaoRow(const Camera& cam, const Image& depth, const Image& n, const GtaoKernel& k, float* ao, int y) {
  const hn::ScalableTag<float> d;
  const hn::RebindToSigned<decltype(d)> di;
  const hn::RebindToUnsigned<decltype(d)> du;
  using V = hn::Vec<decltype(d)>;
  const int lanes = static_cast<int>(hn::Lanes(d));
  const int w = cam.w;
  const float* zp = depth.plane(0);
  const float* zr = depth.row(0, y);
  const float *n0 = n.row(0, y), *n1 = n.row(1, y), *n2 = n.row(2, y);
  const V zero = hn::Zero(d), one = hn::Set(d, 1.0f), neg_one = hn::Set(d, -1.0f), half = hn::Set(d, 0.5f);
  const V quarter = hn::Set(d, 0.25f), two = hn::Set(d, 2.0f);
  const V inf = hn::Set(d, std::numeric_limits<float>::infinity());
  const V fw = hn::Set(d, static_cast<float>(w)), fh = hn::Set(d, static_cast<float>(cam.h));
  const V fw_in = hn::Set(d, static_cast<float>(w) - 0.5f), fh_in = hn::Set(d, static_cast<float>(cam.h) - 0.5f);
  const V half_pi = hn::Set(d, kHalfPiF), neg_half_pi = hn::Set(d, -kHalfPiF);
  const V ky = hn::Set(d, cam.ky[y]);
  const V cx = hn::Set(d, cam.cx), cy = hn::Set(d, cam.cy), inv_f = hn::Set(d, cam.inv_f);
  const V radius = hn::Set(d, k.radius), inv_falloff = hn::Set(d, k.inv_falloff), r2 = hn::Set(d, k.radius * k.radius);
  const V rf = hn::Set(d, k.radius * cam.f), limit = hn::Set(d, k.limit_px);
  const V thickness = hn::Set(d, k.thickness_m);
  const V inv_slices = hn::Set(d, 1.0f / static_cast<float>(k.slices));
  const V sector_scale = hn::Set(d, static_cast<float>(kSectors) * kInvPi),
          kmax = hn::Set(d, static_cast<float>(kSectors));
  const bool sectors = k.thickness_m > 0;
  const auto vw = hn::Set(di, w);
  const auto trow = hn::Set(di, (y % k.noise) * k.noise);
  const auto vslices = hn::Set(di, k.slices), vsteps = hn::Set(di, k.steps);
  const V cyp = hn::Set(d, static_cast<float>(y) + 0.5f);
  const std::int32_t* masks = reinterpret_cast<const std::int32_t*>(k.low_mask.data());
  int x = 0;
  for (; x + lanes <= w; x += lanes) {
    const V z = hn::LoadU(d, zr + x);
    const auto finite = hn::Lt(z, inf);
    const V px = hn::Mul(hn::LoadU(d, cam.kx.data() + x), z), py = hn::Mul(ky, z), pz = z;
    const V inv_len = hn::Div(one, hn::Sqrt(hn::Add(hn::Add(hn::Mul(px, px), hn::Mul(py, py)), hn::Mul(pz, pz))));
    const V vx = hn::Mul(hn::Neg(px), inv_len), vy = hn::Mul(hn::Neg(py), inv_len), vz = hn::Mul(hn::Neg(pz), inv_len);
    const V nx = hn::LoadU(d, n0 + x), ny = hn::LoadU(d, n1 + x), nz = hn::LoadU(d, n2 + x);
    const V r_px = hn::Max(one, hn::Min(hn::Div(rf, z), limit));
    const auto t = hn::Add(trow, hn::LoadU(di, k.col_t.data() + x));
    const V cxp = hn::Add(hn::ConvertTo(d, hn::Add(hn::Set(di, x), hn::Iota(di, 0))), half);
    V vis = zero;
    for (int s = 0; s < k.slices; ++s) {
      const auto ts = hn::Add(hn::Mul(t, vslices), hn::Set(di, s));
      const V dx = hn::GatherIndex(d, k.dir_x.data(), ts), dy = hn::GatherIndex(d, k.dir_y.data(), ts);
      const V dv = hn::Add(hn::Mul(dx, vx), hn::Mul(dy, vy));
      const V ox = hn::Sub(dx, hn::Mul(dv, vx)), oy = hn::Sub(dy, hn::Mul(dv, vy)), oz = hn::Neg(hn::Mul(dv, vz));
      V ax = hn::Sub(hn::Mul(oy, vz), hn::Mul(oz, vy)), ay = hn::Sub(hn::Mul(oz, vx), hn::Mul(ox, vz)),
        az = hn::Sub(hn::Mul(ox, vy), hn::Mul(oy, vx));
      const V inv_a = hn::Div(one, hn::Sqrt(hn::Add(hn::Add(hn::Mul(ax, ax), hn::Mul(ay, ay)), hn::Mul(az, az))));
      ax = hn::Mul(ax, inv_a);
      ay = hn::Mul(ay, inv_a);
      az = hn::Mul(az, inv_a);
      const V an = hn::Add(hn::Add(hn::Mul(nx, ax), hn::Mul(ny, ay)), hn::Mul(nz, az));
      const V pnx = hn::Sub(nx, hn::Mul(ax, an)), pny = hn::Sub(ny, hn::Mul(ay, an)),
              pnz = hn::Sub(nz, hn::Mul(az, an));
      const V pl = hn::Sqrt(hn::Add(hn::Add(hn::Mul(pnx, pnx), hn::Mul(pny, pny)), hn::Mul(pnz, pnz)));
      const V cos_g = Clamp1(d, hn::Div(hn::Add(hn::Add(hn::Mul(pnx, vx), hn::Mul(pny, vy)), hn::Mul(pnz, vz)), pl));
      const auto neg = hn::Lt(hn::Add(hn::Add(hn::Mul(pnx, ox), hn::Mul(pny, oy)), hn::Mul(pnz, oz)), zero);
      const V sgn = hn::IfThenElse(neg, neg_one, one);
      const V gamma = hn::Mul(sgn, AcosPoly(d, cos_g));
      const V sin_g = hn::Mul(sgn, hn::Sqrt(hn::Sub(one, hn::Mul(cos_g, cos_g))));
      const V base = hn::Sub(gamma, half_pi);
      V hc0 = hn::Neg(sin_g), hc1 = sin_g;
      auto bits = hn::Zero(di);
      for (int j = 0; j < k.steps; ++j) {
        const V tj = hn::GatherIndex(d, k.step_t.data(), hn::Add(hn::Mul(t, vsteps), hn::Set(di, j)));
        const V off = hn::Add(one, hn::Mul(tj, hn::Sub(r_px, one)));
        for (int side = 0; side < 2; ++side) {
          const V sdx = side == 0 ? hn::Mul(dx, off) : hn::Neg(hn::Mul(dx, off));
          const V sdy = side == 0 ? hn::Mul(dy, off) : hn::Neg(hn::Mul(dy, off));
          V sxp = hn::Add(cxp, sdx), syp = hn::Add(cyp, sdy);
          if (k.clamp_edges) {
            sxp = hn::Min(hn::Max(sxp, zero), fw_in);
            syp = hn::Min(hn::Max(syp, zero), fh_in);
          }
          const auto inside =
              hn::And(hn::And(hn::Ge(sxp, zero), hn::Lt(sxp, fw)), hn::And(hn::Ge(syp, zero), hn::Lt(syp, fh)));
          // Lanes off screen read pixel 0 and are discarded below.
          const auto ix = hn::ConvertTo(di, hn::IfThenElseZero(inside, hn::Floor(sxp)));
          const auto iy = hn::ConvertTo(di, hn::IfThenElseZero(inside, hn::Floor(syp)));
          const V zs = hn::GatherIndex(d, zp, hn::Add(hn::Mul(iy, vw), ix));
          // kx[ix], ky[iy] recomputed as make_camera computes them (the same values).
          const V kxs = hn::Mul(hn::Sub(hn::Add(hn::ConvertTo(d, ix), half), cx), inv_f);
          const V kys = hn::Mul(hn::Sub(hn::Add(hn::ConvertTo(d, iy), half), cy), inv_f);
          const V sx = hn::Mul(kxs, zs);
          const V sy = hn::Mul(kys, zs);
          const V ddx = hn::Sub(sx, px), ddy = hn::Sub(sy, py), ddz = hn::Sub(zs, pz);
          const V d2 = hn::Add(hn::Add(hn::Mul(ddx, ddx), hn::Mul(ddy, ddy)), hn::Mul(ddz, ddz));
          const auto valid = hn::And(hn::And(inside, hn::Lt(zs, inf)), hn::Gt(d2, zero));
          const V side_sign = side == 0 ? one : neg_one;
          if (sectors) {
            const V inv_ls =
                hn::Div(one, hn::Sqrt(hn::Add(hn::Add(hn::Mul(sx, sx), hn::Mul(sy, sy)), hn::Mul(zs, zs))));
            const V ex = hn::Mul(sx, inv_ls), ey = hn::Mul(sy, inv_ls), ez = hn::Mul(zs, inv_ls);
            const V b = hn::Add(hn::Add(hn::Mul(ddx, ex), hn::Mul(ddy, ey)), hn::Mul(ddz, ez));
            const V disc = hn::Sub(hn::Mul(b, b), hn::Sub(d2, r2));
            const V q = hn::Sqrt(hn::Max(disc, zero));
            const V u0 = hn::Max(zero, hn::Sub(hn::Neg(b), q)), u1 = hn::Min(thickness, hn::Add(hn::Neg(b), q));
            const V f0x = hn::Add(ddx, hn::Mul(ex, u0)), f0y = hn::Add(ddy, hn::Mul(ey, u0)),
                    f0z = hn::Add(ddz, hn::Mul(ez, u0));
            const V f1x = hn::Add(ddx, hn::Mul(ex, u1)), f1y = hn::Add(ddy, hn::Mul(ey, u1)),
                    f1z = hn::Add(ddz, hn::Mul(ez, u1));
            const V l0 = hn::Add(hn::Add(hn::Mul(f0x, f0x), hn::Mul(f0y, f0y)), hn::Mul(f0z, f0z));
            const V l1 = hn::Add(hn::Add(hn::Mul(f1x, f1x), hn::Mul(f1y, f1y)), hn::Mul(f1z, f1z));
            const auto use = hn::And(hn::And(valid, hn::Ge(disc, zero)),
                                     hn::And(hn::Le(u0, u1), hn::And(hn::Gt(l0, zero), hn::Gt(l1, zero))));
            const V c0 = Clamp1(
                d, hn::Div(hn::Add(hn::Add(hn::Mul(f0x, vx), hn::Mul(f0y, vy)), hn::Mul(f0z, vz)), hn::Sqrt(l0)));
            const V c1 = Clamp1(
                d, hn::Div(hn::Add(hn::Add(hn::Mul(f1x, vx), hn::Mul(f1y, vy)), hn::Mul(f1z, vz)), hn::Sqrt(l1)));
            const V ta = hn::Mul(side_sign, AcosPoly(d, c0)), tb = hn::Mul(side_sign, AcosPoly(d, c1));
            const V ua = hn::Mul(hn::Sub(hn::Min(ta, tb), base), sector_scale);
            const V ub = hn::Mul(hn::Sub(hn::Max(ta, tb), base), sector_scale);
            const auto a =
                hn::ConvertTo(di, hn::IfThenElseZero(use, hn::Min(hn::Max(hn::Floor(hn::Add(ua, half)), zero), kmax)));
            const auto e =
                hn::ConvertTo(di, hn::IfThenElseZero(use, hn::Min(hn::Max(hn::Floor(hn::Add(ub, half)), zero), kmax)));
            bits = hn::Or(bits, hn::AndNot(hn::GatherIndex(di, masks, a), hn::GatherIndex(di, masks, e)));
            continue;
          }
          const V dist = hn::Sqrt(d2);
          const V c = hn::Div(hn::Add(hn::Add(hn::Mul(ddx, vx), hn::Mul(ddy, vy)), hn::Mul(ddz, vz)), dist);
          const V wgt = hn::Min(hn::Max(hn::Mul(hn::Sub(radius, dist), inv_falloff), zero), one);
          const auto use = hn::And(valid, hn::Gt(wgt, zero));
          const V low = side == 0 ? hn::Neg(sin_g) : sin_g;
          V& hc = side == 0 ? hc0 : hc1;
          hc = hn::IfThenElse(use, hn::Max(hc, hn::Add(low, hn::Mul(hn::Sub(c, low), wgt))), hc);
        }
      }
      if (sectors) {
        V open = zero, all = zero;
        const auto ubits = hn::BitCast(du, bits);
        for (int i = 0; i < kSectors; ++i) {
          const V cphi = hn::Set(d, k.cos_phi[i]);
          const V wi = hn::Mul(cphi, hn::Abs(hn::Add(hn::Mul(sin_g, cphi), hn::Mul(cos_g, hn::Set(d, k.sin_phi[i])))));
          all = hn::Add(all, wi);
          const auto clear = hn::Eq(hn::And(ubits, hn::Set(du, 1u << i)), hn::Zero(du));
          open = hn::IfThenElse(hn::RebindMask(d, clear), hn::Add(open, wi), open);
        }
        vis = hn::Add(vis, hn::Mul(pl, hn::Mul(hn::Add(cos_g, hn::Mul(gamma, sin_g)), hn::Div(open, all))));
        continue;
      }
      const V two_sin = hn::Mul(two, sin_g);
      V arc0, arc1;
      {
        const V c = Clamp1(d, hc0);
        const V h = AcosPoly(d, c);
        const V clamped = hn::Add(hn::Add(cos_g, hn::Mul(hn::Add(gamma, half_pi), two_sin)), cos_g);
        const V c2 = hn::Add(hn::Mul(hn::Sub(hn::Mul(hn::Mul(two, c), c), one), cos_g),
                             hn::Mul(hn::Mul(hn::Mul(two, c), hn::Sqrt(hn::Sub(one, hn::Mul(c, c)))), sin_g));
        const V free = hn::Sub(hn::Add(cos_g, hn::Mul(h, two_sin)), c2);
        arc1 = hn::IfThenElse(hn::Gt(hn::Sub(h, gamma), half_pi), clamped, free);
      }
      {
        const V c = Clamp1(d, hc1);
        const V h = hn::Neg(AcosPoly(d, c));
        const V clamped = hn::Add(hn::Add(cos_g, hn::Mul(hn::Sub(gamma, half_pi), two_sin)), cos_g);
        const V c2 = hn::Add(hn::Mul(hn::Sub(hn::Mul(hn::Mul(two, c), c), one), cos_g),
                             hn::Mul(hn::Mul(hn::Mul(two, c), hn::Neg(hn::Sqrt(hn::Sub(one, hn::Mul(c, c))))), sin_g));
        const V free = hn::Sub(hn::Add(cos_g, hn::Mul(h, two_sin)), c2);
        arc0 = hn::IfThenElse(hn::Lt(hn::Sub(h, gamma), neg_half_pi), clamped, free);
      }
      vis = hn::Add(vis, hn::Mul(pl, hn::Mul(hn::Add(arc0, arc1), quarter)));
    }
    const V a = hn::Min(hn::Max(hn::Mul(vis, inv_slices), zero), one);
    hn::StoreU(hn::IfThenElse(finite, a, one), d, ao + static_cast<std::size_t>(y) * w + x);
  }
  return x;
}

}  // namespace HWY_NAMESPACE
}  // namespace dofkit::detail::ao
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace dofkit::detail::ao {

HWY_EXPORT(GtaoRow);

void gtao_rows_fast(const Camera& cam, const Image& depth, const Image& n, const GtaoKernel& k, float* ao, int y0,
                    int y1) {
  for (int y = y0; y < y1; ++y) {
    const int done = HWY_DYNAMIC_DISPATCH(GtaoRow)(cam, depth, n, k, ao, y);
    gtao_span_plain(cam, depth, n, k, ao, y, done, cam.w);
  }
}

}  // namespace dofkit::detail::ao
#endif  // HWY_ONCE
