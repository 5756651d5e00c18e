// CoC models and conversions (docs/coc.md).
#include "dofkit/coc.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "core/clones.hpp"
#include "dofkit/error.hpp"

namespace dofkit {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
inline double saturate(double t) { return t < 0 ? 0 : (t > 1 ? 1 : t); }

// Four-plane ramp; `near_r`/`far_r` already in image pixels.
double four_plane_radius(const FourPlane& p, double z, double near_r, double far_r) {
  if (z <= p.near_blurry_m) return near_r;
  if (z < p.near_sharp_m) {
    const double t = p.linear_in_inverse_depth
                         ? (1 / z - 1 / p.near_sharp_m) / (1 / p.near_blurry_m - 1 / p.near_sharp_m)
                         : (p.near_sharp_m - z) / (p.near_sharp_m - p.near_blurry_m);
    return near_r * t;
  }
  if (z <= p.far_sharp_m) return 0.0;
  if (z < p.far_blurry_m) {
    double t;
    if (p.linear_in_inverse_depth) {
      const double inv_fb = std::isinf(p.far_blurry_m) ? 0.0 : 1 / p.far_blurry_m;
      t = (1 / p.far_sharp_m - 1 / z) / (1 / p.far_sharp_m - inv_fb);
    } else {
      t = std::isinf(p.far_blurry_m) ? 0.0 : (z - p.far_sharp_m) / (p.far_blurry_m - p.far_sharp_m);
    }
    return -far_r * t;
  }
  return -far_r;
}

std::string num(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

void require(bool ok, const std::string& message) {
  if (!ok) throw_usage(message);
}
}  // namespace

double thin_lens_k_px(const ThinLens& lens, double image_width_px) {
  const double f = lens.focal_length_mm;
  const double zf = lens.focus_distance_m * 1000.0;        // mm
  const double p = image_width_px / lens.sensor_width_mm;  // px per mm
  return p * f * f / (2.0 * lens.f_number * (zf - f));
}

double thin_lens_depth_for_coc(double focus_m, double k_px, double r_px) {
  if (k_px + r_px <= 0) return kInf;
  return focus_m * k_px / (k_px + r_px);
}

BlurAtInfinity to_blur_at_infinity(const ThinLens& lens, double image_width_px) {
  return {lens.focus_distance_m, thin_lens_k_px(lens, image_width_px)};
}

void validate(const CameraModel& camera) {
  require(!(camera.max_coc_px <= 0) && !std::isnan(camera.max_coc_px),
          "--max-coc: must be > 0 pixels (got " + num(camera.max_coc_px) + ")");
  require(camera.reference_width_px >= 0 && std::isfinite(camera.reference_width_px),
          "reference width must be >= 0 pixels");
  std::visit(
      [](const auto& m) {
        using T = std::decay_t<decltype(m)>;
        auto finite_pos = [](double v) { return std::isfinite(v) && v > 0; };
        if constexpr (std::is_same_v<T, ThinLens>) {
          require(finite_pos(m.f_number), "--f-number: must be > 0 (got " + num(m.f_number) + ")");
          require(finite_pos(m.focal_length_mm), "--focal-length: must be > 0 mm (got " + num(m.focal_length_mm) + ")");
          require(finite_pos(m.sensor_width_mm), "--sensor-width: must be > 0 mm (got " + num(m.sensor_width_mm) + ")");
          require(std::isfinite(m.focus_distance_m) && m.focus_distance_m * 1000.0 > m.focal_length_mm,
                  "--focus: must be farther than the focal length (" + num(m.focal_length_mm) + " mm); got " +
                      num(m.focus_distance_m) + " m");
        } else if constexpr (std::is_same_v<T, BlurAtInfinity>) {
          require(finite_pos(m.focus_distance_m), "--focus: must be > 0 m (got " + num(m.focus_distance_m) + ")");
          require(std::isfinite(m.blur_at_infinity_px) && m.blur_at_infinity_px >= 0,
                  "--blur-at-infinity: must be >= 0 px (got " + num(m.blur_at_infinity_px) + ")");
        } else if constexpr (std::is_same_v<T, FourPlane>) {
          require(finite_pos(m.near_blurry_m) && m.near_blurry_m < m.near_sharp_m && m.near_sharp_m <= m.far_sharp_m &&
                      m.far_sharp_m < m.far_blurry_m && std::isfinite(m.far_sharp_m),
                  "--planes: need 0 < NB < NS <= FS < FB (got " + num(m.near_blurry_m) + "," + num(m.near_sharp_m) +
                      "," + num(m.far_sharp_m) + "," + num(m.far_blurry_m) + ")");
          require(std::isfinite(m.near_radius_px) && m.near_radius_px >= 0,
                  "--near-radius: must be >= 0 px (got " + num(m.near_radius_px) + ")");
          require(std::isfinite(m.far_radius_px) && m.far_radius_px >= 0,
                  "--far-radius: must be >= 0 px (got " + num(m.far_radius_px) + ")");
        } else if constexpr (std::is_same_v<T, StarCraft>) {
          require(finite_pos(m.focus_distance_m), "--starcraft: FOCUS must be > 0 m");
          require(std::isfinite(m.full_focus_range_m) && m.full_focus_range_m >= 0, "--starcraft: FULL must be >= 0 m");
          require(std::isfinite(m.no_focus_range_m) && m.no_focus_range_m > m.full_focus_range_m,
                  "--starcraft: NONE must be greater than FULL");
          require(std::isfinite(m.amount) && m.amount >= 0, "--starcraft: AMOUNT must be >= 0");
          require(std::isfinite(m.max_radius_px) && m.max_radius_px >= 0,
                  "--starcraft: the maximum radius must be >= 0 px");
        } else if constexpr (std::is_same_v<T, NearFarBlend>) {
          require(m.near_begin_m >= 0 && m.near_begin_m < m.near_end_m && m.near_end_m <= m.far_begin_m &&
                      m.far_begin_m < m.far_end_m && std::isfinite(m.far_begin_m),
                  "near/far blend: need 0 <= nb < ne <= fb < fe");
          require(std::isfinite(m.max_radius_px) && m.max_radius_px >= 0,
                  "near/far blend: the maximum radius must be >= 0 px");
        }
      },
      camera.model);
}

CocFunction::CocFunction(const CameraModel& camera, int image_width_px) : model_(camera.model) {
  const double ref = camera.reference_width_px > 0 ? camera.reference_width_px : image_width_px;
  scale_ = ref > 0 ? image_width_px / ref : 1.0;
  max_coc_ = camera.max_coc_px * scale_;
  // Absolute cap: no parameter may make a radius larger than a quarter of the image width
  // (at least 8 px), so no pass can become quadratic in the image size.
  max_coc_ = std::min(max_coc_, std::max(0.25 * image_width_px, 8.0));
  if (const auto* t = std::get_if<ThinLens>(&model_)) {
    thin_ = true;
    k_ = thin_lens_k_px(*t, image_width_px);
    focus_ = t->focus_distance_m;
  } else if (const auto* b = std::get_if<BlurAtInfinity>(&model_)) {
    thin_ = true;
    k_ = b->blur_at_infinity_px * scale_;
    focus_ = b->focus_distance_m;
  }
}

float CocFunction::operator()(float zf) const noexcept {
  const double z = zf;
  double r;
  if (!(z > 0)) {
    r = max_coc_;  // NaN, zero, negative: treat as touching the lens (validated away by callers)
  } else if (thin_) {
    r = k_ * (focus_ / z - 1.0);
  } else if (const auto* p = std::get_if<FourPlane>(&model_)) {
    r = four_plane_radius(*p, z, p->near_radius_px * scale_, p->far_radius_px * scale_);
  } else if (const auto* s = std::get_if<StarCraft>(&model_)) {
    const double d = z - s->focus_distance_m;
    const double c = std::isinf(d) ? (s->amount > 0 ? std::min(1.0, s->amount) : 0.0)
                                   : saturate(s->amount * std::max(0.0, std::fabs(d) - s->full_focus_range_m) /
                                              (s->no_focus_range_m - s->full_focus_range_m));
    r = (d < 0 ? 1.0 : -1.0) * c * s->max_radius_px * scale_;
  } else if (const auto* n = std::get_if<NearFarBlend>(&model_)) {
    const double nr = saturate((z - n->near_end_m) / (n->near_begin_m - n->near_end_m));
    const double fr = std::isinf(z) ? 1.0 : saturate((z - n->far_begin_m) / (n->far_end_m - n->far_begin_m));
    r = (nr > 0 ? nr : -fr) * n->max_radius_px * scale_;
  } else {
    r = 0;
  }
  if (r > max_coc_) r = max_coc_;
  if (r < -max_coc_) r = -max_coc_;
  return static_cast<float>(r);
}

namespace {
// The thin-lens branch of CocFunction::operator() over a row: the same double arithmetic in
// the same order, so the results are identical. The divisor is made safe before the division
// (z <= 0 and NaN divide 1 and are then replaced by `hi`), which lets the compiler turn the
// branch into a blend and vectorise the division (a conditional division cannot be
// if-converted: it could trap). Compiled for AVX-512F / AVX2 / baseline, picked at run time;
// the sequence (divide, subtract, multiply) contains no multiply-add, so every target rounds
// alike. The selects are if-converted only without -ftrapping-math (DOFKIT_NO_TRAPPING_MATH).
DOFKIT_CLONES DOFKIT_NO_TRAPPING_MATH void thin_lens_row(const float* z, float* r, int n, double k, double focus,
                                                         double hi) {
  const double lo = -hi;
  for (int i = 0; i < n; ++i) {
    const double zd = z[i];
    const bool ok = zd > 0;
    const double q = focus / (ok ? zd : 1.0);
    const double t = k * (q - 1.0);
    double v = ok ? t : hi;
    v = v > hi ? hi : v;
    v = v < lo ? lo : v;
    r[i] = static_cast<float>(v);
  }
}
}  // namespace

void CocFunction::evaluate(const float* z, float* r, int n) const noexcept {
  if (!thin_) {
    for (int i = 0; i < n; ++i) r[i] = (*this)(z[i]);
    return;
  }
  thin_lens_row(z, r, n, k_, focus_, max_coc_);
}

double focus_distance_m(const CocModelKind& model) {
  return std::visit(
      [](const auto& m) -> double {
        using T = std::decay_t<decltype(m)>;
        if constexpr (std::is_same_v<T, FourPlane>)
          return 2 * m.near_sharp_m * m.far_sharp_m / (m.near_sharp_m + m.far_sharp_m);
        else if constexpr (std::is_same_v<T, NearFarBlend>)
          return 0.5 * (m.near_end_m + m.far_begin_m);
        else
          return m.focus_distance_m;
      },
      model);
}

CocModelKind with_focus(const CocModelKind& model, double focus_m) {
  CocModelKind out = model;
  std::visit(
      [&](auto& m) {
        using T = std::decay_t<decltype(m)>;
        if constexpr (std::is_same_v<T, FourPlane>) {
          const double k = focus_m / focus_distance_m(model);
          m.near_blurry_m *= k;
          m.near_sharp_m *= k;
          m.far_sharp_m *= k;
          m.far_blurry_m *= k;
        } else if constexpr (std::is_same_v<T, NearFarBlend>) {
          const double d = focus_m - focus_distance_m(model);
          m.near_begin_m = std::max(0.0, m.near_begin_m + d);
          m.near_end_m += d;
          m.far_begin_m += d;
          m.far_end_m += d;
        } else {
          m.focus_distance_m = focus_m;
        }
      },
      out);
  return out;
}

FourPlane to_four_plane(const BlurAtInfinity& lens, double near_radius_px, double far_radius_px) {
  // The artist ramps start from 0 px at the sharp planes. With ramps linear in 1/z (the
  // physical law) the conversion is exact when both sharp planes sit at the focus distance,
  // where the physical radius is 0: r_art(z) = R_n (1/z − 1/z_F)/(1/z_nb − 1/z_F) = K (z_F/z − 1).
  const double zf = lens.focus_distance_m, k = lens.blur_at_infinity_px;
  FourPlane p;
  p.near_sharp_m = zf;
  p.far_sharp_m = zf;
  p.near_blurry_m = thin_lens_depth_for_coc(zf, k, near_radius_px);
  p.far_blurry_m = thin_lens_depth_for_coc(zf, k, -far_radius_px);
  p.near_radius_px = near_radius_px;
  p.far_radius_px = far_radius_px;
  p.linear_in_inverse_depth = true;
  return p;
}

BlurAtInfinity to_thin_lens(const FourPlane& planes) {
  const double zf = 2 * planes.near_sharp_m * planes.far_sharp_m / (planes.near_sharp_m + planes.far_sharp_m);
  if (planes.linear_in_inverse_depth || !(zf > planes.near_sharp_m)) {
    // No plateau (or 1/z ramps): K from the near-blurry plane, r(z_nb) = R_n = K (z_F/z_nb − 1).
    const double t = zf / planes.near_blurry_m - 1.0;
    return {zf, t > 0 ? planes.near_radius_px / t : 0.0};
  }
  // Linear ramps with a sharp plateau: fit through the sharp planes, where the physical
  // radius is 0.5 px: 0.5 = K (z_F/z_ns − 1).
  return {zf, 0.5 * planes.near_sharp_m / (zf - planes.near_sharp_m)};
}

FourPlane to_four_plane(const StarCraft& sc) {
  FourPlane p;
  p.near_sharp_m = sc.focus_distance_m - sc.full_focus_range_m;
  p.far_sharp_m = sc.focus_distance_m + sc.full_focus_range_m;
  const double ramp = sc.no_focus_range_m - sc.full_focus_range_m;
  double delta, level;
  if (sc.amount >= 1) {
    delta = sc.full_focus_range_m + ramp / sc.amount;
    level = 1.0;
  } else {
    delta = sc.no_focus_range_m;
    level = sc.amount;
  }
  p.near_blurry_m = std::max(1e-6, sc.focus_distance_m - delta);
  p.far_blurry_m = sc.focus_distance_m + delta;
  p.near_radius_px = level * sc.max_radius_px;
  p.far_radius_px = level * sc.max_radius_px;
  return p;
}

StarCraft to_starcraft(const FourPlane& planes) {
  StarCraft s;
  s.focus_distance_m = 0.5 * (planes.near_sharp_m + planes.far_sharp_m);
  s.full_focus_range_m = 0.5 * (planes.far_sharp_m - planes.near_sharp_m);
  const double near_d = s.focus_distance_m - planes.near_blurry_m;
  const double far_d = std::isinf(planes.far_blurry_m) ? near_d : planes.far_blurry_m - s.focus_distance_m;
  s.no_focus_range_m = 0.5 * (near_d + far_d);
  s.amount = 1.0;
  s.max_radius_px = 0.5 * (planes.near_radius_px + planes.far_radius_px);
  return s;
}

NearFarBlend near_far_from_focus(double focus_m, double transition_m, double max_radius_px) {
  NearFarBlend n;
  n.near_begin_m = std::max(focus_m - transition_m, 0.0);
  n.near_end_m = focus_m;
  n.far_begin_m = focus_m;
  n.far_end_m = focus_m + transition_m;
  n.max_radius_px = max_radius_px;
  return n;
}

std::string describe(const CameraModel& camera) {
  std::ostringstream s;
  std::visit(
      [&](const auto& m) {
        using T = std::decay_t<decltype(m)>;
        if constexpr (std::is_same_v<T, ThinLens>)
          s << "thin lens f=" << m.focal_length_mm << "mm N=" << m.f_number << " focus=" << m.focus_distance_m
            << "m sensor=" << m.sensor_width_mm << "mm";
        else if constexpr (std::is_same_v<T, BlurAtInfinity>)
          s << "thin lens focus=" << m.focus_distance_m << "m K=" << m.blur_at_infinity_px << "px";
        else if constexpr (std::is_same_v<T, FourPlane>)
          s << "four planes " << m.near_blurry_m << "," << m.near_sharp_m << "," << m.far_sharp_m << ","
            << m.far_blurry_m << "m near=" << m.near_radius_px << "px far=" << m.far_radius_px << "px";
        else if constexpr (std::is_same_v<T, StarCraft>)
          s << "starcraft focus=" << m.focus_distance_m << "m full=" << m.full_focus_range_m
            << "m none=" << m.no_focus_range_m << "m amount=" << m.amount << " max=" << m.max_radius_px << "px";
        else
          s << "near/far blend " << m.near_begin_m << "," << m.near_end_m << "," << m.far_begin_m << "," << m.far_end_m
            << "m max=" << m.max_radius_px << "px";
      },
      camera.model);
  if (std::isfinite(camera.max_coc_px)) s << " max-coc=" << camera.max_coc_px << "px";
  if (camera.reference_width_px > 0) s << " at width " << camera.reference_width_px << "px";
  return s.str();
}

}  // namespace dofkit
