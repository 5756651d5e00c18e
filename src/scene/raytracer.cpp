// Over 800 lines: every pass (pinhole, thin lens, AO, G-buffer, lit) shares the file-local primitive routines.
// The ray tracer of raytracer.hpp: intersections, procedural textures, pinhole and thin-lens
// passes.
#include "scene/raytracer.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <numbers>

#include "core/aperture.hpp"
#include "core/parallel.hpp"
#include "dofkit/error.hpp"
#include "scene/sampling.hpp"

namespace dofkit::scene {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kEps = 1e-9;  // smallest accepted ray parameter (metres of depth)
constexpr int kTile = 16;      // tile side, px (the unit of primitive culling and of threading)

Vec3 cross(Vec3 a, Vec3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
Vec3 normalize(Vec3 a) { return a * (1.0 / std::sqrt(dot(a, a))); }
double smooth5(double t) { return t * t * t * (t * (t * 6 - 15) + 10); }  // C2 fade
double clamp01(double t) { return t < 0 ? 0 : (t > 1 ? 1 : t); }

// Value noise: lattice values in [0, 1) at integer points (integer hashes of the point's
// coordinates, wrapped to 32 bits, and the seed), blended with a C2 fade; values in [0, 1].
double value_noise(double x, double y, std::uint32_t seed) {
  const double fx = std::floor(x), fy = std::floor(y);
  const auto ix = static_cast<std::uint32_t>(static_cast<std::int64_t>(fx));
  const auto iy = static_cast<std::uint32_t>(static_cast<std::int64_t>(fy));
  const double tx = smooth5(x - fx), ty = smooth5(y - fy);
  // Nested hashing h(ix + h(iy, seed)): each row's hash is shared by its two corners.
  const std::uint32_t hy0 = detail::hash32((iy * 0x85ebca77U) ^ seed);
  const std::uint32_t hy1 = detail::hash32(((iy + 1) * 0x85ebca77U) ^ seed);
  const std::uint32_t kx0 = ix * 0x9e3779b1U, kx1 = kx0 + 0x9e3779b1U;
  constexpr double k = 1.0 / 4294967296.0;
  const double v00 = detail::hash32(kx0 + hy0) * k, v10 = detail::hash32(kx1 + hy0) * k;
  const double v01 = detail::hash32(kx0 + hy1) * k, v11 = detail::hash32(kx1 + hy1) * k;
  const double a = v00 + (v10 - v00) * tx, b = v01 + (v11 - v01) * tx;
  return a + (b - a) * ty;
}

// Fractal sum of octaves; each octave is rotated by an irrational-ish angle and shifted so
// the lattices of different octaves never line up (no visible grid at any scale). The sum is
// re-centred and its contrast doubled (a sum of n octaves has a smaller spread than one).
double fbm(const Texture& t, double u, double v) {
  if (t.octaves <= 0) return 0;
  double x = u / t.noise_scale_m, y = v / t.noise_scale_m;
  double sum = 0, amp = 1, norm = 0;
  const double c = std::cos(0.61), s = std::sin(0.61);
  for (int k = 0; k < t.octaves; ++k) {
    sum += amp * value_noise(x, y, t.seed + 977u * static_cast<std::uint32_t>(k));
    norm += amp;
    amp *= t.gain;
    const double nx = 2 * (c * x - s * y) + 17.3, ny = 2 * (s * x + c * y) - 5.9;
    x = nx;
    y = ny;
  }
  return clamp01(0.5 + 2.0 * (sum / norm - 0.5));
}

Rgb lerp(Rgb a, Rgb b, double t) {
  return {static_cast<float>(a.r + (b.r - a.r) * t), static_cast<float>(a.g + (b.g - a.g) * t),
          static_cast<float>(a.b + (b.b - a.b) * t)};
}

// Any unit vector perpendicular to `a`.
Vec3 perpendicular(Vec3 a) {
  const Vec3 h = std::abs(a.x) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
  return normalize(cross(a, h));
}

// Smallest t > kEps where the ray crosses the surface of a convex solid, given the parameters
// of two roots (kInf if none).
double first_positive(double t0, double t1) {
  if (t0 > kEps) return t0;
  if (t1 > kEps) return t1;
  return kInf;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Textures

Rgb shade(const Texture& t, double u, double v) {
  Rgb c = t.octaves > 0 ? lerp(t.a, t.b, fbm(t, u, v)) : t.a;
  double m = t.emission;
  if (t.checker_m > 0) {
    const auto cx = static_cast<std::int64_t>(std::floor(u / t.checker_m));
    const auto cy = static_cast<std::int64_t>(std::floor(v / t.checker_m));
    m *= ((cx + cy) & 1) ? 1 + t.checker_contrast : 1 - t.checker_contrast;
  }
  if (t.line_spacing_m > 0) {
    const double fu = u / t.line_spacing_m - std::floor(u / t.line_spacing_m);
    const double fv = v / t.line_spacing_m - std::floor(v / t.line_spacing_m);
    const double w = t.line_width_m / t.line_spacing_m;
    if (fu < w || fv < w) m *= 1 - t.line_darkness;
  }
  return {static_cast<float>(c.r * m), static_cast<float>(c.g * m), static_cast<float>(c.b * m)};
}

// ---------------------------------------------------------------------------------------------
// Primitives

Primitive Primitive::plane(Vec3 point, Vec3 normal, Vec3 u_axis, Texture t, std::string name) {
  Primitive p;
  p.kind = Kind::plane;
  p.p0 = point;
  p.p1 = normalize(normal);
  // Remove any normal component so (u, v, n) is orthonormal.
  p.axis_u = normalize(u_axis - p.p1 * dot(u_axis, p.p1));
  p.tex = t;
  p.name = std::move(name);
  return p;
}

Primitive Primitive::box(Vec3 lo, Vec3 hi, Texture t, std::string name) {
  Primitive p;
  p.kind = Kind::box;
  p.p0 = {std::min(lo.x, hi.x), std::min(lo.y, hi.y), std::min(lo.z, hi.z)};
  p.p1 = {std::max(lo.x, hi.x), std::max(lo.y, hi.y), std::max(lo.z, hi.z)};
  p.tex = t;
  p.name = std::move(name);
  return p;
}

Primitive Primitive::sphere(Vec3 centre, double r, Texture t, std::string name) {
  Primitive p;
  p.kind = Kind::sphere;
  p.p0 = centre;
  p.radius = r;
  p.tex = t;
  p.name = std::move(name);
  return p;
}

Primitive Primitive::cylinder(Vec3 a, Vec3 b, double r, Texture t, std::string name) {
  Primitive p;
  p.kind = Kind::cylinder;
  p.p0 = a;
  p.p1 = b;
  p.radius = r;
  p.axis_u = perpendicular(normalize(b - a));
  p.tex = t;
  p.name = std::move(name);
  return p;
}

Primitive Primitive::oriented_box(Vec3 centre, Vec3 half, Vec3 u, Vec3 v, Texture t, std::string name) {
  Primitive p;
  p.kind = Kind::oriented_box;
  p.p0 = centre;
  p.p1 = {std::abs(half.x), std::abs(half.y), std::abs(half.z)};
  p.axis_u = normalize(u);
  p.axis_v = normalize(v - p.axis_u * dot(v, p.axis_u));
  p.tex = t;
  p.name = std::move(name);
  return p;
}

namespace {

// An oriented box's third axis and the coordinates of x in its frame (origin at the centre).
Vec3 obox_w(const Primitive& p) { return cross(p.axis_u, p.axis_v); }
Vec3 obox_local(const Primitive& p, Vec3 x) {
  const Vec3 q = x - p.p0;
  return {dot(q, p.axis_u), dot(q, p.axis_v), dot(q, obox_w(p))};
}

// Index (0, 1, 2) of the face axis of a point q on a box of half size h, in the box's frame
// centred on it: the axis along which the point is farthest out relative to the half size.
int face_axis(Vec3 q, Vec3 h) {
  const double qx = std::abs(q.x) / std::max(h.x, 1e-12);
  const double qy = std::abs(q.y) / std::max(h.y, 1e-12);
  const double qz = std::abs(q.z) / std::max(h.z, 1e-12);
  if (qx >= qy && qx >= qz) return 0;
  return qy >= qz ? 1 : 2;
}

// Slab test of the ray (o, d) against the box [lo, hi] (both in the same frame): the entry
// parameter (or the exit one when the origin is inside), kInf if missed.
double slab(const double os[3], const double ds[3], const double lo[3], const double hi[3]) {
  double t0 = -kInf, t1 = kInf;
  for (int a = 0; a < 3; ++a) {
    if (ds[a] == 0) {
      if (os[a] < lo[a] || os[a] > hi[a]) return kInf;
      continue;
    }
    const double inv = 1.0 / ds[a];
    double ta = (lo[a] - os[a]) * inv, tb = (hi[a] - os[a]) * inv;
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  if (t0 > t1) return kInf;
  return first_positive(t0, t1);
}

}  // namespace

double intersect(const Primitive& p, Vec3 o, Vec3 d) {
  switch (p.kind) {
    case Primitive::Kind::oriented_box: {
      const Vec3 w = obox_w(p), q = o - p.p0;
      const double os[3] = {dot(q, p.axis_u), dot(q, p.axis_v), dot(q, w)};
      const double ds[3] = {dot(d, p.axis_u), dot(d, p.axis_v), dot(d, w)};
      const double hi[3] = {p.p1.x, p.p1.y, p.p1.z}, lo[3] = {-p.p1.x, -p.p1.y, -p.p1.z};
      return slab(os, ds, lo, hi);
    }
    case Primitive::Kind::plane: {
      const double dn = dot(d, p.p1);
      if (dn == 0) return kInf;
      const double t = dot(p.p0 - o, p.p1) / dn;
      return t > kEps ? t : kInf;
    }
    case Primitive::Kind::box: {
      const double os[3] = {o.x, o.y, o.z}, ds[3] = {d.x, d.y, d.z};
      const double lo[3] = {p.p0.x, p.p0.y, p.p0.z}, hi[3] = {p.p1.x, p.p1.y, p.p1.z};
      return slab(os, ds, lo, hi);
    }
    case Primitive::Kind::sphere: {
      // |o + t d − c|² = R²: a t² + 2 b t + c = 0.
      const Vec3 oc = o - p.p0;
      const double a = dot(d, d), b = dot(oc, d), c = dot(oc, oc) - p.radius * p.radius;
      const double disc = b * b - a * c;
      if (disc < 0) return kInf;
      const double s = std::sqrt(disc);
      return first_positive((-b - s) / a, (-b + s) / a);
    }
    case Primitive::Kind::cylinder: {
      const Vec3 axis = p.p1 - p.p0;
      const double len = std::sqrt(dot(axis, axis));
      const Vec3 ax = axis * (1.0 / len);
      const Vec3 w = o - p.p0;
      const double dw = dot(d, ax), ww = dot(w, ax);
      // Lateral surface: components perpendicular to the axis satisfy |w⊥ + t d⊥|² = R².
      const Vec3 dp = d - ax * dw, wp = w - ax * ww;
      double best = kInf;
      const double a = dot(dp, dp), b = dot(wp, dp), c = dot(wp, wp) - p.radius * p.radius;
      const double disc = b * b - a * c;
      if (a > 0 && disc >= 0) {
        const double s = std::sqrt(disc);
        for (double t : {(-b - s) / a, (-b + s) / a}) {
          const double h = ww + t * dw;
          if (t > kEps && h >= 0 && h <= len) best = std::min(best, t);
        }
      }
      // End caps: discs in the planes h = 0 and h = len.
      if (dw != 0) {
        for (double h : {0.0, len}) {
          const double t = (h - ww) / dw;
          if (t > kEps && t < best) {
            const Vec3 q = wp + dp * t;
            if (dot(q, q) <= p.radius * p.radius) best = t;
          }
        }
      }
      return best;
    }
  }
  return kInf;
}

Rgb shade_at(const Primitive& p, Vec3 x) {
  switch (p.kind) {
    case Primitive::Kind::oriented_box: {
      // As for an axis-aligned box, in the box's own frame (coordinates from its min corner).
      const Vec3 q = obox_local(p, x);
      const Vec3 r = q + p.p1;
      const int a = face_axis(q, p.p1);
      if (a == 0) return shade(p.tex, r.z, r.y);
      if (a == 1) return shade(p.tex, r.x, r.z);
      return shade(p.tex, r.x, r.y);
    }
    case Primitive::Kind::plane: {
      const Vec3 q = x - p.p0;
      const Vec3 v_axis = cross(p.p1, p.axis_u);
      return shade(p.tex, dot(q, p.axis_u), dot(q, v_axis));
    }
    case Primitive::Kind::box: {
      // Face = the axis along which the point is farthest out relative to the half size.
      const Vec3 c = (p.p0 + p.p1) * 0.5, h = (p.p1 - p.p0) * 0.5;
      const double qx = std::abs(x.x - c.x) / std::max(h.x, 1e-12);
      const double qy = std::abs(x.y - c.y) / std::max(h.y, 1e-12);
      const double qz = std::abs(x.z - c.z) / std::max(h.z, 1e-12);
      const Vec3 r = x - p.p0;
      if (qx >= qy && qx >= qz) return shade(p.tex, r.z, r.y);
      if (qy >= qz) return shade(p.tex, r.x, r.z);
      return shade(p.tex, r.x, r.y);
    }
    case Primitive::Kind::sphere: {
      const Vec3 q = x - p.p0;
      const double phi = std::atan2(q.x, -q.z);  // 0 facing the camera
      const double theta = std::acos(std::clamp(q.y / p.radius, -1.0, 1.0));
      return shade(p.tex, phi * p.radius, theta * p.radius);
    }
    case Primitive::Kind::cylinder: {
      const Vec3 axis = p.p1 - p.p0;
      const double len = std::sqrt(dot(axis, axis));
      const Vec3 ax = axis * (1.0 / len);
      const Vec3 w = x - p.p0;
      const double h = dot(w, ax);
      const Vec3 q = w - ax * h;
      const Vec3 e2 = cross(ax, p.axis_u);
      const double qu = dot(q, p.axis_u), qv = dot(q, e2);
      // The nearest of the three surfaces (lateral, either cap) holds the point; deciding by
      // distance keeps a point known only approximately (e.g. from a float depth) on its face.
      const double lateral = std::abs(std::sqrt(qu * qu + qv * qv) - p.radius);
      if (std::min(std::abs(h), std::abs(h - len)) < lateral) return shade(p.tex, qu, qv + h);  // cap
      return shade(p.tex, std::atan2(qv, qu) * p.radius, h);
    }
  }
  return {};
}

Vec3 normal_at(const Primitive& p, Vec3 x) {
  switch (p.kind) {
    case Primitive::Kind::plane:
      return p.p1;
    case Primitive::Kind::box: {
      const Vec3 c = (p.p0 + p.p1) * 0.5, h = (p.p1 - p.p0) * 0.5;
      const Vec3 q = x - c;
      switch (face_axis(q, h)) {
        case 0:
          return {q.x < 0 ? -1.0 : 1.0, 0, 0};
        case 1:
          return {0, q.y < 0 ? -1.0 : 1.0, 0};
        default:
          return {0, 0, q.z < 0 ? -1.0 : 1.0};
      }
    }
    case Primitive::Kind::oriented_box: {
      const Vec3 q = obox_local(p, x);
      switch (face_axis(q, p.p1)) {
        case 0:
          return p.axis_u * (q.x < 0 ? -1.0 : 1.0);
        case 1:
          return p.axis_v * (q.y < 0 ? -1.0 : 1.0);
        default:
          return obox_w(p) * (q.z < 0 ? -1.0 : 1.0);
      }
    }
    case Primitive::Kind::sphere:
      return normalize(x - p.p0);
    case Primitive::Kind::cylinder: {
      const Vec3 axis = p.p1 - p.p0;
      const double len = std::sqrt(dot(axis, axis));
      const Vec3 ax = axis * (1.0 / len);
      const Vec3 w = x - p.p0;
      const double h = dot(w, ax);
      const Vec3 q = w - ax * h;
      const double lateral = std::abs(std::sqrt(dot(q, q)) - p.radius);
      // The nearest of the three surfaces holds the point (as in shade_at).
      if (std::min(std::abs(h), std::abs(h - len)) < lateral) return std::abs(h) < std::abs(h - len) ? ax * -1.0 : ax;
      return normalize(q);
    }
  }
  return {0, 0, 1};
}

Rgb shade_background(const Background& bg, Vec3 d) {
  const double tx = d.x / d.z, ty = d.y / d.z;
  const double up = clamp01(-ty / 0.4);  // y points down: −ty = tan(elevation)
  const Rgb g = lerp(bg.horizon, bg.top, up);
  const Rgb c = shade(bg.clouds, tx, ty);
  return {g.r * c.r, g.g * c.g, g.b * c.b};
}

// ---------------------------------------------------------------------------------------------
// Camera

double LensCamera::f_px() const { return 0.5 * width / std::tan(0.5 * hfov_deg * std::numbers::pi / 180.0); }
double LensCamera::lens_radius_m() const { return k_px * focus_m / f_px(); }
double LensCamera::coc_px(double z) const { return k_px * (focus_m / z - 1.0); }

// ---------------------------------------------------------------------------------------------
// Rendering

namespace {

// Axis-aligned bounds of a bounded primitive (false for a plane).
bool bounds_of(const Primitive& p, Vec3& lo, Vec3& hi) {
  switch (p.kind) {
    case Primitive::Kind::plane:
      return false;
    case Primitive::Kind::box:
      lo = p.p0;
      hi = p.p1;
      return true;
    case Primitive::Kind::sphere:
      lo = p.p0 - Vec3{p.radius, p.radius, p.radius};
      hi = p.p0 + Vec3{p.radius, p.radius, p.radius};
      return true;
    case Primitive::Kind::cylinder: {
      const Vec3 r{p.radius, p.radius, p.radius};
      lo = Vec3{std::min(p.p0.x, p.p1.x), std::min(p.p0.y, p.p1.y), std::min(p.p0.z, p.p1.z)} - r;
      hi = Vec3{std::max(p.p0.x, p.p1.x), std::max(p.p0.y, p.p1.y), std::max(p.p0.z, p.p1.z)} + r;
      return true;
    }
    case Primitive::Kind::oriented_box: {
      const Vec3 w = obox_w(p);
      const Vec3 e{std::abs(p.axis_u.x) * p.p1.x + std::abs(p.axis_v.x) * p.p1.y + std::abs(w.x) * p.p1.z,
                   std::abs(p.axis_u.y) * p.p1.x + std::abs(p.axis_v.y) * p.p1.y + std::abs(w.y) * p.p1.z,
                   std::abs(p.axis_u.z) * p.p1.x + std::abs(p.axis_v.z) * p.p1.y + std::abs(w.z) * p.p1.z};
      lo = p.p0 - e;
      hi = p.p0 + e;
      return true;
    }
  }
  return false;
}

// Screen-space culling. A point Q at depth z seen through any lens point lands within |r(z)|
// pixels of its pinhole projection (derivation in raytracer.hpp), so the rays of a tile can
// only hit primitives whose projected bounding box, grown by the largest |r| over their depth
// range, overlaps the tile. |r| is monotone on each side of the focus, so its maximum over
// [z_min, z_max] is at an end. Unbounded primitives (planes) and any that reach the lens plane
// are always candidates.
struct Culler {
  struct Bounds {
    double x0, y0, x1, y1;
    bool always;
  };
  std::vector<Bounds> bounds;

  Culler(const Scene& scene, const LensCamera& cam, bool lens) {
    const double f = cam.f_px();
    for (const Primitive& p : scene.prims) {
      Vec3 lo, hi;
      switch (p.kind) {
        case Primitive::Kind::plane:
          bounds.push_back({0, 0, 0, 0, true});
          continue;
        case Primitive::Kind::box:
          lo = p.p0;
          hi = p.p1;
          break;
        case Primitive::Kind::sphere:
          lo = p.p0 - Vec3{p.radius, p.radius, p.radius};
          hi = p.p0 + Vec3{p.radius, p.radius, p.radius};
          break;
        case Primitive::Kind::cylinder:
        case Primitive::Kind::oriented_box:
          bounds_of(p, lo, hi);
          break;
      }
      if (lo.z <= 1e-6) {
        bounds.push_back({0, 0, 0, 0, true});
        continue;
      }
      Bounds b{kInf, kInf, -kInf, -kInf, false};
      for (int i = 0; i < 8; ++i) {
        const Vec3 c{(i & 1) ? hi.x : lo.x, (i & 2) ? hi.y : lo.y, (i & 4) ? hi.z : lo.z};
        const double sx = f * c.x / c.z + 0.5 * cam.width, sy = f * c.y / c.z + 0.5 * cam.height;
        b.x0 = std::min(b.x0, sx);
        b.x1 = std::max(b.x1, sx);
        b.y0 = std::min(b.y0, sy);
        b.y1 = std::max(b.y1, sy);
      }
      const double grow = (lens ? std::max(std::abs(cam.coc_px(lo.z)), std::abs(cam.coc_px(hi.z))) : 0) + 1;
      b.x0 -= grow;
      b.y0 -= grow;
      b.x1 += grow;
      b.y1 += grow;
      bounds.push_back(b);
    }
  }

  // Primitive indices whose rays may reach pixels [x0, x1) × [y0, y1).
  std::vector<int> candidates(int x0, int y0, int x1, int y1) const {
    std::vector<int> out;
    for (int i = 0; i < static_cast<int>(bounds.size()); ++i) {
      const Bounds& b = bounds[i];
      if (b.always || (b.x1 >= x0 && b.x0 <= x1 && b.y1 >= y0 && b.y0 <= y1)) out.push_back(i);
    }
    return out;
  }
};

Hit closest(const Scene& scene, const std::vector<int>& cand, Vec3 o, Vec3 d) {
  Hit h;
  for (int i : cand) {
    const double t = intersect(scene.prims[i], o, d);
    if (t < h.z) {
      h.z = t;
      h.prim = i;
    }
  }
  return h;
}

Rgb radiance(const Scene& scene, const Hit& h, Vec3 o, Vec3 d) {
  if (h.prim < 0) return shade_background(scene.background, d);
  if (scene.lit) {
    const Primitive& p = scene.prims[h.prim];
    const Rgb c = lit_at(scene, p, o + d * h.z, o);
    if (!(p.camera_alpha < 1)) return c;
    // A key transparency: its coverage of its own radiance over what lies behind it (the
    // nearest surface past it among all primitives but itself).
    Hit behind;
    for (int i = 0; i < static_cast<int>(scene.prims.size()); ++i) {
      if (i == h.prim) continue;
      const double t = intersect(scene.prims[i], o, d);
      if (t < behind.z) {
        behind.z = t;
        behind.prim = i;
      }
    }
    const Rgb b = radiance(scene, behind, o, d);
    const float a = p.camera_alpha;
    return {a * c.r + (1 - a) * b.r, a * c.g + (1 - a) * b.g, a * c.b + (1 - a) * b.b};
  }
  return shade_at(scene.prims[h.prim], o + d * h.z);
}

template <class Body>
void for_each_tile(const LensCamera& cam, const Progress& progress, Body body) {
  const int tx = (cam.width + kTile - 1) / kTile, ty = (cam.height + kTile - 1) / kTile;
  const int n = tx * ty;
  std::atomic<int> done{0};
  core::parallel_for(n, [&](int b, int e) {
    for (int t = b; t < e; ++t) {
      const int x0 = (t % tx) * kTile, y0 = (t / tx) * kTile;
      body(x0, y0, std::min(x0 + kTile, cam.width), std::min(y0 + kTile, cam.height));
      const int k = ++done;
      if (progress) progress(static_cast<double>(k) / n);
    }
  });
}

void check_camera(const LensCamera& cam) {
  if (cam.width <= 0 || cam.height <= 0) throw_usage("--size: width and height must be > 0");
  if (!(cam.hfov_deg > 0 && cam.hfov_deg < 180)) throw_usage("field of view must be in (0, 180) degrees");
  if (!(cam.focus_m > 0) || !std::isfinite(cam.focus_m)) throw_usage("--focus: must be > 0 metres");
  if (!(cam.k_px >= 0) || !std::isfinite(cam.k_px)) throw_usage("--blur-at-infinity: must be >= 0 px");
  validate(cam.aperture);
}

}  // namespace

Frame render_pinhole(const Scene& scene, const LensCamera& cam, int layers) {
  check_camera(cam);
  if (layers < 0 || layers > 64) throw_usage("--layers: must be 0..64");
  const int w = cam.width, h = cam.height;
  const double f = cam.f_px();
  Frame fr;
  fr.color = Image(w, h, 4);
  fr.depth = Image(w, h, 1);
  for (int l = 0; l < layers; ++l) {
    fr.layer_color.emplace_back(w, h, 4, 0.0f);
    fr.layer_depth.emplace_back(w, h, 1, std::numeric_limits<float>::infinity());
  }
  const Culler culler(scene, cam, false);
  for_each_tile(cam, {}, [&](int x0, int y0, int x1, int y1) {
    const std::vector<int> cand = culler.candidates(x0, y0, x1, y1);
    std::vector<std::pair<double, int>> hits;
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x) {
        const Vec3 o{0, 0, 0};
        const Vec3 d{(x + 0.5 - 0.5 * w) / f, (y + 0.5 - 0.5 * h) / f, 1.0};
        const Hit hit = closest(scene, cand, o, d);
        const Rgb c = radiance(scene, hit, o, d);
        fr.color.at(x, y, 0) = c.r;
        fr.color.at(x, y, 1) = c.g;
        fr.color.at(x, y, 2) = c.b;
        fr.color.at(x, y, 3) = 1.0f;
        fr.depth.at(x, y) = static_cast<float>(hit.z);
        if (layers == 0) continue;
        // Every primitive the ray enters, sorted front to back (ties by index), then the
        // background. Layer 0 is the closest, i.e. exactly the visible surface above.
        hits.clear();
        for (int i : cand) {
          const double t = intersect(scene.prims[i], o, d);
          if (t < kInf) hits.emplace_back(t, i);
        }
        std::sort(hits.begin(), hits.end());
        hits.emplace_back(kInf, -1);
        const int n = std::min<int>(layers, static_cast<int>(hits.size()));
        for (int l = 0; l < n; ++l) {
          const Hit lh{hits[l].first, hits[l].second};
          const Rgb lc = radiance(scene, lh, o, d);
          Image& col = fr.layer_color[l];
          col.at(x, y, 0) = lc.r;
          col.at(x, y, 1) = lc.g;
          col.at(x, y, 2) = lc.b;
          col.at(x, y, 3) = 1.0f;
          fr.layer_depth[l].at(x, y) = static_cast<float>(lh.z);
        }
      }
  });
  return fr;
}

namespace {

// Lens-plane region (a disc) from which the line through the focus-plane point P can reach an
// emitter sphere. Lines through P that touch the sphere form a cone with apex P, axis towards
// the centre C and half-angle asin(ρ/|C − P|); it meets the lens plane z = 0 in an ellipse.
// We bound the ellipse by a disc around the projection of C, from 16 directions on the cone
// boundary with a 10 % margin. The bound only has to be reasonable, not exact: it defines a
// partition of the lens (see render_thin_lens), and any partition gives an unbiased estimate.
struct EmitterRegion {
  double cx, cy, r;
};

bool emitter_region(const Primitive& e, Vec3 p, double lens_r, double lens_bound, EmitterRegion& out) {
  const Vec3 v = e.p0 - p;
  const double dist = std::sqrt(dot(v, v));
  if (dist < 1.5 * e.radius) return false;  // P (nearly) inside: the pixel is in focus on it
  const Vec3 w = v * (1 / dist);
  const double sin_a = e.radius / dist, cos_a = std::sqrt(1 - sin_a * sin_a);
  // A line through P in direction u meets z = 0 at P − u·(P.z / u.z); the whole cone must
  // cross the lens plane at a finite distance (u.z bounded away from 0).
  const Vec3 e1 = perpendicular(w), e2 = cross(w, e1);
  auto project = [&](Vec3 u, double& x, double& y) {
    if (std::abs(u.z) < 1e-3) return false;
    x = p.x - u.x * (p.z / u.z);
    y = p.y - u.y * (p.z / u.z);
    return true;
  };
  double cx, cy;
  if (!project(w, cx, cy)) return false;
  double r = 0;
  for (int k = 0; k < 16; ++k) {
    const double th = 2 * std::numbers::pi * k / 16;
    const Vec3 u = w * cos_a + (e1 * std::cos(th) + e2 * std::sin(th)) * sin_a;
    double x, y;
    if (u.z * w.z <= 0 || !project(u, x, y)) return false;  // cone grazes the lens plane
    r = std::max(r, std::hypot(x - cx, y - cy));
  }
  r *= 1.1;
  if (r > 0.5 * lens_r) return false;                     // large: plain lens samples do well
  if (std::hypot(cx, cy) > lens_bound + r) return false;  // cannot be seen through the lens
  out = {cx, cy, r};
  return true;
}

// Is lens-plane point (x, y) (metres) inside the aperture of radius a (circle or n-gon with
// vertices at (2k+1)π/n + rot)?
bool in_aperture(double x, double y, double a, int blades, double rot) {
  const double rr = std::hypot(x, y);
  if (rr > a) return false;
  if (blades < 3) return true;
  // Angle from the nearest edge midpoint (at 2kπ/n + rot); the boundary is at apothem / cos.
  const double sector = 2 * std::numbers::pi / blades;
  double phi = std::fmod(std::atan2(y, x) - rot, sector);
  if (phi < 0) phi += sector;
  const double from_mid = std::min(phi, sector - phi);
  return rr * std::cos(from_mid) <= a * std::cos(std::numbers::pi / blades);
}

// Radiance emission threshold above which a sphere is treated as an HDR emitter.
constexpr double kEmitterRadiance = 2.0;
// Lens samples per emitter region and pixel, at least (else the same as the main samples).
constexpr int kMinEmitterSamples = 64;

}  // namespace

// Variance reduction for small HDR emitters. A tiny, very bright emitter is seen from a small
// part of the lens; plain lens samples hit it a handful of times per pixel, so its bokeh disc
// would be very noisy. We partition the lens into the emitter regions D_1 … D_m (discs, see
// emitter_region; D_j minus the earlier ones) and the rest, and estimate each part separately:
//   ∫_lens f = ∫ f·[l ∉ ∪D] (N uniform lens samples, weight A_lens/N)
//            + Σ_j ∫_{D_j} f·[l ∈ lens]·[l ∉ D_1..D_{j−1}] (M uniform samples in D_j, weight A_Dj/M).
// Every lens point belongs to exactly one part, so the sum is unbiased whatever the regions are;
// the regions only decide where the samples go. Each sample is traced normally (occlusion by
// nearer objects, or missing the emitter, is handled by the trace).
Image render_thin_lens(const Scene& scene, const LensCamera& cam, int samples, std::uint64_t seed,
                       const Progress& progress) {
  check_camera(cam);
  if (samples < 1 || samples > (1 << 20)) throw_usage("--samples: must be 1..1048576");
  const int w = cam.width, h = cam.height;
  const double f = cam.f_px(), zf = cam.focus_m, a = cam.lens_radius_m();
  // The aperture: the model's far-field footprint of radius 1, in image axes, scaled by a.
  // Blender's rotation turns counter-clockwise on screen; these axes have y down, so the
  // polygon's edge midpoints lie at 2kπ/n − rotation here.
  const core::ApertureModel model(cam.aperture, w, h);
  const ApertureShape& ap = cam.aperture;
  const double rot = -ap.rotation_deg * std::numbers::pi / 180.0;
  const double ratio = ap.anamorphic;
  const bool round = ap.blades == 0 || ap.curvature >= 1.0;
  const int blades = round ? 0 : ap.blades;
  // Exact: an area-preserving map onto the aperture (disc or straight polygon, squeezed) and
  // its exact area. Otherwise the samples cover the bounding disc (curved blades) or box (an
  // image) and are weighted by the transmission, including the cat's eye.
  const bool exact = !ap.image && (round || ap.curvature == 0.0) && ap.cat_eye == 0.0;
  const bool boxed = ap.image != nullptr;
  const int nch = model.channels();
  const double ex = model.unit_extent_x(), ey = model.unit_extent_y();
  const double lens_bound = a * (boxed ? std::hypot(ex, ey) : std::max(1.0, 1.0 / ratio));
  // Lens area in the same normalisation as the samples (metres²): the aperture's (exact) or the
  // sampled domain's. (K = 0 is a pinhole: every sample is the same ray; a unit "area" keeps
  // the weights finite.)
  const double lens_area = a <= 0   ? 1.0
                           : boxed  ? 4 * ex * ey * a * a
                           : blades ? 0.5 * blades * a * a * std::sin(2 * std::numbers::pi / blades) / ratio
                                    : std::numbers::pi * a * a / ratio;
  const double hd = 0.5 * std::hypot(double(w), double(h));
  const std::uint32_t seed32 =
      detail::hash_combine(detail::hash32(static_cast<std::uint32_t>(seed)), static_cast<std::uint32_t>(seed >> 32));
  Image out(w, h, 4);
  const Culler culler(scene, cam, true);
  for_each_tile(cam, progress, [&](int x0, int y0, int x1, int y1) {
    const std::vector<int> cand = culler.candidates(x0, y0, x1, y1);
    std::vector<int> emitters;
    for (int i : cand)
      if (scene.prims[i].kind == Primitive::Kind::sphere && scene.prims[i].tex.emission > kEmitterRadiance)
        emitters.push_back(i);
    std::vector<EmitterRegion> regions;
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x) {
        // Focus-plane point of the pixel centre; every lens ray of this pixel passes through it.
        const Vec3 p{(x + 0.5 - 0.5 * w) / f * zf, (y + 0.5 - 0.5 * h) / f * zf, zf};
        const std::uint32_t pixel_seed = detail::hash_combine(detail::hash_combine(seed32, x), y);
        // Cat's eye: the second circle (radius 1 in lens units, squeezed like the aperture),
        // displaced toward the frame centre by cat_eye · (distance from the centre / half diagonal).
        const double eye_x = ap.cat_eye * (0.5 * w - (x + 0.5)) / hd, eye_y = ap.cat_eye * (0.5 * h - (y + 0.5)) / hd;
        // Transmission of lens point (lx, ly) (metres) per channel; returns false if it is 0.
        double t[3] = {1, 1, 1};
        auto transmit = [&](double lx, double ly) {
          const double ux = lx / a, uy = ly / a;
          if (ap.cat_eye > 0) {
            const double qx = (ux - eye_x) * ratio, qy = uy - eye_y;
            if (qx * qx + qy * qy > 1) return false;
          }
          if (exact || !ap.image) {
            if (!exact && model.unit_transmission(ux, uy, core::Field::far) <= 0) return false;
            if (exact && !in_aperture(ux * ratio * a, ly, a, blades, rot)) return false;
            t[0] = t[1] = t[2] = 1;
            return true;
          }
          bool any = false;
          for (int c = 0; c < 3; ++c) {
            t[c] = model.unit_transmission(ux, uy, core::Field::far, std::min(c, nch - 1));
            any |= t[c] > 0;
          }
          return any;
        };
        regions.clear();
        if (a > 0)
          for (int e : emitters) {
            EmitterRegion r;
            if (emitter_region(scene.prims[e], p, a, lens_bound, r)) regions.push_back(r);
          }
        auto in_region = [&](double lx, double ly, std::size_t upto) {
          for (std::size_t j = 0; j < upto; ++j)
            if ((lx - regions[j].cx) * (lx - regions[j].cx) + (ly - regions[j].cy) * (ly - regions[j].cy) <=
                regions[j].r * regions[j].r)
              return true;
          return false;
        };
        double sum[3] = {0, 0, 0}, wsum[3] = {0, 0, 0};
        auto trace = [&](double lx, double ly, double weight) {
          const Vec3 o{lx, ly, 0};
          const Vec3 d = (p - o) * (1.0 / zf);  // d.z = 1: t is planar depth
          const Rgb c = radiance(scene, closest(scene, cand, o, d), o, d);
          sum[0] += weight * t[0] * c.r;
          sum[1] += weight * t[1] * c.g;
          sum[2] += weight * t[2] * c.b;
          for (int k = 0; k < 3; ++k) wsum[k] += weight * t[k];
        };
        const detail::SobolSet lens_set(pixel_seed);
        const double w_main = lens_area / samples;
        for (int i = 0; i < samples; ++i) {
          double u, v, lx, ly;
          lens_set.sample(static_cast<std::uint32_t>(i), u, v);
          if (boxed) {
            lx = (2 * u - 1) * ex;
            ly = (2 * v - 1) * ey;
          } else {
            if (blades && exact)
              detail::polygon_sample(u, v, blades, rot, lx, ly);
            else
              detail::concentric_disc(u, v, lx, ly);
            lx /= ratio;
          }
          lx *= a;
          ly *= a;
          if (in_region(lx, ly, regions.size())) continue;
          if (!exact && !transmit(lx, ly)) continue;
          trace(lx, ly, w_main);
        }
        const int m_region = std::max(kMinEmitterSamples, samples);
        for (std::size_t j = 0; j < regions.size(); ++j) {
          const detail::SobolSet set(detail::hash_combine(pixel_seed, 0x51ed27u + static_cast<std::uint32_t>(j)));
          const EmitterRegion& r = regions[j];
          const double w_region = std::numbers::pi * r.r * r.r / m_region;
          for (int i = 0; i < m_region; ++i) {
            double u, v, lx, ly;
            set.sample(static_cast<std::uint32_t>(i), u, v);
            detail::concentric_disc(u, v, lx, ly);
            lx = r.cx + r.r * lx;
            ly = r.cy + r.r * ly;
            if (transmit(lx, ly) && !in_region(lx, ly, j)) trace(lx, ly, w_region);
          }
        }
        for (int c = 0; c < 3; ++c) {
          // Exact apertures: the known area (an unbiased estimate); else the ratio estimate.
          const double norm = exact ? lens_area : wsum[c];
          out.at(x, y, c) = norm > 0 ? static_cast<float>(sum[c] / norm) : 0.0f;
        }
        out.at(x, y, 3) = 1.0f;
      }
  });
  return out;
}

// ---------------------------------------------------------------------------------------------
// Scene pitch, ambient occlusion and the G-buffer

void pitch_scene(Scene& scene, double pitch_deg) {
  const double a = pitch_deg * std::numbers::pi / 180.0, c = std::cos(a), s = std::sin(a);
  // A level camera turned down by `a` sees the world direction (0, sin a, cos a) on its axis.
  const auto rot = [&](Vec3 w) { return Vec3{w.x, c * w.y - s * w.z, s * w.y + c * w.z}; };
  scene.pitch_deg += pitch_deg;
  // Lights are in the files' camera space (X, Y up, Z back) = the tracer's (x, −y, −z).
  const auto rot_file = [&](std::array<double, 3>& v) {
    const Vec3 t = rot({v[0], -v[1], -v[2]});
    v = {t.x, -t.y, -t.z};
  };
  for (Light& l : scene.lights) {
    rot_file(l.position_m);
    rot_file(l.direction);
  }
  for (Primitive& p : scene.prims) {
    switch (p.kind) {
      case Primitive::Kind::plane:
        p.p0 = rot(p.p0);
        p.p1 = rot(p.p1);
        p.axis_u = rot(p.axis_u);
        break;
      case Primitive::Kind::box: {
        const Vec3 centre = (p.p0 + p.p1) * 0.5, half = (p.p1 - p.p0) * 0.5;
        p.kind = Primitive::Kind::oriented_box;
        p.p0 = rot(centre);
        p.p1 = half;
        p.axis_u = rot({1, 0, 0});
        p.axis_v = rot({0, 1, 0});
        break;
      }
      case Primitive::Kind::oriented_box:
        p.p0 = rot(p.p0);
        p.axis_u = rot(p.axis_u);
        p.axis_v = rot(p.axis_v);
        break;
      case Primitive::Kind::sphere:
        p.p0 = rot(p.p0);
        break;
      case Primitive::Kind::cylinder:
        p.p0 = rot(p.p0);
        p.p1 = rot(p.p1);
        p.axis_u = rot(p.axis_u);
        break;
    }
  }
}

double ao_at(const Scene& scene, const std::vector<int>& cand, Vec3 p, Vec3 n, double radius_m, int rays,
             std::uint32_t seed) {
  if (rays < 1) throw_usage("ambient occlusion: rays must be >= 1");
  const Vec3 t1 = perpendicular(n), t2 = cross(n, t1);
  // Lift the origin off the surface so that a ray never finds the surface it starts on (the
  // hit point carries the rounding of the primary ray).
  const double lift = 1e-7 * (1 + std::sqrt(dot(p, p)));
  const Vec3 o = p + n * lift;
  const int count = cand.empty() ? static_cast<int>(scene.prims.size()) : static_cast<int>(cand.size());
  const detail::SobolSet set(seed);
  int open = 0;
  for (int i = 0; i < rays; ++i) {
    double u, v, dx, dy;
    set.sample(static_cast<std::uint32_t>(i), u, v);
    detail::concentric_disc(u, v, dx, dy);
    const double dz = std::sqrt(std::max(0.0, 1 - dx * dx - dy * dy));
    const Vec3 d = t1 * dx + t2 * dy + n * dz;  // unit length: t is the distance
    bool hit = false;
    for (int k = 0; k < count && !hit; ++k) {
      const int idx = cand.empty() ? k : cand[k];
      const double t = intersect(scene.prims[idx], o, d);  // kInf: missed
      hit = t < kInf && t <= radius_m;
    }
    open += hit ? 0 : 1;
  }
  return static_cast<double>(open) / rays;
}

namespace {

// Primary hit of pixel (x, y) of the pinhole camera: the hit (z = ray parameter = depth), the
// point and the ray direction (d.z = 1).
struct PrimaryHit {
  Hit hit;
  Vec3 point, dir;
};
PrimaryHit primary_hit(const Scene& scene, const std::vector<int>& cand, const LensCamera& cam, double f, int x,
                       int y) {
  PrimaryHit r;
  r.dir = {(x + 0.5 - 0.5 * cam.width) / f, (y + 0.5 - 0.5 * cam.height) / f, 1.0};
  // The opaque surface: key transparencies (camera_alpha < 1) are not in the opaque buffers.
  for (int i : cand) {
    if (scene.prims[i].camera_alpha < 1) continue;
    const double t = intersect(scene.prims[i], {0, 0, 0}, r.dir);
    if (t < r.hit.z) {
      r.hit.z = t;
      r.hit.prim = i;
    }
  }
  if (r.hit.prim >= 0) r.point = r.dir * r.hit.z;
  return r;
}

// The normal of a primary hit turned towards the camera.
Vec3 facing_normal(const Scene& scene, const PrimaryHit& h) {
  Vec3 n = normal_at(scene.prims[h.hit.prim], h.point);
  if (dot(n, h.dir) > 0) n = n * -1.0;
  return n;
}

// Calls body(x, y, hit) for every pixel centre's opaque primary hit, tile by tile in parallel
// (each pixel once, so writes to the pixel's own output are thread-count independent).
template <class Body>
void for_each_primary_hit(const Scene& scene, const LensCamera& cam, Body body) {
  const double f = cam.f_px();
  const Culler culler(scene, cam, false);
  for_each_tile(cam, {}, [&](int x0, int y0, int x1, int y1) {
    const std::vector<int> cand = culler.candidates(x0, y0, x1, y1);
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x) body(x, y, primary_hit(scene, cand, cam, f, x, y));
  });
}

}  // namespace

Image render_ao(const Scene& scene, const LensCamera& cam, double radius_m, int rays, std::uint64_t seed,
                const Progress& progress) {
  check_camera(cam);
  if (!(radius_m > 0)) throw_usage("ambient occlusion radius must be > 0 metres");
  if (rays < 1 || rays > (1 << 20)) throw_usage("ambient occlusion rays must be 1..1048576");
  const int w = cam.width, h = cam.height;
  const double f = cam.f_px();
  const std::uint32_t seed32 = detail::hash_combine(detail::hash32(static_cast<std::uint32_t>(seed) ^ 0x0a0c1u),
                                                    static_cast<std::uint32_t>(seed >> 32));
  Image out(w, h, 1, 1.0f);
  const Culler culler(scene, cam, false);
  for_each_tile(cam, progress, [&](int x0, int y0, int x1, int y1) {
    const std::vector<int> cand = culler.candidates(x0, y0, x1, y1);
    std::vector<PrimaryHit> hits;
    Vec3 lo{kInf, kInf, kInf}, hi{-kInf, -kInf, -kInf};
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x) {
        hits.push_back(primary_hit(scene, cand, cam, f, x, y));
        const PrimaryHit& ph = hits.back();
        if (ph.hit.prim < 0) continue;
        lo = {std::min(lo.x, ph.point.x), std::min(lo.y, ph.point.y), std::min(lo.z, ph.point.z)};
        hi = {std::max(hi.x, ph.point.x), std::max(hi.y, ph.point.y), std::max(hi.z, ph.point.z)};
      }
    // Occluders: the primitives within radius_m of the tile's hit points' bounds (all of them
    // when the radius is unlimited). Culling only skips primitives no ray can hit in range.
    std::vector<int> near;
    for (int i = 0; i < static_cast<int>(scene.prims.size()); ++i) {
      Vec3 plo, phi;
      if (std::isinf(radius_m) || !bounds_of(scene.prims[i], plo, phi) ||
          (plo.x <= hi.x + radius_m && phi.x >= lo.x - radius_m && plo.y <= hi.y + radius_m &&
           phi.y >= lo.y - radius_m && plo.z <= hi.z + radius_m && phi.z >= lo.z - radius_m))
        near.push_back(i);
    }
    std::size_t k = 0;
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x) {
        const PrimaryHit& ph = hits[k++];
        if (ph.hit.prim < 0) continue;  // background: 1
        const std::uint32_t pixel_seed = detail::hash_combine(detail::hash_combine(seed32, x), y);
        // No primitive in range: nothing can occlude (ao_at would read an empty list as "all").
        if (!near.empty())
          out.at(x, y) =
              static_cast<float>(ao_at(scene, near, ph.point, facing_normal(scene, ph), radius_m, rays, pixel_seed));
      }
  });
  return out;
}

