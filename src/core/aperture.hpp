// The aperture model shared by every method that can draw a bokeh shape (reference, scatter,
// layered's disc mode, sterna's taps, the fast `lens` method) and by the ground-truth ray
// tracer: one definition of the footprint a source pixel spreads over, so that they all agree.
//
// Coordinates: screen pixels, x right, y DOWN (image rows), offsets (dx, dy) = receiver − source.
// A source's footprint has radius rho = max(|r|, 0.5) px (r = its signed CoC) and a field side:
// Field::far for r <= 0 (behind the focus plane: the aperture as it is), Field::near for r > 0
// (in front: the aperture turned by 180°, i.e. the far footprint point-reflected).
//
// The footprint (see include/dofkit/aperture.hpp for the user-facing conventions):
//   * analytic shapes (circle, polygon, curved blades, anamorphic) have a gauge T(dx, dy) per
//     field, independent of the radius, and the anti-aliased coverage
//         cov = sat(lim(rho) − T(dx, dy)),  lim(rho) = (s/μ)·(rho − 0.5) + 1   (sat: clamp to [0, 1])
//     With q = (anamorphic·dx, −dy) (far field; y up, squeezed), h(q) = max_k (n_k · q) over the
//     blades' edge normals n_k (the first at rotation_deg, counter-clockwise), c the curvature,
//         G(q) = (1 − c)·h(q) + c·|q|,  s = (1 − c)·cos(π/n) + c,  μ = s·min(anamorphic, 1),
//     the gauge is T = G(q)/μ: convex, positively homogeneous and T(p) >= |p|. The footprint's
//     half-coverage contour is G = s·(rho − 0.5) + μ/2, i.e. G = s·rho (vertices on the circle of
//     radius rho, Cycles' convention) when not squeezed wider; at rho = 0.5 only the centre
//     offset is covered, for every shape (an in-focus pixel stays itself). For the plain circle
//     T = sqrtf(dx² + dy²) in float and lim = rho + 0.5f: the coverage the reference always had.
//   * an aperture image: cov = the image (normalised to a maximum of 1 per channel, rotated,
//     squeezed, its longer side spanning 2·rho) box-filtered over the receiver pixel's square
//     (a footprint that rotation or squeeze makes wider than 2·rho is scaled down by up to half a
//     pixel, so that at rho = 0.5 it still fits the centre pixel).
//     Rasters are made per radius (kernel()); KernelBank keeps them for a quantised set of radii.
//   * cat's eye (position dependent): cov = min(cov, sat(rho + 0.5 − |(a·(dx − ox), dy − oy)|))
//     (a = anamorphic: the second circle is squeezed like the aperture's) with its centre
//     o = eye_offset(rho, field, sx, sy) (far field: toward the frame centre).
//
// API for the methods, in the order a scatter or gather needs it:
//   (a) coverage(dx, dy, rho, field, sx, sy, c): the coverage in [0, 1] of one offset from a
//       source at pixel centre (sx, sy) (used only with cat's eye), channel c (RGB images).
//   (b) row_span(dy, rho, field, sx, sy): conservative [x0, x1] — every dx with non-zero
//       coverage on row offset dy lies in it (for span / prefix-sum scatters);
//       row_interior(...): a span where the coverage is exactly 1 (every channel; may be empty).
//       reach(rho): the largest |dx| or |dy| with non-zero coverage.
//   (c) weight_sum(rho, field, sx, sy, c): the exact energy normaliser, the sum of the coverages
//       of every integer offset (double). Equal for both fields.
//   (d) kernel(rho, field, sx, sy, c): the coverage raster (2·reach + 1)² of one footprint;
//       KernelBank: rasters and sums for radii quantised to 1/8 px (aperture images).
//   For SIMD scatters of analytic shapes: gauge(dx, dy, field) is T (fill a table once, then
//   cov = sat(lim(rho) − T)); since T >= |p| the footprint lies in the circle |p| < lim(rho), and
//   inner_scale() M gives T <= M·|p| (so |p| <= (lim − 1)/M has coverage 1).
//   For fixed tap patterns (sterna) and lens sampling (the tracer): unit_transmission() and
//   unit_boundary_map() describe the continuous footprint of radius 1, without cat's eye.
//
// Thread safety: every const member may be called from any thread.
#pragma once
#include <algorithm>
#include <array>
#include <cstddef>
#include <memory>
#include <vector>

