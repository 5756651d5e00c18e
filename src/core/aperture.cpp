// The aperture model (see aperture.hpp) and the validation of the public settings.
#include "core/aperture.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>

#include "core/parallel.hpp"
#include "dofkit/error.hpp"

namespace dofkit {

namespace {
std::string num(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}
}  // namespace

void validate(const ApertureShape& a) {
  if (a.blades != 0 && (a.blades < 3 || a.blades > 16))
    throw_usage("--blades: must be 0 (circle) or 3..16 (got " + std::to_string(a.blades) + ")");
  if (!std::isfinite(a.rotation_deg)) throw_usage("--blade-rotation: must be a finite number of degrees");
  if (!(a.curvature >= 0.0 && a.curvature <= 1.0))
    throw_usage("--blade-curvature: must be in [0, 1] (0 = straight blades, 1 = circle; got " + num(a.curvature) + ")");
  if (!(a.anamorphic >= 0.1 && a.anamorphic <= 10.0))
    throw_usage("--anamorphic: must be in [0.1, 10] (1 = round bokeh; got " + num(a.anamorphic) + ")");
  if (!(a.cat_eye >= 0.0 && a.cat_eye <= 1.0))
    throw_usage("--cat-eye: must be in [0, 1] (0 = off; got " + num(a.cat_eye) + ")");
  if (a.image) {
    const Image& img = *a.image;
    if (img.empty() || img.width() <= 0 || img.height() <= 0) throw_usage("--aperture-image: the image is empty");
    if (img.width() > 1024 || img.height() > 1024)
      throw_usage("--aperture-image: " + std::to_string(img.width()) + "x" + std::to_string(img.height()) +
                  " is larger than 1024x1024");
    if (img.channels() != 1 && img.channels() != 3 && img.channels() != 4)
      throw_usage("--aperture-image: expected 1 (grey), 3 (RGB) or 4 (RGBA) planes, got " +
                  std::to_string(img.channels()));
    const int used = img.channels() == 1 ? 1 : 3;
    for (int c = 0; c < used; ++c) {
      double sum = 0;
      const float* p = img.plane(c);
      for (std::size_t i = 0; i < img.plane_size(); ++i) {
        if (!std::isfinite(p[i]) || p[i] < 0)
          throw_usage("--aperture-image: pixel (" + std::to_string(i % img.width()) + ", " +
                      std::to_string(i / img.width()) + ") is " + num(p[i]) + " (must be finite and >= 0)");
        sum += p[i];
      }
      if (!(sum > 0))
        throw_usage(used == 1 ? std::string("--aperture-image: the image is all black (no light passes)")
                              : std::string("--aperture-image: channel ") + "RGB"[c] +
                                    " is all black (every colour channel must let some light through)");
    }
  }
}

void validate(const HighlightRecovery& h) {
  if (!(h.threshold >= 0.0 && h.threshold < 1.0))
    throw_usage("--highlight-threshold: must be in [0, 1) (a display value; got " + num(h.threshold) + ")");
  if (!(h.boost >= 0.0) || !std::isfinite(h.boost))
    throw_usage("--highlight-boost: must be a finite number >= 0 (0 = off; got " + num(h.boost) + ")");
}

}  // namespace dofkit