GBuffer render_gbuffer(const Scene& scene, const LensCamera& cam) {
  check_camera(cam);
  const int w = cam.width, h = cam.height;
  const double f = cam.f_px();
  GBuffer g;
  g.z = Image(w, h, 1);
  g.normal = Image(w, h, 3, 0.0f);
  g.albedo = Image(w, h, 3, 0.0f);
  g.specular = Image(w, h, 3, 0.0f);
  g.gloss = Image(w, h, 1, 0.0f);
  g.emissive = Image(w, h, 3, 0.0f);
  const Culler culler(scene, cam, false);
  for_each_tile(cam, {}, [&](int x0, int y0, int x1, int y1) {
    const std::vector<int> cand = culler.candidates(x0, y0, x1, y1);
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x) {
        const PrimaryHit ph = primary_hit(scene, cand, cam, f, x, y);
        g.z.at(x, y) = static_cast<float>(ph.hit.z);
        if (ph.hit.prim < 0) {
          const Rgb sky = shade_background(scene.background, ph.dir);
          g.emissive.at(x, y, 0) = sky.r;
          g.emissive.at(x, y, 1) = sky.g;
          g.emissive.at(x, y, 2) = sky.b;
          continue;
        }
        const Primitive& p = scene.prims[ph.hit.prim];
        // Camera space of the files: X right, Y up, Z towards the camera (the tracer's y and z
        // point the other way).
        const Vec3 n = facing_normal(scene, ph);
        g.normal.at(x, y, 0) = static_cast<float>(n.x);
        g.normal.at(x, y, 1) = static_cast<float>(-n.y);
        g.normal.at(x, y, 2) = static_cast<float>(-n.z);
        const Rgb c = shade_at(p, ph.point);
        const bool emitter = p.tex.emission > 1;
        const float to_albedo = static_cast<float>(1 / p.tex.emission);
        const float rgb[3] = {c.r, c.g, c.b};
        const float spec[3] = {p.specular.r, p.specular.g, p.specular.b};
        for (int ch = 0; ch < 3; ++ch) {
          if (emitter)
            g.emissive.at(x, y, ch) = rgb[ch];
          else
            g.albedo.at(x, y, ch) = std::clamp(rgb[ch] * to_albedo, 0.0f, 1.0f);
          g.specular.at(x, y, ch) = std::clamp(spec[ch], 0.0f, 1.0f);
        }
        g.gloss.at(x, y) = std::clamp(p.gloss, 0.0f, 1.0f);
      }
  });
  return g;
}

