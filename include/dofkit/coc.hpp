// dofkit — camera and circle-of-confusion (CoC) models.
//
// Every model maps a planar depth z (scene units, metres by default) to a *signed CoC radius
// in pixels*: r > 0 near field (in front of focus), r < 0 far field, |r| <= 0.5 in focus.
// Radii given in pixels are specified at `CameraModel::reference_width_px` and scale with
// the width of the image being rendered (a 2x larger image gets 2x larger radii), so the
// same camera gives the same picture at any resolution. See docs/coc.md for the formulas.
#pragma once
#include <limits>
#include <string>
#include <variant>

namespace dofkit {

/// Physical thin lens: r(z) = K (z_F / z − 1) with K = (W / S_w) f² / (2 N (z_F − f)).
struct ThinLens {
  double focal_length_mm = 50.0;  ///< f, millimetres (> 0)
  double f_number = 2.8;          ///< N, dimensionless (> 0)
  double focus_distance_m = 5.0;  ///< z_F, metres (> focal length)
  double sensor_width_mm = 36.0;  ///< S_w, millimetres (> 0); the image width spans it
};

/// Thin lens given directly by its blur radius at infinity: r(z) = K (z_F / z − 1).
struct BlurAtInfinity {
  double focus_distance_m = 5.0;     ///< z_F, metres (> 0)
  double blur_at_infinity_px = 8.0;  ///< K, pixels at the reference width (>= 0)
};

/// Artist four-plane model (Skylanders / G3D): z_nb < z_ns <= z_fs < z_fb, linear ramps
/// from 0 at the sharp planes to ±R at the blurry planes, constant beyond.
struct FourPlane {
  double near_blurry_m = 0.5;  ///< z_nb, metres: nearer than this → radius near_radius_px
  double near_sharp_m = 2.0;   ///< z_ns, metres: sharp from here …
  double far_sharp_m = 4.0;    ///< z_fs, metres: … to here
  double far_blurry_m = 20.0;  ///< z_fb, metres: farther than this → radius −far_radius_px
  double near_radius_px = 16;  ///< R_n, pixels at the reference width (>= 0)
  double far_radius_px = 8;    ///< R_f, pixels at the reference width (>= 0)
  /// Ramps linear in 1/z instead of z (matches the physical law between the planes).
  bool linear_in_inverse_depth = false;
};

/// StarCraft II: level c(z) = saturate(amount · max(0, |z − F| − full) / (none − full)) in
/// [0, 1] selects a blur level. To drive other methods it maps to a signed radius
/// r = ±c · max_radius_px (sign by side of the focus distance).
struct StarCraft {
  double focus_distance_m = 5.0;    ///< F, metres
  double full_focus_range_m = 0.5;  ///< R_full, metres: |z − F| below this is sharp
  double no_focus_range_m = 5.0;    ///< R_none, metres (> R_full): full blur from here (amount 1)
  double amount = 1.0;              ///< α, dimensionless (>= 0)
  double max_radius_px = 16.0;      ///< radius of level 1, pixels at the reference width
};

/// Sterna's near/far blend factors: near = saturate((z − ne)/(nb − ne)),
/// far = saturate((z − fb)/(fe − fb)); r = near·max_radius_px or −far·max_radius_px.
/// The demo's controls (focus F, transition T) give nb = max(F − T, 0), ne = fb = F, fe = F + T.
struct NearFarBlend {
  double near_begin_m = 1.0;    ///< nb, metres: fully near-blurred at and inside this
  double near_end_m = 5.0;      ///< ne, metres: near blend reaches 0 here
  double far_begin_m = 5.0;     ///< fb, metres: far blend starts here
  double far_end_m = 10.0;      ///< fe, metres: fully far-blurred from here
  double max_radius_px = 12.0;  ///< radius at blend 1, pixels at the reference width
};

using CocModelKind = std::variant<BlurAtInfinity, ThinLens, FourPlane, StarCraft, NearFarBlend>;

/// A camera = a CoC model + the resolution its pixel radii refer to + a clamp.
struct CameraModel {
  CocModelKind model = BlurAtInfinity{};
  /// Width (px) at which the model's pixel radii are given. 0 = the rendered image's width.
  /// ThinLens needs none (its radius follows W / S_w).
  double reference_width_px = 0.0;
  /// Clamp |r| to this many pixels at the reference width (+inf = no clamp).
  double max_coc_px = std::numeric_limits<double>::infinity();
};

/// Throws Error(usage) naming the parameter if the model is inconsistent (f-number <= 0,
/// focus <= focal length, planes out of order, negative radius …).
void validate(const CameraModel& camera);

/// Evaluates a camera's signed CoC for an image of a given width. Cheap to copy.
class CocFunction {
 public:
  CocFunction(const CameraModel& camera, int image_width_px);
  /// Signed CoC radius in pixels at this image width, clamped to ±max_coc. z = +inf is
  /// valid (the far limit). NaN or z <= 0 gives the near clamp value.
  float operator()(float z) const noexcept;
  /// r[i] = (*this)(z[i]) for i < n, bit for bit, with a vectorisable loop for the thin lens.
  void evaluate(const float* z, float* r, int n) const noexcept;
  /// Factor from reference-width pixels to image pixels.
  double scale() const noexcept { return scale_; }
  /// Clamp in image pixels (+inf if none).
  double max_coc_px() const noexcept { return max_coc_; }