namespace dofkit::core {

namespace {
constexpr double kPi = std::numbers::pi;
inline float sat(float v) { return std::min(std::max(v, 0.0f), 1.0f); }
// Float safety margin (px) of the integer spans: the gauge and the level are floats, ~1e-7
// relative; the margin is far larger, and a span only has to be conservative.
inline double margin(double level) { return 1e-3 + 1e-5 * level; }
}  // namespace

ApertureModel::ApertureModel() = default;

ApertureModel::ApertureModel(const ApertureShape& shape, int width, int height)
    : shape_(shape), width_(width), height_(height) {
  validate(shape);
  eye_ = shape.cat_eye;
  ratio_ = shape.anamorphic;

  const double theta = shape.rotation_deg * kPi / 180.0;
  if (shape.image) {
    kind_ = Kind::image;
    const Image& img = *shape.image;
    // Grey unless R, G and B differ somewhere.
    channels_ = 1;
    if (img.channels() >= 3)
      for (std::size_t i = 0; i < img.plane_size() && channels_ == 1; ++i)
        if (img.plane(0)[i] != img.plane(1)[i] || img.plane(0)[i] != img.plane(2)[i]) channels_ = 3;
    const int w = img.width(), h = img.height(), L = std::max(w, h);
    // Image coordinates: u in [−w/L, w/L], v in [−h/L, h/L] (v down). Footprint p = S·R·(u, v):
    // R turns counter-clockwise on screen, S divides x by the anamorphic ratio.
    const double ct = std::cos(theta), st = std::sin(theta);
    const bool identity = std::fmod(shape.rotation_deg, 360.0) == 0.0 && ratio_ == 1.0;
    double ext = 0;
    for (int k = 0; k < 4; ++k) {
      const double u = (k & 1 ? 1 : -1) * double(w) / L, v = (k & 2 ? 1 : -1) * double(h) / L;
      ext = std::max({ext, std::abs((u * ct + v * st) / ratio_), std::abs(-u * st + v * ct)});
    }
    auto canon = std::make_shared<Canon>();
    canon->n = identity ? L : std::clamp(static_cast<int>(std::ceil(L * ext * std::max(1.0, 1.0 / ratio_))), 64, 1024);
    canon->ext = identity ? 1.0 : ext;
    const int n = canon->n;
    canon->cell.assign(channels_, std::vector<float>(static_cast<std::size_t>(n) * n, 0.0f));
    for (int c = 0; c < channels_; ++c) {
      const float* src = img.plane(c);
      std::vector<float>& dst = canon->cell[c];
      if (identity) {
        const int ox = (L - w) / 2, oy = (L - h) / 2;  // centred (odd padding: half a cell off)
        for (int j = 0; j < h; ++j)
          for (int i = 0; i < w; ++i) dst[static_cast<std::size_t>(j + oy) * n + i + ox] = src[j * w + i];
      } else {
        // Each cell: the mean of 3×3 bilinear samples of the image (zero outside it).
        auto sample = [&](double u, double v) {
          const double fx = (u * L / 2 + w / 2.0) - 0.5, fy = (v * L / 2 + h / 2.0) - 0.5;
          const int x0 = static_cast<int>(std::floor(fx)), y0 = static_cast<int>(std::floor(fy));
          const double ax = fx - x0, ay = fy - y0;
          auto at = [&](int x, int y) { return (x < 0 || y < 0 || x >= w || y >= h) ? 0.0 : double(src[y * w + x]); };
          return (1 - ay) * ((1 - ax) * at(x0, y0) + ax * at(x0 + 1, y0)) +
                 ay * ((1 - ax) * at(x0, y0 + 1) + ax * at(x0 + 1, y0 + 1));
        };
        const double cs = 2 * ext / n;
        core::parallel_for(n, [&](int j0, int j1) {
          for (int j = j0; j < j1; ++j)
            for (int i = 0; i < n; ++i) {
              double acc = 0;
              for (int sj = 0; sj < 3; ++sj)
                for (int si = 0; si < 3; ++si) {
                  const double px = -ext + (i + (si + 0.5) / 3) * cs, py = -ext + (j + (sj + 0.5) / 3) * cs;
                  const double xr = px * ratio_, yr = py;
                  acc += sample(xr * ct - yr * st, xr * st + yr * ct);
                }
              dst[static_cast<std::size_t>(j) * n + i] = static_cast<float>(acc / 9);
            }
        });
      }
      const float mx = *std::max_element(dst.begin(), dst.end());
      if (!(mx > 0)) throw_usage("--aperture-image: the image is all black (no light passes)");
      for (float& v : dst) v /= mx;
    }
    canon->sat.assign(channels_, std::vector<double>(static_cast<std::size_t>(n + 1) * (n + 1), 0.0));
    for (int c = 0; c < channels_; ++c) {
      std::vector<double>& s = canon->sat[c];
      for (int j = 0; j < n; ++j) {
        double row = 0;
        for (int i = 0; i < n; ++i) {
          row += canon->cell[c][static_cast<std::size_t>(j) * n + i];
          s[static_cast<std::size_t>(j + 1) * (n + 1) + i + 1] = s[static_cast<std::size_t>(j) * (n + 1) + i + 1] + row;
        }
      }
    }
    // Bounding box of the non-zero cells (any channel), in unit footprint coordinates.
    int i0 = n, i1 = -1, j0 = n, j1 = -1;
    for (int c = 0; c < channels_; ++c)
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i)
          if (canon->cell[c][static_cast<std::size_t>(j) * n + i] > 0) {
            i0 = std::min(i0, i), i1 = std::max(i1, i), j0 = std::min(j0, j), j1 = std::max(j1, j);
          }
    const double cs = 2 * canon->ext / n;
    ext_x_ = std::max(std::abs(-canon->ext + i0 * cs), std::abs(-canon->ext + (i1 + 1) * cs));
    ext_y_ = std::max(std::abs(-canon->ext + j0 * cs), std::abs(-canon->ext + (j1 + 1) * cs));
    canon_ = std::move(canon);
    s_ = 1;
    return;
  }
  const bool round = shape.blades == 0 || shape.curvature >= 1.0;
  if (round && ratio_ == 1.0) {
    kind_ = Kind::circle;
    return;
  }
  kind_ = Kind::analytic;
  if (!round) {
    const int n = shape.blades;
    for (int k = 0; k < n; ++k) {
      nx_.push_back(std::cos(theta + 2 * kPi * k / n));
      ny_.push_back(std::sin(theta + 2 * kPi * k / n));
    }
    apothem_ = std::cos(kPi / n);
    curv_ = shape.curvature;
  } else {
    curv_ = 1.0;
  }
  s_ = (1 - curv_) * apothem_ + curv_;
  beta_ = (1 - curv_) + curv_ / apothem_;
  // G(q) >= s·|q| >= s·min(a, 1)·|p| = μ|p|, and G(q) <= |q| <= max(a, 1)·|p|.
  mu_ = s_ * std::min(ratio_, 1.0);
  m_ = std::max(ratio_, 1.0) / mu_;
  level_ = static_cast<float>(s_ / mu_);
  ext_x_ = 1.0 / ratio_;
  ext_y_ = 1.0;
}