Rgb lit_at(const Scene& scene, const Primitive& p, Vec3 x, Vec3 eye) {
  const Rgb c = shade_at(p, x);
  if (p.tex.emission > 1) return c;
  // The files' camera space: the tracer's (x, −y, −z).
  Vec3 n = normal_at(p, x);
  const Vec3 to_eye = eye - x;
  if (dot(n, to_eye) < 0) n = n * -1.0;
  const double len = std::sqrt(dot(to_eye, to_eye));
  const std::array<double, 3> P{x.x, -x.y, -x.z}, N{n.x, -n.y, -n.z};
  const std::array<double, 3> V{to_eye.x / len, -to_eye.y / len, -to_eye.z / len};
  std::array<double, 3> albedo, spec;
  const float to_albedo = static_cast<float>(1 / p.tex.emission);
  const float rgb[3] = {c.r, c.g, c.b}, sp[3] = {p.specular.r, p.specular.g, p.specular.b};
  for (int ch = 0; ch < 3; ++ch) {
    albedo[ch] = std::clamp(rgb[ch] * to_albedo, 0.0f, 1.0f);
    spec[ch] = std::clamp(sp[ch], 0.0f, 1.0f);
  }
  const double gloss = std::clamp(p.gloss, 0.0f, 1.0f);
  const int own = (&p >= scene.prims.data() && &p < scene.prims.data() + scene.prims.size())
                      ? static_cast<int>(&p - scene.prims.data())
                      : -1;
  double acc[3] = {0, 0, 0};
  for (const Light& l : scene.lights) {
    const std::array<double, 3> c3 = shade_light(l, P, N, V, albedo, spec, gloss);
    if (c3[0] == 0 && c3[1] == 0 && c3[2] == 0) continue;
    const Rgb t = shadow_transmittance(scene, l, x, own);
    const double tr[3] = {t.r, t.g, t.b};
    for (int ch = 0; ch < 3; ++ch) acc[ch] += c3[ch] * tr[ch];
  }
  return {static_cast<float>(acc[0]), static_cast<float>(acc[1]), static_cast<float>(acc[2])};
}