#include "dofkit/aperture.hpp"
#include "dofkit/image.hpp"

namespace dofkit::core {

enum class Field : int { far = 0, near = 1 };
/// The field side of a signed CoC (r > 0: near).
inline Field field_of(float coc) noexcept { return coc > 0.0f ? Field::near : Field::far; }

/// Integer span [x0, x1] of offsets; empty when x0 > x1.
struct Span {
  int x0 = 0, x1 = -1;
  bool empty() const noexcept { return x0 > x1; }
};

class ApertureModel {
 public:
  /// The circle (no image size needed).
  ApertureModel();
  /// Validates `shape` (dofkit::validate) and prepares it for frames of width × height px
  /// (the frame size matters only for cat's eye).
  ApertureModel(const ApertureShape& shape, int width, int height);

  const ApertureShape& shape() const noexcept { return shape_; }
  bool is_circle() const noexcept { return kind_ == Kind::circle; }
  bool has_image() const noexcept { return kind_ == Kind::image; }
  /// Whether the footprint depends on the source position (cat's eye).
  bool position_dependent() const noexcept { return eye_ > 0.0; }
  /// Coverage channels: 3 for an RGB aperture image, else 1.
  int channels() const noexcept { return channels_; }

  // (a)
  float coverage(int dx, int dy, float rho, Field f, float sx = 0, float sy = 0, int c = 0) const;
  /// The second circle's centre (px, relative to the source) for cat's eye; (0, 0) when off.
  void eye_offset(float rho, Field f, float sx, float sy, float& ox, float& oy) const;

  // (b)
  Span row_span(int dy, float rho, Field f, float sx = 0, float sy = 0) const;
  Span row_interior(int dy, float rho, Field f, float sx = 0, float sy = 0) const;
  int reach(float rho) const;

  // (c)
  double weight_sum(float rho, Field f, float sx = 0, float sy = 0, int c = 0) const;

  // (d)
  struct Kernel {
    int reach = 0;           ///< offsets −reach..reach in x and y
    std::vector<float> cov;  ///< (2·reach + 1)² coverages, row dy = −reach first
    double sum = 0;          ///< Σ cov (the normaliser)
    float at(int dx, int dy) const { return cov[static_cast<std::size_t>(dy + reach) * (2 * reach + 1) + dx + reach]; }
  };
  /// With eye = false the cat's eye is left out (the shape alone, as KernelBank keeps it).
  Kernel kernel(float rho, Field f, float sx = 0, float sy = 0, int c = 0, bool eye = true) const;
  /// coverage() without the cat's eye.
  float shape_coverage(int dx, int dy, float rho, Field f, int c = 0) const;
  /// The cat's eye's own coverage sat(rho + 0.5 − |(dx, dy) − o|) (1 when it is off).
  float eye_coverage(int dx, int dy, float rho, Field f, float sx, float sy) const;

  // Analytic shapes (not images): the gauge and its scales (see the top of this file).
  float gauge(int dx, int dy, Field f) const;
  /// lim(rho) of the coverage (analytic shapes; the circle's is rho + 0.5f).
  float lim(float rho) const noexcept { return kind_ == Kind::circle ? rho + 0.5f : level_ * (rho - 0.5f) + 1.0f; }
  float inner_scale() const noexcept { return static_cast<float>(m_); }

  // The continuous footprint of radius 1 (screen coordinates, far field unless f says near),
  // without cat's eye: transmission in [0, 1] (analytic: 0 or 1; image: bilinear, max 1).
  double unit_transmission(double x, double y, Field f, int c = 0) const;
  /// Analytic shapes: maps a point (ux, uy) of the unit disc (screen coordinates) to the unit
  /// footprint by moving it radially (the boundary of the disc onto the boundary of the shape,
  /// the centre stays), then applying the anamorphic squeeze; far field.
  void unit_boundary_map(double ux, double uy, double& x, double& y) const;
  /// Half-extent of the unit footprint's bounding box (x, y), far field.
  double unit_extent_x() const noexcept { return ext_x_; }
  double unit_extent_y() const noexcept { return ext_y_; }