double ApertureModel::gauge_d(double x, double y) const {
  const double qx = ratio_ * x, qy = -y;
  const double len = std::sqrt(qx * qx + qy * qy);
  if (nx_.empty()) return len;
  double h = -1e300;
  for (std::size_t k = 0; k < nx_.size(); ++k) h = std::max(h, nx_[k] * qx + ny_[k] * qy);
  return (1 - curv_) * h + curv_ * len;
}

float ApertureModel::gauge(int dx, int dy, Field f) const {
  if (kind_ == Kind::circle) {
    const float fx = static_cast<float>(dx), fy = static_cast<float>(dy);
    return std::sqrt(fx * fx + fy * fy);
  }
  if (f == Field::near) dx = -dx, dy = -dy;
  return static_cast<float>(gauge_d(dx, dy) / mu_);
}

void ApertureModel::eye_offset(float rho, Field f, float sx, float sy, float& ox, float& oy) const {
  ox = oy = 0.0f;
  if (eye_ <= 0 || width_ <= 0 || height_ <= 0) return;
  const double hd = 0.5 * std::sqrt(double(width_) * width_ + double(height_) * height_);
  const double k = eye_ * std::max(double(rho) - 0.5, 0.0) / hd * (f == Field::near ? -1.0 : 1.0);
  ox = static_cast<float>(k * (0.5 * width_ - sx));
  oy = static_cast<float>(k * (0.5 * height_ - sy));
}