Image render_lit(const Scene& scene, const LensCamera& cam) {
  check_camera(cam);
  Image out(cam.width, cam.height, 3, 0.0f);
  for_each_primary_hit(scene, cam, [&](int x, int y, const PrimaryHit& ph) {
    const Rgb c = ph.hit.prim < 0 ? shade_background(scene.background, ph.dir)
                                  : lit_at(scene, scene.prims[ph.hit.prim], ph.point, {0, 0, 0});
    out.at(x, y, 0) = c.r;
    out.at(x, y, 1) = c.g;
    out.at(x, y, 2) = c.b;
  });
  return out;
}

Rgb shadow_transmittance(const Scene& scene, const Light& l, Vec3 x, int own) {
  if (!l.casts_shadows || l.kind == Light::Kind::ambient) return {1, 1, 1};
  // The files' camera space is the tracer's (x, −y, −z).
  Vec3 d;
  double t_max;
  if (l.kind == Light::Kind::directional) {
    d = {-l.direction[0], l.direction[1], l.direction[2]};
    t_max = kInf;
  } else {
    d = Vec3{l.position_m[0], -l.position_m[1], -l.position_m[2]} - x;
    t_max = 1;  // the light itself
  }
  double f[3] = {1, 1, 1};
  for (int i = 0; i < static_cast<int>(scene.prims.size()); ++i) {
    const Primitive& p = scene.prims[i];
    if (i == own || p.camera_alpha < 1) continue;  // key transparencies cast no shadow
    const double t = intersect(p, x, d);
    if (!(t < t_max)) continue;
    if (!p.translucent) return {0, 0, 0};
    f[0] *= p.filter.r;
    f[1] *= p.filter.g;
    f[2] *= p.filter.b;
  }
  return {static_cast<float>(f[0]), static_cast<float>(f[1]), static_cast<float>(f[2])};
}