 private:
  enum class Kind { circle, analytic, image };
  double gauge_d(double x, double y) const;  // T for the far field, double
  float image_cov(int dx, int dy, float rho, Field f, int c) const;
  // The image footprint's scale (px per unit): rho, less what keeps a footprint wider than
  // [−1, 1]² (a rotated image) inside the centre pixel at rho = 0.5.
  double image_scale(float rho) const { return double(rho) - 0.5 + 0.5 / std::max({ext_x_, ext_y_, 1.0}); }
  // Exact row extents of the analytic footprint {T < level} (far field, without cat's eye):
  // an outer interval (every point with T < level) and an inner one (T <= level there).
  bool outer_extent(double y, double level, double& x0, double& x1) const;
  bool inner_extent(double y, double level, double& x0, double& x1) const;
  Span span_of(int dy, float rho, Field f, float sx, float sy, bool interior, bool eye = true) const;

  ApertureShape shape_;
  Kind kind_ = Kind::circle;
  int channels_ = 1;
  int width_ = 0, height_ = 0;
  double eye_ = 0;
  // Analytic: blade normals (y up), curvature, scales.
  std::vector<double> nx_, ny_;
  double apothem_ = 1;  // cos(π/n)
  double curv_ = 0, ratio_ = 1, s_ = 1, mu_ = 1, m_ = 1, beta_ = 1;
  float level_ = 1;  // s/μ
  double ext_x_ = 1, ext_y_ = 1;
  // Image: the footprint resampled onto a square grid of n×n cells covering [−ext, ext]² of
  // the unit footprint (far field), per channel, with summed-area tables for box filtering.
  struct Canon {
    int n = 0;
    double ext = 1;                        // half side, unit footprint units
    std::vector<std::vector<float>> cell;  // per channel, n·n, max 1
    std::vector<std::vector<double>> sat;  // per channel, (n+1)², sat[j][i] = Σ cells x<i, y<j
  };
  std::shared_ptr<const Canon> canon_;
};

/// Rasters of an aperture image (or any shape) for every radius a frame uses, quantised to
/// `step` px (1/8 px unless that would exceed ~64 M floats; see step()), without the cat's eye;
/// near rasters are the far ones point-reflected. Each raster row carries `pad` zeros on both
/// sides (so vector loads may run past the footprint). Made once per render; read by any thread.
class KernelBank {
 public:
  KernelBank(const ApertureModel& model, float rho_max, int channel, int pad = 0);
  int bucket(float rho) const noexcept;
  float bucket_rho(int b) const noexcept { return 0.5f + b * step_; }
  float step() const noexcept { return step_; }
  /// Raster of bucket b, field f: row dy at raster(b, f) + (dy + reach(b))·pitch(b), column dx
  /// at + dx + reach(b); columns −reach − pad … reach + pad are readable (zero outside).
  const float* raster(int b, Field f) const noexcept { return data_.data() + offset_[b][static_cast<int>(f)]; }
  int reach(int b) const noexcept { return reach_[b]; }
  int pitch(int b) const noexcept { return 2 * reach_[b] + 1 + 2 * pad_; }
  double sum(int b) const noexcept { return sum_[b]; }
  /// Exact non-zero extent of row dy of bucket b, field f (empty if none).
  Span row_span(int b, Field f, int dy) const noexcept;

 private:
  float step_ = 0.125f;
  int pad_ = 0;
  std::vector<int> reach_;
  std::vector<double> sum_;
  std::vector<std::array<std::size_t, 2>> offset_;  // per bucket: far and near raster in data_
  std::vector<float> data_;
  std::vector<std::size_t> span_off_;  // per bucket: its far rows' spans in spans_ (near: point-reflected)
  std::vector<Span> spans_;
};

}  // namespace dofkit::core
