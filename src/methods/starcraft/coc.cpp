// C1 — the blur level c per pixel, and the sizes of the levels.
//
// Native model (camera = StarCraft): c = saturate(α · max(0, |z − F| − R_full) / (R_none − R_full)),
// the chapter's ComputeCOC, evaluated at full resolution.
// Any other camera gives a signed radius r (px); it is mapped onto the levels so that the
// blur at every pixel has the variance of the camera's disc (LevelGeometry::level_of_radius).
#include <algorithm>
#include <cmath>
#include <variant>

#include "core/parallel.hpp"
#include "methods/starcraft/final_simd.hpp"
#include "methods/starcraft/starcraft.hpp"

namespace dofkit::detail::starcraft {

namespace {

/// The camera's characteristic blur radius in image px: what "fully blurred" means for it.
/// Thin lens: K, the radius at infinity (the far field never exceeds it; nearer objects
/// beyond K saturate at the large level). Artist models: their maximum radius.
double characteristic_radius(const MethodContext& ctx) {
  const double scale = ctx.coc_of.scale();
  const double w = ctx.frame.width();
  const double r = std::visit(
      [&](const auto& m) -> double {
        using T = std::decay_t<decltype(m)>;
        if constexpr (std::is_same_v<T, ThinLens>)
          return thin_lens_k_px(m, w);
        else if constexpr (std::is_same_v<T, BlurAtInfinity>)
          return m.blur_at_infinity_px * scale;
        else if constexpr (std::is_same_v<T, FourPlane>)
          return std::max(m.near_radius_px, m.far_radius_px) * scale;
        else if constexpr (std::is_same_v<T, StarCraft>)
          return m.max_radius_px * scale;
        else
          return m.max_radius_px * scale;  // NearFarBlend
      },
      ctx.camera.model);
  return std::min(r, ctx.coc_of.max_coc_px());
}

}  // namespace

LevelGeometry make_geometry(const MethodContext& ctx, const Settings& s) {
  LevelGeometry g;
  g.native = std::holds_alternative<StarCraft>(ctx.camera.model);
  g.r_small = 2.0f * std::sqrt(24.0f / 17.0f);
  double rl = s.large_radius_px > 0 ? s.large_radius_px * ctx.coc_of.scale() : characteristic_radius(ctx);
  // Keep the levels ordered (each at least 25 % wider than the one below) so the mapping is
  // monotonic even for a camera that barely blurs; such a camera then never reaches c = 1.
  double rm = std::max(s.medium_fraction * rl, 1.25 * g.r_small);
  rl = std::max(rl, 1.25 * rm);
  g.r_medium = static_cast<float>(rm);
  g.r_large = static_cast<float>(rl);
  g.sigma_medium = static_cast<float>(s.sigma_per_radius * rm);
  g.sigma_large = static_cast<float>(s.sigma_per_radius * rl);
  g.sigma_depth = static_cast<float>(s.depth_blur * g.sigma_large);
  return g;
}

void compute_levels(const MethodContext& ctx, const LevelGeometry& g, Image& level, bool plain) {
  const int w = ctx.frame.width(), h = ctx.frame.height();
  level.resize(w, h, 1);
  const StarCraft* sc = std::get_if<StarCraft>(&ctx.camera.model);
  core::parallel_for(
      h,
      [&](int y0, int y1) {
        for (int y = y0; y < y1; ++y) {
          float* c = level.row(0, y);
          if (sc) {
            const float* z = ctx.frame.depth.row(0, y);
            const double range = sc->no_focus_range_m - sc->full_focus_range_m;
            for (int x = 0; x < w; ++x) {
              const double d = std::fabs(static_cast<double>(z[x]) - sc->focus_distance_m);
              // |z − F| = +inf for the sky: the limit of the formula is 1 when α > 0.
              const double t = std::isinf(d) ? (sc->amount > 0 ? 1.0 : 0.0)
                                             : sc->amount * std::max(0.0, d - sc->full_focus_range_m) / range;
              c[x] = static_cast<float>(std::clamp(t, 0.0, 1.0));
            }
          } else {
            const float* r = ctx.coc.row(0, y);
            if (plain) {
              for (int x = 0; x < w; ++x) c[x] = g.level_of_radius(r[x]);
            } else {
              int x = levels_row_simd(r, c, 0, w, g.r_small * g.r_small - 0.25f, g.r_medium * g.r_medium - 0.25f,
                                      g.r_large * g.r_large - 0.25f);
              for (; x < w; ++x) c[x] = g.level_of_radius(r[x]);
            }
          }
        }
      },
      16);
}

}  // namespace dofkit::detail::starcraft