namespace {

// A spot light's map frame: camera → light space (the light looks along −Z, its axis) and a
// square perspective projection; f = the projection's focal factor.
void shadow_frame(const Light& l, std::array<double, 16>& view, std::array<double, 16>& proj, double& f) {
  const std::array<double, 3> z = {-l.direction[0], -l.direction[1], -l.direction[2]};
  const std::array<double, 3> up =
      std::abs(z[1]) < 0.9 ? std::array<double, 3>{0, 1, 0} : std::array<double, 3>{1, 0, 0};
  std::array<double, 3> x = {up[1] * z[2] - up[2] * z[1], up[2] * z[0] - up[0] * z[2], up[0] * z[1] - up[1] * z[0]};
  const double xl = std::sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
  for (double& v : x) v /= xl;
  const std::array<double, 3> y = {z[1] * x[2] - z[2] * x[1], z[2] * x[0] - z[0] * x[2], z[0] * x[1] - z[1] * x[0]};
  const std::array<double, 3>* rows[3] = {&x, &y, &z};
  view = {};
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) view[4 * r + c] = (*rows[r])[c];
    view[4 * r + 3] =
        -((*rows[r])[0] * l.position_m[0] + (*rows[r])[1] * l.position_m[1] + (*rows[r])[2] * l.position_m[2]);
  }
  view[15] = 1;
  f = 1 / std::tan((l.outer_deg + 2) * std::numbers::pi / 180);
  // An OpenGL-style projection with near 0.01 m and far at the light's radius (its z row is
  // for a rasteriser; the lookup compares the light's planar depth −q.z).
  const double n = 0.01, fr = std::max(l.radius_m, 0.02);
  proj = {f, 0, 0, 0, 0, f, 0, 0, 0, 0, (fr + n) / (n - fr), 2 * fr * n / (n - fr), 0, 0, -1, 0};
}