float ApertureModel::image_cov(int dx, int dy, float rho, Field f, int c) const {
  if (f == Field::near) dx = -dx, dy = -dy;
  const Canon& k = *canon_;
  const double scale = k.n / (2 * k.ext) / image_scale(rho);  // cells per px
  auto cx = [&](double v) { return std::clamp(v * scale + 0.5 * k.n, 0.0, double(k.n)); };
  const double x0 = cx(dx - 0.5), x1 = cx(dx + 0.5), y0 = cx(dy - 0.5), y1 = cx(dy + 0.5);
  if (x1 <= x0 || y1 <= y0) return 0.0f;
  const std::vector<double>& s = k.sat[c];
  const int stride = k.n + 1;
  // The integral of piecewise-constant cells is bilinear in the corner within a cell.
  auto F = [&](double X, double Y) {
    int i = std::min(static_cast<int>(X), k.n - 1), j = std::min(static_cast<int>(Y), k.n - 1);
    const double a = X - i, b = Y - j;
    const double f00 = s[static_cast<std::size_t>(j) * stride + i],
                 f10 = s[static_cast<std::size_t>(j) * stride + i + 1];
    const double f01 = s[static_cast<std::size_t>(j + 1) * stride + i];
    const double cell = k.cell[c][static_cast<std::size_t>(j) * k.n + i];
    return f00 * (1 - a - b) + f10 * a + f01 * b + a * b * cell;
  };
  const double integral = F(x1, y1) - F(x0, y1) - F(x1, y0) + F(x0, y0);
  // The sums cancel to ~1e-14 where the image is empty: below 1e-6 counts as nothing.
  const double cov = integral / (scale * scale);
  return cov < 1e-6 ? 0.0f : sat(static_cast<float>(cov));
}

float ApertureModel::shape_coverage(int dx, int dy, float rho, Field f, int c) const {
  if (kind_ == Kind::image) return image_cov(dx, dy, rho, f, std::min(c, channels_ - 1));
  return sat(lim(rho) - gauge(dx, dy, f));
}

float ApertureModel::eye_coverage(int dx, int dy, float rho, Field f, float sx, float sy) const {
  if (eye_ <= 0) return 1.0f;
  float ox, oy;
  eye_offset(rho, f, sx, sy, ox, oy);
  const float ex = (static_cast<float>(dx) - ox) * static_cast<float>(ratio_), ey = static_cast<float>(dy) - oy;
  return sat(rho + 0.5f - std::sqrt(ex * ex + ey * ey));
}

float ApertureModel::coverage(int dx, int dy, float rho, Field f, float sx, float sy, int c) const {
  const float cov = shape_coverage(dx, dy, rho, f, c);
  return eye_ > 0 ? std::min(cov, eye_coverage(dx, dy, rho, f, sx, sy)) : cov;
}

int ApertureModel::reach(float rho) const {
  if (kind_ == Kind::image)
    return std::max(0, static_cast<int>(std::ceil(std::max(ext_x_, ext_y_) * image_scale(rho) + 0.5)) - 1);
  // Non-zero coverage needs |p| <= T < lim.
  return std::max(0, static_cast<int>(std::ceil(double(lim(rho)))) - 1);
}

bool ApertureModel::outer_extent(double y, double level, double& x0, double& x1) const {
  // Every analytic T satisfies T >= s·|q| (a circle) and, with blades, T >= h(q) (a polygon).
  const double rc = level / s_;
  if (y * y >= rc * rc) return false;
  const double hw = std::sqrt(rc * rc - y * y) / ratio_;
  x0 = -hw;
  x1 = hw;
  for (std::size_t k = 0; k < nx_.size(); ++k) {
    // nx·ratio·x + ny·(−y) < level
    const double a = nx_[k] * ratio_, b = level + ny_[k] * y;
    if (std::abs(a) < 1e-12) {
      if (b <= 0) return false;
    } else if (a > 0) {
      x1 = std::min(x1, b / a);
    } else {
      x0 = std::max(x0, b / a);
    }
  }
  return x0 <= x1;
}

