// P1 (docs/methods/sterna.md): separate near and far blend factors at full resolution.
//
// Sterna's near/far values are not radii: the gather kernel has one fixed size and the two
// factors only say how much of the blurred field replaces the sharp pixel. A NearFarBlend
// camera *is* that model, so its planes are evaluated directly from z (native):
//   near = saturate((z − ne)/(nb − ne)),  far = saturate((z − fb)/(fe − fb)).
// Any other camera gives a signed radius r (px at this width). A field whose true radius is
// r is approximated by the fixed kernel of radius R blended in by r/R; we start the ramp at
// the edge of the focus field (|r| = ½ px) so that in-focus pixels get exactly 0 and stay
// untouched: near = saturate((r − ½)/(R − ½)), far = saturate((−r − ½)/(R − ½)).
#include <algorithm>
#include <cmath>
#include <variant>

#include "core/parallel.hpp"
#include "methods/sterna/passes.hpp"

namespace dofkit::detail::sterna {

namespace {
// NaN-safe: NaN → 0 (the comparisons are false).
inline float saturate(float v) { return v > 0.0f ? (v < 1.0f ? v : 1.0f) : 0.0f; }
inline float saturate(double v) { return v > 0.0 ? static_cast<float>(v < 1.0 ? v : 1.0) : 0.0f; }
}  // namespace

void compute_full_coc(const MethodContext& ctx, const Settings& s, FullCoc& out) {
  const int w = ctx.frame.width(), h = ctx.frame.height();
  out.coc.resize(w, h, 2);
  const NearFarBlend* nfb = std::get_if<NearFarBlend>(&ctx.camera.model);
  // The blend planes are used in double: two planes that differ only beyond float precision
  // would otherwise give 0/0.
  const double nb = nfb ? nfb->near_begin_m : 0.0;
  const double ne = nfb ? nfb->near_end_m : 0.0;
  const double fb = nfb ? nfb->far_begin_m : 0.0;
  const double fe = nfb ? nfb->far_end_m : 0.0;
  const float ramp = std::max(s.blend_radius_px - 0.5f, 1e-3f);
  core::parallel_for(
      h,
      [&](int y0, int y1) {
        for (int y = y0; y < y1; ++y) {
          float* n = out.coc.row(0, y);
          float* f = out.coc.row(1, y);
          if (nfb) {
            const float* z = ctx.frame.depth.row(0, y);
            for (int x = 0; x < w; ++x) {
              // z = +inf: the near ratio is −inf → 0 and the far ratio +inf → 1.
              n[x] = saturate((z[x] - ne) / (nb - ne));
              f[x] = std::isinf(z[x]) ? 1.0f : saturate((z[x] - fb) / (fe - fb));
              if (n[x] > 0.0f && f[x] > 0.0f) f[x] = 0.0f;  // overlapping planes: near wins
            }
          } else {
            const float* r = ctx.coc.row(0, y);
            for (int x = 0; x < w; ++x) {
              n[x] = saturate((r[x] - 0.5f) / ramp);
              f[x] = saturate((-r[x] - 0.5f) / ramp);
            }
          }
        }
      },
      16);
}

}  // namespace dofkit::detail::sterna