// Camera-space point → tracer axes, and a light-space vector → camera space (the view's
// rotation transposed).
Vec3 tracer_of(const std::array<double, 3>& p) { return {p[0], -p[1], -p[2]}; }
std::array<double, 3> light_to_camera(const std::array<double, 16>& view, double lx, double ly, double lz) {
  std::array<double, 3> o{};
  for (int c = 0; c < 3; ++c) o[c] = view[c] * lx + view[4 + c] * ly + view[8 + c] * lz;
  return o;
}

// The primitives (bit i = primitive i, the first 64) that the whole line from the light through
// x crosses: from a point or spot light's position on, or along a directional light's
// direction through x.
std::uint64_t casters_on_line(const Scene& scene, const Light& l, Vec3 x) {
  Vec3 o, d;
  if (l.kind == Light::Kind::directional) {
    d = tracer_of(l.direction);
    o = x - d * 1e4;
  } else {
    o = tracer_of(l.position_m);
    d = x - o;
  }
  std::uint64_t set = 0;
  for (std::size_t i = 0; i < scene.prims.size() && i < 64; ++i)
    if (!(scene.prims[i].camera_alpha < 1) && intersect(scene.prims[i], o, d) < kInf) set |= std::uint64_t{1} << i;
  return set;
}

}  // namespace