 private:
  CocModelKind model_;
  double scale_ = 1.0;
  double max_coc_ = std::numeric_limits<double>::infinity();
  double k_ = 0.0, focus_ = 0.0;  // thin-lens cache: r = k (focus / z − 1)
  bool thin_ = false;
};

/// K (blur radius at infinity, px) of a thin lens for an image `image_width_px` wide.
double thin_lens_k_px(const ThinLens& lens, double image_width_px);
/// Depth whose thin-lens CoC is r: z(r) = z_F K / (K + r); +inf for r <= −K.
double thin_lens_depth_for_coc(double focus_m, double k_px, double r_px);
/// The focus distance a model is centred on, if it has one (four-plane: harmonic mean of
/// the sharp planes).
double focus_distance_m(const CocModelKind& model);
/// Returns a copy of the model refocused to `focus_m` (four-plane: all planes move by the
/// same ratio; Sterna planes shift by the same offset).
CocModelKind with_focus(const CocModelKind& model, double focus_m);

// Conversions of docs/coc.md. Pixel radii stay at the same reference width.
/// Thin lens (as BlurAtInfinity) → four planes with maxima R_n, R_f and ramps linear in 1/z,
/// sharp planes at the focus distance: reproduces the physical curve exactly up to the
/// blurry planes (z_fb = +inf if R_f >= K).
FourPlane to_four_plane(const BlurAtInfinity& lens, double near_radius_px, double far_radius_px);
/// Four planes → thin lens: z_F = harmonic mean of the sharp planes; K through the sharp
/// planes (K = 0.5 z_ns/(z_F − z_ns)) for linear ramps with a plateau, else through the
/// near-blurry plane (exact inverse of the conversion above).
BlurAtInfinity to_thin_lens(const FourPlane& planes);
/// StarCraft II → four planes (symmetric).
FourPlane to_four_plane(const StarCraft& sc);
/// Four planes → StarCraft II (exact only when symmetric; otherwise the mean).
StarCraft to_starcraft(const FourPlane& planes);
/// Sterna demo controls (focus F, transition T) → blend planes.
NearFarBlend near_far_from_focus(double focus_m, double transition_m, double max_radius_px);
/// ThinLens → BlurAtInfinity at a given image width.
BlurAtInfinity to_blur_at_infinity(const ThinLens& lens, double image_width_px);

/// Human-readable one-line description of a model (for reports and params.json).
std::string describe(const CameraModel& camera);

}  // namespace dofkit