bool ApertureModel::inner_extent(double y, double level, double& x0, double& x1) const {
  if (level <= 0) return false;
  // T <= |q| (a circle of radius level) and, with blades, T <= β·h(q) (a polygon of apothem
  // level/β): both sets lie inside {T <= level}; take the wider of the two intervals.
  bool any = false;
  if (y * y < level * level) {
    const double hw = std::sqrt(level * level - y * y) / ratio_;
    x0 = -hw;
    x1 = hw;
    any = true;
  }
  if (!nx_.empty()) {
    const double lp = level / beta_;
    double p0 = -1e300, p1 = 1e300;
    bool ok = true;
    for (std::size_t k = 0; k < nx_.size() && ok; ++k) {
      const double a = nx_[k] * ratio_, b = lp + ny_[k] * y;
      if (std::abs(a) < 1e-12) {
        ok = b >= 0;
      } else if (a > 0) {
        p1 = std::min(p1, b / a);
      } else {
        p0 = std::max(p0, b / a);
      }
    }
    if (ok && p0 <= p1 && (!any || p1 - p0 > x1 - x0)) {
      x0 = p0;
      x1 = p1;
      any = true;
    }
  }
  return any;
}

Span ApertureModel::span_of(int dy, float rho, Field f, float sx, float sy, bool interior, bool eye) const {
  Span out;
  if (kind_ == Kind::image) {
    if (interior) return out;  // no offset is guaranteed full coverage
    const int r = reach(rho);
    if (dy < -r || dy > r) return out;
    const int hx = std::max(0, static_cast<int>(std::ceil(ext_x_ * image_scale(rho) + 0.5)) - 1);
    out = {-hx, hx};
  } else {
    const double lim = this->lim(rho);
    const double mg = margin(lim);
    // The near field's row dy is the far field's row −dy, mirrored.
    const double y = f == Field::near ? -dy : dy;
    double x0 = 0, x1 = -1;
    if (interior) {
      const double level = lim - 1.0 - mg;  // T <= level there, so lim − T >= 1 in float too
      if (kind_ == Kind::circle) {
        if (!(level > 0 && y * y <= level * level)) return out;
        x1 = std::sqrt(level * level - y * y);
        x0 = -x1;
      } else if (!inner_extent(y, mu_ * level, x0, x1)) {
        return out;
      }
      out = {static_cast<int>(std::ceil(x0)), static_cast<int>(std::floor(x1))};
    } else {
      const double level = lim + mg;
      if (kind_ == Kind::circle) {
        if (y * y >= level * level) return out;
        x1 = std::sqrt(level * level - y * y);
        x0 = -x1;
      } else if (!outer_extent(y, mu_ * level, x0, x1)) {
        return out;
      }
      out = {static_cast<int>(std::ceil(x0 - mg)), static_cast<int>(std::floor(x1 + mg))};
    }
    if (f == Field::near) out = {-out.x1, -out.x0};
  }
  if (eye && eye_ > 0 && !out.empty()) {
    float ox, oy;
    eye_offset(rho, f, sx, sy, ox, oy);
    const double mg = margin(rho);
    const double ey = dy - double(oy);
    const double level = interior ? double(rho) + 0.5 - 1.0 - mg : double(rho) + 0.5 + mg;
    if (level <= 0 || ey * ey >= level * level) return Span{};
    const double hw = std::sqrt(level * level - ey * ey) / ratio_;
    const int e0 = static_cast<int>(std::ceil(ox - hw - (interior ? 0 : mg)));
    const int e1 = static_cast<int>(std::floor(ox + hw + (interior ? 0 : mg)));
    out = {std::max(out.x0, e0), std::min(out.x1, e1)};
  }
  return out;
}