ShadowMaps render_shadow_maps(const Scene& scene, const Light& l, int size_px, double bias_m) {
  if (l.kind != Light::Kind::spot) throw_usage("shadow maps: only spot lights get rendered maps");
  if (!(l.outer_deg <= 80)) throw_usage("shadow maps: a spot's outer cone must be <= 80 degrees");
  if (size_px < 1 || size_px > kMaxShadowMapSide)
    throw_usage("shadow maps: size must be 1.." + std::to_string(kMaxShadowMapSide));
  ShadowMaps m;
  double f = 1;
  shadow_frame(l, m.view, m.projection, f);
  m.bias_m = bias_m;
  m.opaque_depth = Image(size_px, size_px, 1, static_cast<float>(kInf));
  m.translucent_depth = Image(size_px, size_px, 1, static_cast<float>(kInf));
  m.translucent_color = Image(size_px, size_px, 3, 1.0f);
  const Vec3 o = tracer_of(l.position_m);
  core::parallel_for(size_px, [&](int y0, int y1) {
    std::vector<double> ts(scene.prims.size());
    for (int y = y0; y < y1; ++y)
      for (int x = 0; x < size_px; ++x) {
        // Texel centre → NDC → light-space ray with z = −1, so the ray parameter is the depth.
        const double u = 2 * (x + 0.5) / size_px - 1, v = 1 - 2 * (y + 0.5) / size_px;
        const Vec3 d = tracer_of(light_to_camera(m.view, u / f, v / f, -1));
        double opaque = kInf, trans = kInf;
        for (std::size_t i = 0; i < scene.prims.size(); ++i) {
          ts[i] = scene.prims[i].camera_alpha < 1 ? kInf : intersect(scene.prims[i], o, d);
          if (!scene.prims[i].translucent) opaque = std::min(opaque, ts[i]);
        }
        double c[3] = {1, 1, 1};
        for (std::size_t i = 0; i < scene.prims.size(); ++i) {
          const Primitive& p = scene.prims[i];
          if (!p.translucent || !(ts[i] < kInf)) continue;
          trans = std::min(trans, ts[i]);
          if (ts[i] <= opaque) {  // the colour pass's less-equal test against the opaque map
            c[0] *= p.filter.r;
            c[1] *= p.filter.g;
            c[2] *= p.filter.b;
          }
        }
        m.opaque_depth.at(x, y) = static_cast<float>(opaque);
        m.translucent_depth.at(x, y) = static_cast<float>(trans);
        for (int k = 0; k < 3; ++k) m.translucent_color.at(x, y, k) = static_cast<float>(c[k]);
      }
  });
  return m;
}

