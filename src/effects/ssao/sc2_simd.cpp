// Pass 3 (sc2) — the raw occlusion term, Highway kernels with run-time dispatch.
// Inputs / outputs and the arithmetic: exactly sc2_sample.cpp's (its oracle), one pixel per
// lane: the same IEEE operations in the same order (no FMA: -ffp-contract=off in
// CMakeLists.txt), the quarter-res texel and the table entry fetched by gathers. The row tail
// that does not fill a vector is left to sc2_span_plain. Rows are split over the threads by
// the caller; each pixel depends only on its own inputs, so any split gives the same values.
#include <cstddef>
#include <cstdint>
#include <limits>

#include "effects/ssao/ssao.hpp"

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "effects/ssao/sc2_simd.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace dofkit::detail::ao {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// Columns [x0, returned) of row y (whole vectors only).
int Sc2Row(const Camera& cam, const Image& depth, const Image& n, const Image& quarter, const Sc2Kernel& k,
           const Sc2Out& out, int y, int x0, int x1) {
  const hn::ScalableTag<float> d;
  const hn::RebindToSigned<decltype(d)> di;
  const int lanes = static_cast<int>(hn::Lanes(d));
  const int w = cam.w, qw = quarter.width();
  const float inv_rf = 1.0f / (k.radius_wide * cam.f);
  const float inv_count[2] = {1.0f / static_cast<float>(k.n_small), 1.0f / static_cast<float>(k.n_wide)};
  const float* q = quarter.plane(0);
  const float* zr = depth.row(0, y);
  const float *n0 = n.row(0, y), *n1 = n.row(1, y), *n2 = n.row(2, y);
  const int n_offsets = k.n_small + k.n_wide;
  const std::size_t trow = static_cast<std::size_t>(y % k.noise) * n_offsets * k.period;
  const float *rfx = k.refl_x.data() + trow, *rfy = k.refl_y.data() + trow, *rfz = k.refl_z.data() + trow;
  const auto zero = hn::Zero(d), one = hn::Set(d, 1.0f), quarter_px = hn::Set(d, k.q_scale);
  const auto q_off = hn::Set(d, k.q_offset);
  const auto inf = hn::Set(d, std::numeric_limits<float>::infinity());
  const auto fw = hn::Set(d, static_cast<float>(cam.w)), fh = hn::Set(d, static_cast<float>(cam.h));
  const auto f = hn::Set(d, cam.f), cx = hn::Set(d, cam.cx), cy = hn::Set(d, cam.cy);
  const auto ky = hn::Set(d, cam.ky[y]);
  const auto limit = hn::Set(d, k.limit_px), vinv_rf = hn::Set(d, inv_rf);
  const auto table_end = hn::Set(d, static_cast<float>(kTableSize));
  const auto vqw = hn::Set(di, qw);
  int x = x0;
  for (; x + lanes <= x1; x += lanes) {
    const auto z = hn::LoadU(d, zr + x);
    const auto finite = hn::Lt(z, inf);
    const auto px = hn::Mul(hn::LoadU(d, cam.kx.data() + x), z), py = hn::Mul(ky, z), pz = z;
    const auto nx = hn::LoadU(d, n0 + x), ny = hn::LoadU(d, n1 + x), nz = hn::LoadU(d, n2 + x);
    const std::size_t phase = static_cast<std::size_t>(x % k.noise);
    const auto scale = hn::Min(one, hn::Mul(hn::Mul(limit, z), vinv_rf));
    hn::Vec<decltype(d)> set_ao[2];
    for (int set = 0; set < 2; ++set) {
      const int i0 = set == 0 ? 0 : k.n_small, i1 = set == 0 ? k.n_small : k.n_small + k.n_wide;
      const auto rs = hn::Mul(hn::Set(d, set == 0 ? k.radius_small : k.radius_wide), scale);
      const auto inv_rs = hn::Div(one, rs);
      const float* table = set == 0 ? k.table_small.data() : k.table_wide.data();
      const auto tscale = hn::Set(d, set == 0 ? k.scale_small : k.scale_wide);
      auto sum = zero;
      const auto neg_rs = hn::Neg(rs);
      for (int i = i0; i < i1; ++i) {
        // The offset reflected through the pixel's noise vector (precomputed per column phase).
        const std::size_t o = static_cast<std::size_t>(i) * k.period + phase;
        const auto vx = hn::LoadU(d, rfx + o), vy = hn::LoadU(d, rfy + o), vz = hn::LoadU(d, rfz + o);
        // Flipped into the normal's hemisphere: (−v)·rs = v·(−rs), the same value.
        const auto flip = hn::Lt(hn::Add(hn::Add(hn::Mul(vx, nx), hn::Mul(vy, ny)), hn::Mul(vz, nz)), zero);
        const auto srs = hn::IfThenElse(flip, neg_rs, rs);
        const auto sx = hn::Add(px, hn::Mul(vx, srs)), sy = hn::Add(py, hn::Mul(vy, srs));
        const auto sz = hn::Add(pz, hn::Mul(vz, srs));
        const auto front = hn::Gt(sz, zero);
        const auto fi = hn::Div(f, sz);
        const auto u = hn::Add(hn::Mul(sx, fi), cx), v = hn::Add(hn::Mul(sy, fi), cy);
        const auto on_screen =
            hn::And(hn::And(front, hn::And(hn::Ge(u, zero), hn::Lt(u, fw))), hn::And(hn::Ge(v, zero), hn::Lt(v, fh)));
        if (hn::AllFalse(d, on_screen)) continue;
        // Lanes off screen read texel 0 and are discarded below.
        const auto qx = hn::ConvertTo(di, hn::IfThenElseZero(on_screen, hn::Add(hn::Mul(u, quarter_px), q_off)));
        const auto qy = hn::ConvertTo(di, hn::IfThenElseZero(on_screen, hn::Add(hn::Mul(v, quarter_px), q_off)));
        const auto zs = hn::GatherIndex(d, q, hn::Add(hn::Mul(qy, vqw), qx));
        const auto a = hn::Mul(hn::Sub(sz, zs), inv_rs);
        const auto ta = hn::Mul(a, tscale);
        const auto hit = hn::And(on_screen, hn::And(hn::Gt(a, zero), hn::Lt(ta, table_end)));
        if (hn::AllFalse(d, hit)) continue;
        const auto ti = hn::ConvertTo(di, hn::IfThenElseZero(hit, ta));
        sum = hn::Add(sum, hn::IfThenElseZero(hit, hn::GatherIndex(d, table, ti)));
      }
      set_ao[set] = hn::Sub(one, hn::Mul(sum, hn::Set(d, inv_count[set])));
    }
    const std::size_t o = static_cast<std::size_t>(y) * w + x;
    hn::StoreU(hn::IfThenElse(finite, hn::Min(set_ao[0], set_ao[1]), one), d, out.ao + o);
    if (out.small) hn::StoreU(hn::IfThenElse(finite, set_ao[0], one), d, out.small + o);
    if (out.wide) hn::StoreU(hn::IfThenElse(finite, set_ao[1], one), d, out.wide + o);
  }
  return x;
}

}  // namespace HWY_NAMESPACE
}  // namespace dofkit::detail::ao
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace dofkit::detail::ao {

HWY_EXPORT(Sc2Row);

void sc2_rows_fast(const Camera& cam, const Image& depth, const Image& n, const Image& quarter, const Sc2Kernel& k,
                   const Sc2Out& out, int y0, int y1) {
  for (int y = y0; y < y1; ++y) {
    const int done = HWY_DYNAMIC_DISPATCH(Sc2Row)(cam, depth, n, quarter, k, out, y, 0, cam.w);
    sc2_span_plain(cam, depth, n, quarter, k, out, y, done, cam.w);
  }
}

}  // namespace dofkit::detail::ao
#endif  // HWY_ONCE