Span ApertureModel::row_span(int dy, float rho, Field f, float sx, float sy) const {
  return span_of(dy, rho, f, sx, sy, false);
}

Span ApertureModel::row_interior(int dy, float rho, Field f, float sx, float sy) const {
  return span_of(dy, rho, f, sx, sy, true);
}

double ApertureModel::weight_sum(float rho, Field f, float sx, float sy, int c) const {
  const int r = reach(rho);
  double sum = 0;
  for (int dy = -r; dy <= r; ++dy) {
    const Span o = row_span(dy, rho, f, sx, sy);
    if (o.empty()) continue;
    Span in = row_interior(dy, rho, f, sx, sy);
    if (in.empty() || in.x0 < o.x0 || in.x1 > o.x1) in = {o.x1 + 1, o.x1};  // none: all rim
    sum += static_cast<double>(in.x1 - in.x0 + 1);
    for (int dx = o.x0; dx < in.x0; ++dx) sum += coverage(dx, dy, rho, f, sx, sy, c);
    for (int dx = in.x1 + 1; dx <= o.x1; ++dx) sum += coverage(dx, dy, rho, f, sx, sy, c);
  }
  return sum;
}

ApertureModel::Kernel ApertureModel::kernel(float rho, Field f, float sx, float sy, int c, bool eye) const {
  Kernel k;
  k.reach = reach(rho);
  const int p = 2 * k.reach + 1;
  k.cov.assign(static_cast<std::size_t>(p) * p, 0.0f);
  for (int dy = -k.reach; dy <= k.reach; ++dy) {
    const Span o = span_of(dy, rho, f, sx, sy, false, eye);
    for (int dx = std::max(o.x0, -k.reach); dx <= std::min(o.x1, k.reach); ++dx) {
      const float v = eye ? coverage(dx, dy, rho, f, sx, sy, c) : shape_coverage(dx, dy, rho, f, c);
      k.cov[static_cast<std::size_t>(dy + k.reach) * p + dx + k.reach] = v;
      k.sum += v;
    }
  }
  return k;
}

double ApertureModel::unit_transmission(double x, double y, Field f, int c) const {
  if (f == Field::near) x = -x, y = -y;
  switch (kind_) {
    case Kind::circle:
      return x * x + y * y <= 1.0 ? 1.0 : 0.0;
    case Kind::analytic:
      return gauge_d(x, y) <= s_ ? 1.0 : 0.0;
    case Kind::image: {
      const Canon& k = *canon_;
      const double fx = (x + k.ext) / (2 * k.ext) * k.n - 0.5, fy = (y + k.ext) / (2 * k.ext) * k.n - 0.5;
      const int x0 = static_cast<int>(std::floor(fx)), y0 = static_cast<int>(std::floor(fy));
      const double ax = fx - x0, ay = fy - y0;
      const std::vector<float>& cell = k.cell[std::min(c, channels_ - 1)];
      auto at = [&](int i, int j) {
        return (i < 0 || j < 0 || i >= k.n || j >= k.n) ? 0.0 : double(cell[static_cast<std::size_t>(j) * k.n + i]);
      };
      return (1 - ay) * ((1 - ax) * at(x0, y0) + ax * at(x0 + 1, y0)) +
             ay * ((1 - ax) * at(x0, y0 + 1) + ax * at(x0 + 1, y0 + 1));
    }
  }
  return 0.0;
}