Image render_transparency(const Scene& scene, const LensCamera& cam) {
  check_camera(cam);
  const double f = cam.f_px();
  Image out(cam.width, cam.height, 5, 0.0f);
  for (std::size_t i = 0; i < out.plane_size(); ++i) out.plane(4)[i] = static_cast<float>(kInf);
  core::parallel_for(cam.height, [&](int y0, int y1) {
    for (int y = y0; y < y1; ++y)
      for (int x = 0; x < cam.width; ++x) {
        const Vec3 d{(x + 0.5 - 0.5 * cam.width) / f, (y + 0.5 - 0.5 * cam.height) / f, 1.0};
        Hit opaque, key;
        for (int i = 0; i < static_cast<int>(scene.prims.size()); ++i) {
          const double t = intersect(scene.prims[i], {0, 0, 0}, d);
          Hit& h = scene.prims[i].camera_alpha < 1 ? key : opaque;
          if (t < h.z) {
            h.z = t;
            h.prim = i;
          }
        }
        if (key.prim < 0 || !(key.z < opaque.z)) continue;
        const Primitive& p = scene.prims[key.prim];
        const Rgb c = lit_at(scene, p, d * key.z, {0, 0, 0});
        const float a = p.camera_alpha;
        out.at(x, y, 0) = a * c.r;
        out.at(x, y, 1) = a * c.g;
        out.at(x, y, 2) = a * c.b;
        out.at(x, y, 3) = a;
        out.at(x, y, 4) = static_cast<float>(key.z);
      }
  });
  return out;
}

Image primitive_ids(const Scene& scene, const LensCamera& cam) {
  check_camera(cam);
  Image out(cam.width, cam.height, 1, -1.0f);
  for_each_primary_hit(scene, cam,
                       [&](int x, int y, const PrimaryHit& ph) { out.at(x, y) = static_cast<float>(ph.hit.prim); });
  return out;
}

Image shadow_band(const Scene& scene, const LensCamera& cam, const Light& l, const ShadowMaps& m, double texels) {
  check_camera(cam);
  const int mw = m.opaque_depth.width();
  Image out(cam.width, cam.height, 1, 0.0f);
  for_each_primary_hit(scene, cam, [&](int x, int y, const PrimaryHit& ph) {
    if (ph.hit.prim < 0) return;
    const std::array<double, 3> p = {ph.point.x, -ph.point.y, -ph.point.z};
    double q[4], c[4];
    for (int r = 0; r < 4; ++r)
      q[r] = m.view[4 * r] * p[0] + m.view[4 * r + 1] * p[1] + m.view[4 * r + 2] * p[2] + m.view[4 * r + 3];
    for (int r = 0; r < 4; ++r)
      c[r] = m.projection[4 * r] * q[0] + m.projection[4 * r + 1] * q[1] + m.projection[4 * r + 2] * q[2] +
             m.projection[4 * r + 3] * q[3];
    if (!(c[3] > 0) || std::abs(c[0] / c[3]) >= 1 || std::abs(c[1] / c[3]) >= 1) {
      out.at(x, y) = 1;
      return;
    }
    // One texel across the light's view at this depth (light-space metres).
    const double step = 2 * c[3] / (m.projection[0] * mw);
    const std::uint64_t here = casters_on_line(scene, l, ph.point);
    bool edge = false;
    for (int j = -2; j <= 2 && !edge; ++j)
      for (int i = -2; i <= 2 && !edge; ++i) {
        if (i == 0 && j == 0) continue;
        const std::array<double, 3> off = light_to_camera(m.view, i * 0.5 * texels * step, j * 0.5 * texels * step, 0);
        edge = casters_on_line(scene, l, ph.point + tracer_of(off)) != here;
      }
    if (edge) out.at(x, y) = 1;
  });
  return out;
}

std::array<double, 16> world_to_camera(const Scene& scene) {
  // pitch_scene turns the tracer's (x, y down, z forward) by R; in the files' axes
  // S·R·S with S = diag(1, −1, −1), which is R again.
  const double a = scene.pitch_deg * std::numbers::pi / 180.0, c = std::cos(a), s = std::sin(a);
  return {1, 0, 0, 0, 0, c, -s, 0, 0, s, c, 0, 0, 0, 0, 1};
}

}  // namespace dofkit::scene