void ApertureModel::unit_boundary_map(double ux, double uy, double& x, double& y) const {
  if (kind_ != Kind::analytic) {
    x = ux;
    y = uy;
    return;
  }
  // In the unsqueezed frame (y up) the shape is {G(q) <= s}; G is homogeneous, so the boundary
  // along direction q/|q| lies at radius s / G(q/|q|).
  const double qx = ux, qy = -uy, len = std::hypot(qx, qy);
  double k = 1.0;
  if (len > 0) {
    double h = len;
    if (!nx_.empty()) {
      h = -1e300;
      for (std::size_t i = 0; i < nx_.size(); ++i) h = std::max(h, nx_[i] * qx + ny_[i] * qy);
    }
    k = s_ * len / ((1 - curv_) * h + curv_ * len);
  }
  x = qx * k / ratio_;
  y = -qy * k;
}

KernelBank::KernelBank(const ApertureModel& model, float rho_max, int channel, int pad) : pad_(pad) {
  rho_max = std::max(rho_max, 0.5f);
  // Total floats for a step: two fields per bucket; coarsen until it fits ~64 M floats.
  for (;;) {
    const int nb = static_cast<int>(std::ceil((rho_max - 0.5f) / step_)) + 1;
    double total = 0;
    for (int b = 0; b < nb; ++b) {
      const double r = model.reach(0.5f + b * step_);
      total += 2 * (2 * r + 1) * (2 * r + 1 + 2 * pad);
    }
    if (total <= 64e6 || step_ >= 4.0f) break;
    step_ *= 2;
  }
  const int nb = static_cast<int>(std::ceil((rho_max - 0.5f) / step_)) + 1;
  reach_.resize(nb);
  sum_.assign(nb, 0.0);
  offset_.resize(nb);
  span_off_.resize(nb);
  std::size_t total = 0, spans = 0;
  for (int b = 0; b < nb; ++b) {
    reach_[b] = model.reach(bucket_rho(b));
    const std::size_t rows = static_cast<std::size_t>(2 * reach_[b] + 1), p = static_cast<std::size_t>(pitch(b));
    offset_[b] = {total + pad_, total + rows * p + pad_};
    total += 2 * rows * p;
    span_off_[b] = spans;
    spans += rows;
  }
  data_.assign(total, 0.0f);
  spans_.assign(spans, Span{});
  core::parallel_for(nb, [&](int b0, int b1) {
    for (int b = b0; b < b1; ++b) {
      const ApertureModel::Kernel k = model.kernel(bucket_rho(b), Field::far, 0, 0, channel, false);
      const int p = 2 * reach_[b] + 1, r = reach_[b], pitch_b = pitch(b);
      float* far = data_.data() + offset_[b][0];
      float* near = data_.data() + offset_[b][1];
      for (int j = 0; j < p; ++j)
        for (int i = 0; i < p; ++i) {
          const float v = k.cov[static_cast<std::size_t>(j) * p + i];
          far[static_cast<std::size_t>(j) * pitch_b + i] = v;
          near[static_cast<std::size_t>(p - 1 - j) * pitch_b + (p - 1 - i)] = v;  // point reflection
        }
      sum_[b] = k.sum;
      for (int j = 0; j < p; ++j) {
        Span s;
        for (int i = 0; i < p; ++i)
          if (k.cov[static_cast<std::size_t>(j) * p + i] > 0) {
            if (s.empty()) s.x0 = i - r;
            s.x1 = i - r;
          }
        if (s.x1 < s.x0) s = Span{};
        spans_[span_off_[b] + j] = s;
      }
    }
  });
}

int KernelBank::bucket(float rho) const noexcept {
  const int b = static_cast<int>(std::lround((rho - 0.5f) / step_));
  return std::clamp(b, 0, static_cast<int>(reach_.size()) - 1);
}

Span KernelBank::row_span(int b, Field f, int dy) const noexcept {
  const int r = reach_[b];
  if (dy < -r || dy > r) return Span{};
  if (f == Field::far) return spans_[span_off_[b] + dy + r];
  const Span s = spans_[span_off_[b] - dy + r];
  return s.empty() ? s : Span{-s.x1, -s.x0};
}

}  // namespace dofkit::core
