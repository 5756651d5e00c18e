// Deferred lighting (include/dofkit/light.hpp, docs/methods/lighting.md).
//
// Two paths share one per-pixel shading loop (shade_pixel), so they add the same terms in the
// same order:
//   brute: every light at every pixel;
//   tiled: per 16×16 tile, the lights whose volume reaches the tile's frustum (side planes
//          through the tile's edges, depth slab between its nearest and farthest depth), and
//          per pixel only those whose volume holds the pixel's reconstructed point (the
//          stencil test: the ray's entry and exit through the light sphere bracket the depth;
//          with the camera inside the sphere only the exit counts; a spot's cone as well).
// Every test is conservative (volumes grown by a relative 1e-6), and the shading of a light
// outside its volume is exactly +0 or −0 (the window and the spot factor saturate to 0), so
// skipping it leaves the sum's bits unchanged: the two paths are bit-identical (tested).
// Each tile writes only its own pixels, so the result is the same for every thread count.
#include "dofkit/light.hpp"

#include <algorithm>
#include <cmath>
#include <mutex>
#include <numbers>

#include "core/parallel.hpp"
#include "dofkit/error.hpp"

namespace dofkit {

namespace {

constexpr int kTile = 16;
constexpr double kGrow = 1e-6;  // relative growth of every culling volume
constexpr double kPi = std::numbers::pi;

using V3 = std::array<double, 3>;
double dot3(const V3& a, const V3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
V3 sub3(const V3& a, const V3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
V3 cross3(const V3& a, const V3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

std::string num(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%g", v);
  return b;
}

// A light with its per-light constants.
struct Prepared {
  Light::Kind kind;
  V3 pos, axis, rad;  // rad = colour · intensity
  double r2 = 0, inv_r2 = 0;
  double cos_outer = 0, inv_cos_range = 0;
  bool ao = false;
  // Culling volume: bounding sphere (centre, radius) of the light's reach, grown.
  V3 bound_c;
  double bound_r = 0;
  double stencil_r2 = 0;  // the grown sphere, squared
  double cos_outer_grown = 0, sin_outer = 0;
  bool local = false;  // point / spot: culled; directional / ambient: everywhere
  const ShadowMaps* shadow = nullptr;
};

Prepared prepare(const Light& l) {
  Prepared p;
  p.kind = l.kind;
  p.pos = l.position_m;
  p.axis = l.direction;
  for (int c = 0; c < 3; ++c) p.rad[c] = l.color[c] * l.intensity;
  p.ao = l.ao;
  p.shadow = l.shadow.get();
  p.local = l.kind == Light::Kind::point || l.kind == Light::Kind::spot;
  if (!p.local) return p;
  p.r2 = l.radius_m * l.radius_m;
  p.inv_r2 = 1 / p.r2;
  const double grown = l.radius_m * (1 + kGrow) + 1e-12;
  p.stencil_r2 = grown * grown;
  p.bound_c = l.position_m;
  p.bound_r = grown;
  if (l.kind == Light::Kind::spot) {
    const double outer = l.outer_deg * kPi / 180, inner = l.inner_deg * kPi / 180;
    p.cos_outer = std::cos(outer);
    p.inv_cos_range = 1 / (std::cos(inner) - p.cos_outer);
    p.cos_outer_grown = p.cos_outer - kGrow;
    p.sin_outer = std::sin(std::min(outer + kGrow, kPi / 2));
    // The cone's bounding sphere: for a wide cone the cap's circle, for a narrow one the sphere
    // through the apex and the cap's rim (centre on the axis at r / (2 cos θ)).
    if (outer > kPi / 4) {
      const double c = std::cos(outer), s = std::sin(outer);
      for (int k = 0; k < 3; ++k) p.bound_c[k] = l.position_m[k] + l.direction[k] * l.radius_m * c;
      p.bound_r = std::min(grown, (l.radius_m * s) * (1 + kGrow) + 1e-12);
      // A cone wider than 45° keeps the cap itself too: the sphere's part beyond the cap's
      // circle plane reaches r·(1 − cos θ) further, within the radius r·sin θ for θ ≥ 45°.
    } else {
      const double c = std::cos(outer);
      const double h = l.radius_m / (2 * c);
      for (int k = 0; k < 3; ++k) p.bound_c[k] = l.position_m[k] + l.direction[k] * h;
      p.bound_r = h * (1 + kGrow) + 1e-12;
    }
  }
  return p;
}

// Everything the shading needs about one pixel.
struct Pixel {
  V3 p, n, v;
  V3 diffuse;  // albedo / π
  V3 spec;     // specular · (e + 8) / (8π)
  double e = 0;
  double albedo[3];
  double ao = 1;
};

// One light's contribution at one pixel. Exactly ±0 outside the light's volume.
[[gnu::noinline]] void shade(const Pixel& px, const Prepared& l, double out[3]) {
  out[0] = out[1] = out[2] = 0;
  if (l.kind == Light::Kind::ambient) {
    const double a = l.ao ? px.ao : 1;
    for (int c = 0; c < 3; ++c) out[c] = px.albedo[c] * l.rad[c] * a;
    return;
  }
  V3 L;
  double scale;
  if (l.kind == Light::Kind::directional) {
    L = {-l.axis[0], -l.axis[1], -l.axis[2]};
    scale = 1;
  } else {
    const V3 d = sub3(l.pos, px.p);
    const double d2 = dot3(d, d);
    if (!(d2 < l.r2) || d2 < 1e-30) return;
    const double x = d2 * l.inv_r2;
    double w = 1 - x * x;
    w = std::clamp(w, 0.0, 1.0);
    scale = w * w / std::max(d2, kMinLightDistance2);
    const double inv_d = 1 / std::sqrt(d2);
    L = {d[0] * inv_d, d[1] * inv_d, d[2] * inv_d};
    if (l.kind == Light::Kind::spot) {
      const double cos_a = -dot3(L, l.axis);
      const double t = std::clamp((cos_a - l.cos_outer) * l.inv_cos_range, 0.0, 1.0);
      scale *= t * t;
    }
  }
  const double nl = dot3(px.n, L);
  if (!(nl > 0)) return;
  scale *= nl;
  if (l.ao) scale *= px.ao;
  const V3 h = {L[0] + px.v[0], L[1] + px.v[1], L[2] + px.v[2]};
  const double hh = dot3(h, h);
  double sp = 0;
  if (hh > 1e-30) {
    const double nh = dot3(px.n, h) / std::sqrt(hh);
    if (nh > 0) sp = std::pow(nh, px.e);
  }
  for (int c = 0; c < 3; ++c) out[c] = (px.diffuse[c] + px.spec[c] * sp) * l.rad[c] * scale;
}

struct Buffers {
  int w = 0, h = 0;
  const float *z, *n[3], *alb[3], *spc[3], *gl, *em[3], *ao;
  double f = 0;
};

const float* plane_or_null(const Image* im, int c) { return im ? im->plane(c) : nullptr; }

// The pixel's reconstructed point; false for the background.
bool load_point(const Buffers& b, int x, int y, Pixel& px) {
  const double z = b.z[static_cast<std::size_t>(y) * b.w + x];
  if (std::isinf(z)) return false;
  // §5.4's reconstruction: the pixel's eye ray (d.z = −1) times its planar depth.
  px.p = {(x + 0.5 - 0.5 * b.w) / b.f * z, -(y + 0.5 - 0.5 * b.h) / b.f * z, -z};
  return true;
}

// The rest of the pixel (after load_point): normal, view direction, material; false for a
// zero normal (no light).
bool load_material(const Buffers& b, int x, int y, Pixel& px) {
  const std::size_t i = static_cast<std::size_t>(y) * b.w + x;
  const double nx = b.n[0][i], ny = b.n[1][i], nz = b.n[2][i];
  const double nn = nx * nx + ny * ny + nz * nz;
  if (!(nn > 0)) return false;
  const double inv_n = 1 / std::sqrt(nn);
  px.n = {nx * inv_n, ny * inv_n, nz * inv_n};
  const double inv_len = 1 / std::sqrt(dot3(px.p, px.p));
  px.v = {-px.p[0] * inv_len, -px.p[1] * inv_len, -px.p[2] * inv_len};
  const double g = b.gl ? std::clamp(static_cast<double>(b.gl[i]), 0.0, 1.0) : 0.0;
  px.e = std::exp2(1 + 12 * g);
  const double norm = (px.e + 8) / (8 * kPi);
  for (int c = 0; c < 3; ++c) {
    px.albedo[c] = b.alb[c][i];
    px.diffuse[c] = px.albedo[c] / kPi;
    px.spec[c] = (b.spc[c] ? b.spc[c][i] : 0.0) * norm;
  }
  px.ao = b.ao ? std::clamp(static_cast<double>(b.ao[i]), 0.0, 1.0) : 1.0;
  return true;
}

// The shading loop both paths share: emissive, then the listed lights in order.
void shade_pixel(const Buffers& b, bool lit, const Pixel& px, int x, int y, const Prepared* const* list, int count,
                 const int* index, bool emissive, Image& out, std::vector<Image>* layers, long long* shaded) {
  const std::size_t i = static_cast<std::size_t>(y) * b.w + x;
  double acc[3] = {0, 0, 0};
  if (emissive && b.em[0])
    for (int c = 0; c < 3; ++c) acc[c] += b.em[c][i];
  if (lit)
    for (int k = 0; k < count; ++k) {
      double contrib[3];
      shade(px, *list[k], contrib);
      if (list[k]->shadow && (contrib[0] != 0 || contrib[1] != 0 || contrib[2] != 0)) {
        const std::array<double, 3> t = shadow_factor(*list[k]->shadow, px.p);
        for (int c = 0; c < 3; ++c) contrib[c] *= t[c];
      }
      for (int c = 0; c < 3; ++c) acc[c] += contrib[c];
      if (layers)
        for (int c = 0; c < 3; ++c) (*layers)[index[k]].plane(c)[i] = static_cast<float>(contrib[c] + 0.0);
      if (shaded) ++shaded[index[k]];
    }
  for (int c = 0; c < 3; ++c) out.plane(c)[i] = static_cast<float>(acc[c]);
}

// A tile's frustum: four side planes through the camera (unit normals pointing inside) and
// the slab of planar depth [zmin, zmax].
struct TileFrustum {
  V3 plane[4];
  double zmin, zmax;
  V3 centre;  // bounding sphere of the frustum piece
  double radius;
};

V3 ray_dir(const Buffers& b, double px, double py) { return {(px - 0.5 * b.w) / b.f, -(py - 0.5 * b.h) / b.f, -1.0}; }

TileFrustum tile_frustum(const Buffers& b, int x0, int y0, int x1, int y1, double zmin, double zmax) {
  TileFrustum t;
  t.zmin = zmin;
  t.zmax = zmax;
  const V3 c00 = ray_dir(b, x0, y0), c10 = ray_dir(b, x1, y0), c11 = ray_dir(b, x1, y1), c01 = ray_dir(b, x0, y1);
  const V3 mid = ray_dir(b, 0.5 * (x0 + x1), 0.5 * (y0 + y1));
  const V3 edges[4][2] = {{c00, c10}, {c10, c11}, {c11, c01}, {c01, c00}};
  for (int k = 0; k < 4; ++k) {
    V3 n = cross3(edges[k][0], edges[k][1]);
    const double len = std::sqrt(dot3(n, n));
    for (double& v : n) v /= len;
    if (dot3(n, mid) < 0)
      for (double& v : n) v = -v;
    t.plane[k] = n;
  }
  // Bounding sphere of the eight corners (the four edge rays at zmin and zmax).
  V3 corners[8];
  int k = 0;
  for (const V3* c : {&c00, &c10, &c11, &c01})
    for (double z : {zmin, zmax}) corners[k++] = {(*c)[0] * z, (*c)[1] * z, (*c)[2] * z};
  t.centre = {0, 0, 0};
  for (const V3& c : corners)
    for (int j = 0; j < 3; ++j) t.centre[j] += c[j] / 8;
  t.radius = 0;
  for (const V3& c : corners) {
    const V3 d = sub3(c, t.centre);
    t.radius = std::max(t.radius, std::sqrt(dot3(d, d)));
  }
  t.radius = t.radius * (1 + kGrow) + 1e-9;
  return t;
}

// Whether a light's volume can reach the tile's frustum (conservative).
bool reaches_tile(const Prepared& l, const TileFrustum& t) {
  if (!l.local) return true;
  const double r = l.bound_r;
  const V3& c = l.bound_c;
  const double margin = 1e-9 * (1 + std::sqrt(dot3(c, c)));
  for (const V3& n : t.plane)
    if (dot3(n, c) < -r - margin) return false;
  const double depth = -c[2];
  if (depth + r < t.zmin * (1 - kGrow) - margin || depth - r > t.zmax * (1 + kGrow) + margin) return false;
  if (l.kind == Light::Kind::spot) {
    // The cone against the frustum's bounding sphere: the sphere's distance from the cone's
    // surface, beyond the cap, or behind the apex.
    const V3 v = sub3(t.centre, l.pos);
    const double len2 = dot3(v, v), along = dot3(v, l.axis);
    const double across = std::sqrt(std::max(0.0, len2 - along * along));
    const double cos_o = std::sqrt(std::max(0.0, 1 - l.sin_outer * l.sin_outer));
    const double dist = cos_o * across - along * l.sin_outer;
    const double range = std::sqrt(l.stencil_r2);
    if (dist > t.radius + margin || along > t.radius + range + margin || along < -t.radius - margin) return false;
  }
  return true;
}

// The per-pixel volume test (the stencil): is the pixel's point inside the light's volume?
// The pixel ray t·d (d = the eye ray with d.z = −1) enters the grown sphere at t0 and leaves
// it at t1; with the camera outside, the surface at depth z is inside iff t0 <= z <= t1 (the
// front face is in front of it and the back face hidden); with the camera inside only the
// back face is seen, and the surface is inside iff z <= t1.
bool inside_volume(const Prepared& l, bool camera_inside, const V3& d, double z, const V3& p) {
  const double a = dot3(d, d), bq = dot3(d, l.pos), c = dot3(l.pos, l.pos) - l.stencil_r2;
  const double disc = bq * bq - a * c;
  if (disc < 0) return false;
  const double s = std::sqrt(disc);
  const double t1 = (bq + s) / a;
  const double tol = 1e-9 * (1 + z);
  if (z > t1 + tol) return false;
  if (!camera_inside) {
    const double t0 = (bq - s) / a;
    if (z < t0 - tol) return false;
  }
  if (l.kind == Light::Kind::spot) {
    const V3 q = sub3(p, l.pos);
    const double len = std::sqrt(dot3(q, q));
    if (dot3(q, l.axis) < l.cos_outer_grown * len - 1e-12) return false;
  }
  return true;
}

// The first pixel (raster order) at which `bad` holds, or −1; rows are scanned in parallel (the
// fixed cost of a lighting pass is mostly these checks), and the answer is the same for every
// thread count.
template <class Bad>
long long first_bad(const Image& im, int c, Bad bad) {
  std::vector<long long> first(im.height(), -1);
  const float* p = im.plane(c);
  core::parallel_for(
      im.height(),
      [&](int y0, int y1) {
        for (int y = y0; y < y1; ++y) {
          const float* row = p + static_cast<std::size_t>(y) * im.width();
          for (int x = 0; x < im.width(); ++x)
            if (bad(row[x])) {
              first[y] = static_cast<long long>(y) * im.width() + x;
              break;
            }
        }
      },
      16);
  for (long long f : first)
    if (f >= 0) return f;
  return -1;
}

std::string pixel_of(const Image& im, long long i) {
  return "(" + std::to_string(i % im.width()) + ", " + std::to_string(i / im.width()) + ")";
}

void check_plane_finite(const Image* im, const char* what) {
  if (!im) return;
  for (int c = 0; c < im->channels(); ++c) {
    const long long i = first_bad(*im, c, [](float v) { return !std::isfinite(v); });
    if (i >= 0) throw_bad_input(std::string(what) + ": non-finite value at pixel " + pixel_of(*im, i));
  }
}

Buffers check_and_bind(const GBufferRef& g, double hfov_deg, const Image* ao) {
  if (!g.depth || !g.normals || !g.albedo) throw_usage("lighting: depth, normals and albedo are required");
  if (!(hfov_deg > 0 && hfov_deg < 180))
    throw_usage("field of view: must be in (0, 180) degrees, got " + num(hfov_deg));
  const Image& z = *g.depth;
  if (z.channels() != 1) throw_bad_input("depth: expected 1 channel");
  const struct {
    const Image* im;
    int ch;
    const char* name;
  } parts[] = {{g.normals, 3, "normals"}, {g.albedo, 3, "albedo"},     {g.specular, 3, "specular"},
               {g.gloss, 1, "gloss"},     {g.emissive, 3, "emissive"}, {ao, 1, "ao"}};
  for (const auto& p : parts) {
    if (!p.im) continue;
    if (!p.im->same_size(z))
      throw_bad_input(std::string(p.name) + ": " + std::to_string(p.im->width()) + "x" +
                      std::to_string(p.im->height()) + " does not match the depth's " + std::to_string(z.width()) +
                      "x" + std::to_string(z.height()));
    if (p.im->channels() != p.ch)
      throw_bad_input(std::string(p.name) + ": expected " + std::to_string(p.ch) + " channels, got " +
                      std::to_string(p.im->channels()));
    check_plane_finite(p.im, p.name);
  }
  if (const long long i = first_bad(z, 0, [](float v) { return !(v > 0); }); i >= 0)
    throw_bad_input("depth: invalid value " + num(z.plane(0)[i]) + " at pixel " + pixel_of(z, i) +
                    " (planar depth must be > 0 metres, +inf for the background)");
  Buffers b;
  b.w = z.width();
  b.h = z.height();
  b.f = 0.5 * b.w / std::tan(0.5 * hfov_deg * kPi / 180);
  b.z = z.plane(0);
  for (int c = 0; c < 3; ++c) {
    b.n[c] = g.normals->plane(c);
    b.alb[c] = g.albedo->plane(c);
    b.spc[c] = plane_or_null(g.specular, c);
    b.em[c] = plane_or_null(g.emissive, c);
  }
  b.gl = plane_or_null(g.gloss, 0);
  b.ao = plane_or_null(ao, 0);
  return b;
}

std::vector<Light> checked_lights(const std::vector<Light>& lights) {
  if (static_cast<long long>(lights.size()) > kMaxLights)
    throw_usage("lights: " + std::to_string(lights.size()) + " lights, more than the limit of " +
                std::to_string(kMaxLights));
  std::vector<Light> out = lights;
  for (std::size_t k = 0; k < out.size(); ++k) validate_light(out[k], "lights[" + std::to_string(k) + "]");
  return out;
}

}  // namespace

void validate_shadow_maps(const ShadowMaps& m, const std::string& where) {
  const Image& o = m.opaque_depth;
  if (o.empty() || o.channels() != 1) throw_bad_input(where + ".opaque_depth: required, 1 channel");
  if (o.width() > kMaxShadowMapSide || o.height() > kMaxShadowMapSide)
    throw_bad_input(where + ".opaque_depth: " + std::to_string(o.width()) + "x" + std::to_string(o.height()) +
                    " is larger than the limit of " + std::to_string(kMaxShadowMapSide) + " texels a side");
  const auto size_of = [](const Image& im) { return std::to_string(im.width()) + "x" + std::to_string(im.height()); };
  if (m.translucent_depth.empty() != m.translucent_color.empty())
    throw_bad_input(where + ": translucent_depth and translucent_color go together (both or neither)");
  if (!m.translucent_depth.empty()) {
    if (!m.translucent_depth.same_size(o) || m.translucent_depth.channels() != 1)
      throw_bad_input(where + ".translucent_depth: " + size_of(m.translucent_depth) + ", " +
                      std::to_string(m.translucent_depth.channels()) + " channel(s); need " + size_of(o) +
                      " (the opaque map's size), 1 channel");
    if (!m.translucent_color.same_size(o) || m.translucent_color.channels() != 3)
      throw_bad_input(where + ".translucent_color: " + size_of(m.translucent_color) + ", " +
                      std::to_string(m.translucent_color.channels()) + " channel(s); need " + size_of(o) +
                      " (the opaque map's size), 3 channels");
  }
  const auto depth_ok = [&](const Image& im, const char* field) {
    if (im.empty()) return;
    const long long i = first_bad(im, 0, [](float v) { return std::isnan(v) || v < 0; });
    if (i >= 0)
      throw_bad_input(where + "." + field + ": invalid depth at texel " + pixel_of(im, i) +
                      " (need >= 0 metres or +inf)");
  };
  depth_ok(o, "opaque_depth");
  depth_ok(m.translucent_depth, "translucent_depth");
  if (!m.translucent_color.empty())
    for (int c = 0; c < 3; ++c) {
      const long long i = first_bad(m.translucent_color, c, [](float v) { return !(v >= 0 && v <= 1); });
      if (i >= 0)
        throw_bad_input(where + ".translucent_color: value outside [0, 1] at texel " +
                        pixel_of(m.translucent_color, i));
    }
  for (double v : m.view)
    if (!std::isfinite(v)) throw_bad_input(where + ".view_matrix: not all finite numbers");
  for (double v : m.projection)
    if (!std::isfinite(v)) throw_bad_input(where + ".projection_matrix: not all finite numbers");
  if (!std::isfinite(m.bias_m) || m.bias_m < 0)
    throw_bad_input(where + ".bias_m: must be a finite number of metres >= 0, got " + num(m.bias_m));
}

std::array<double, 3> shadow_factor(const ShadowMaps& m, const std::array<double, 3>& p) {
  const auto& V = m.view;
  const auto& P = m.projection;
  double q[4];
  for (int r = 0; r < 4; ++r) q[r] = V[4 * r] * p[0] + V[4 * r + 1] * p[1] + V[4 * r + 2] * p[2] + V[4 * r + 3];
  double c[4];
  for (int r = 0; r < 4; ++r) c[r] = P[4 * r] * q[0] + P[4 * r + 1] * q[1] + P[4 * r + 2] * q[2] + P[4 * r + 3] * q[3];
  if (!(c[3] > 0)) return {1, 1, 1};
  const double u = 0.5 * (c[0] / c[3] + 1), v = 0.5 * (1 - c[1] / c[3]);
  if (!(u >= 0 && u < 1 && v >= 0 && v < 1)) return {1, 1, 1};
  const int w = m.opaque_depth.width(), h = m.opaque_depth.height();
  const int x = std::min(static_cast<int>(u * w), w - 1), y = std::min(static_cast<int>(v * h), h - 1);
  const double d = -q[2];
  // The chapter's order: the translucent test colours the light, the opaque test removes it.
  std::array<double, 3> f{1, 1, 1};
  if (!m.translucent_depth.empty() && !(d <= m.translucent_depth.at(x, y) + m.bias_m))
    for (int k = 0; k < 3; ++k) f[k] *= m.translucent_color.at(x, y, k);
  if (!(d <= m.opaque_depth.at(x, y) + m.bias_m)) f = {0, 0, 0};
  return f;
}

void validate_light(Light& l, const std::string& where) {
  const auto finite3 = [&](const std::array<double, 3>& v, const char* field) {
    for (double x : v)
      if (!std::isfinite(x)) throw_bad_input(where + "." + field + ": not a finite number");
  };
  finite3(l.position_m, "position_m");
  finite3(l.direction, "direction");
  finite3(l.color, "color");
  for (double x : l.color)
    if (x < 0) throw_bad_input(where + ".color: components must be >= 0, got " + num(x));
  if (!std::isfinite(l.intensity) || l.intensity < 0)
    throw_bad_input(where + ".intensity: must be a finite number >= 0, got " + num(l.intensity));
  if (l.kind == Light::Kind::point || l.kind == Light::Kind::spot)
    if (!std::isfinite(l.radius_m) || !(l.radius_m > 0))
      throw_bad_input(where + ".radius_m: must be a finite number of metres > 0, got " + num(l.radius_m));
  if (l.kind == Light::Kind::spot) {
    if (!std::isfinite(l.inner_deg) || !std::isfinite(l.outer_deg) || !(l.inner_deg >= 0) || !(l.outer_deg <= 90) ||
        !(l.inner_deg < l.outer_deg))
      throw_bad_input(where + ".inner_deg/outer_deg: need 0 <= inner_deg < outer_deg <= 90, got " + num(l.inner_deg) +
                      " and " + num(l.outer_deg));
  }
  if (l.shadow) {
    if (l.kind == Light::Kind::ambient) throw_bad_input(where + ".shadow: an ambient light casts no shadow");
    validate_shadow_maps(*l.shadow, where + ".shadow");
  }
  if (l.kind == Light::Kind::spot || l.kind == Light::Kind::directional) {
    const double len = std::sqrt(dot3(l.direction, l.direction));
    if (!(len > 1e-12)) throw_bad_input(where + ".direction: must not be the zero vector");
    for (double& v : l.direction) v /= len;
  }
}

LightResult deferred_lighting(const GBufferRef& g, const std::vector<Light>& in_lights, const LightSettings& s) {
  if (s.impl != "tiled" && s.impl != "brute") throw_usage("lighting impl: " + s.impl + " is not tiled or brute");
  if (s.threads < 0) throw_usage("--threads: must be >= 0");
  const std::vector<Light> lights = checked_lights(in_lights);
  if (s.layers && static_cast<int>(lights.size()) > kMaxLightLayers)
    throw_usage("light layers: " + std::to_string(lights.size()) + " lights, more than the " +
                std::to_string(kMaxLightLayers) + " that can be written as layers");
  Buffers b;
  core::with_threads(s.threads, [&] { b = check_and_bind(g, s.hfov_deg, s.ao); });
  const int n = static_cast<int>(lights.size());
  std::vector<Prepared> prep;
  prep.reserve(n);
  for (const Light& l : lights) prep.push_back(prepare(l));
  // The chapter's CPU-side test: is the camera inside the (grown) light sphere?
  std::vector<char> camera_inside(n, 0);
  for (int k = 0; k < n; ++k) camera_inside[k] = prep[k].local && dot3(prep[k].pos, prep[k].pos) <= prep[k].stencil_r2;

  LightResult r;
  r.lit = Image(b.w, b.h, 3, 0.0f);
  if (s.layers)
    for (int k = 0; k < n; ++k) r.layers.emplace_back(b.w, b.h, 3, 0.0f);
  const int tx = (b.w + kTile - 1) / kTile, ty = (b.h + kTile - 1) / kTile;
  r.stats.tiles = static_cast<long long>(tx) * ty;
  r.stats.tiles_touched.assign(n, 0);
  r.stats.pixels_shaded.assign(n, 0);
  std::mutex mu;
  const bool brute = s.impl == "brute";
  core::with_threads(s.threads, [&] {
    core::parallel_for(tx * ty, [&](int tb, int te) {
      std::vector<long long> touched(n, 0), shaded(n, 0);
      std::vector<const Prepared*> tile_list, pixel_list;
      std::vector<int> tile_index, pixel_index;
      for (int t = tb; t < te; ++t) {
        const int x0 = (t % tx) * kTile, y0 = (t / tx) * kTile;
        const int x1 = std::min(x0 + kTile, b.w), y1 = std::min(y0 + kTile, b.h);
        double zmin = INFINITY, zmax = 0;
        for (int y = y0; y < y1; ++y)
          for (int x = x0; x < x1; ++x) {
            const double z = b.z[static_cast<std::size_t>(y) * b.w + x];
            if (std::isinf(z)) continue;
            zmin = std::min(zmin, z);
            zmax = std::max(zmax, z);
          }
        tile_list.clear();
        tile_index.clear();
        if (brute) {
          for (int k = 0; k < n; ++k) {
            tile_list.push_back(&prep[k]);
            tile_index.push_back(k);
          }
        } else if (zmax > 0) {
          const TileFrustum fr = tile_frustum(b, x0, y0, x1, y1, zmin, zmax);
          for (int k = 0; k < n; ++k)
            if (reaches_tile(prep[k], fr)) {
              tile_list.push_back(&prep[k]);
              tile_index.push_back(k);
            }
        }
        for (int k : tile_index) ++touched[k];
        // A tile no light reaches keeps its emissive only (the brute path adds exact zeros).
        const bool any = brute || !tile_list.empty();
        for (int y = y0; y < y1; ++y)
          for (int x = x0; x < x1; ++x) {
            Pixel px;
            if (brute) {
              const bool lit = load_point(b, x, y, px) && load_material(b, x, y, px);
              shade_pixel(b, lit, px, x, y, tile_list.data(), static_cast<int>(tile_list.size()), tile_index.data(),
                          s.emissive, r.lit, s.layers ? &r.layers : nullptr, shaded.data());
              continue;
            }
            pixel_list.clear();
            pixel_index.clear();
            if (any && load_point(b, x, y, px)) {
              const double z = b.z[static_cast<std::size_t>(y) * b.w + x];
              const V3 d = ray_dir(b, x + 0.5, y + 0.5);
              for (std::size_t j = 0; j < tile_list.size(); ++j) {
                const Prepared& l = *tile_list[j];
                if (l.local && !inside_volume(l, camera_inside[tile_index[j]], d, z, px.p)) continue;
                pixel_list.push_back(&l);
                pixel_index.push_back(tile_index[j]);
              }
            }
            // A pixel no light reaches keeps its emissive, like a tile no light reaches.
            const bool lit = !pixel_list.empty() && load_material(b, x, y, px);
            shade_pixel(b, lit, px, x, y, pixel_list.data(), static_cast<int>(pixel_list.size()), pixel_index.data(),
                        s.emissive, r.lit, s.layers ? &r.layers : nullptr, shaded.data());
          }
      }
      std::lock_guard<std::mutex> lock(mu);
      for (int k = 0; k < n; ++k) {
        r.stats.tiles_touched[k] += touched[k];
        r.stats.pixels_shaded[k] += shaded[k];
      }
    });
  });
  return r;
}

std::array<double, 3> shade_light(const Light& l, const std::array<double, 3>& p, const std::array<double, 3>& n,
                                  const std::array<double, 3>& v, const std::array<double, 3>& albedo,
                                  const std::array<double, 3>& specular, double gloss) {
  using LD = long double;
  const LD pi = std::numbers::pi_v<long double>;
  std::array<double, 3> out{0, 0, 0};
  if (l.kind == Light::Kind::ambient) {
    for (int c = 0; c < 3; ++c) out[c] = static_cast<double>(LD(albedo[c]) * l.color[c] * l.intensity);
    return out;
  }
  LD L[3], falloff = 1;
  if (l.kind == Light::Kind::directional) {
    for (int c = 0; c < 3; ++c) L[c] = -LD(l.direction[c]);
  } else {
    LD d2 = 0;
    for (int c = 0; c < 3; ++c) {
      L[c] = LD(l.position_m[c]) - p[c];
      d2 += L[c] * L[c];
    }
    const LD r = l.radius_m, d = std::sqrt(d2);
    if (d >= r || d2 < 1e-30L) return out;
    const LD window = std::clamp(1 - std::pow(d / r, 4.0L), 0.0L, 1.0L);
    falloff = window * window / std::max(d2, LD(kMinLightDistance2));
    for (LD& c : L) c /= d;
    if (l.kind == Light::Kind::spot) {
      const LD cos_a = -(L[0] * l.direction[0] + L[1] * l.direction[1] + L[2] * l.direction[2]);
      const LD co = std::cos(LD(l.outer_deg) * pi / 180), ci = std::cos(LD(l.inner_deg) * pi / 180);
      const LD t = std::clamp((cos_a - co) / (ci - co), 0.0L, 1.0L);
      falloff *= t * t;
    }
  }
  const LD nl = n[0] * L[0] + n[1] * L[1] + n[2] * L[2];
  if (!(nl > 0)) return out;
  LD h[3] = {L[0] + v[0], L[1] + v[1], L[2] + v[2]};
  const LD hl = std::sqrt(h[0] * h[0] + h[1] * h[1] + h[2] * h[2]);
  LD blinn = 0;
  const LD e = std::exp2(1 + 12 * LD(std::clamp(gloss, 0.0, 1.0)));
  if (hl > 1e-15L) {
    const LD nh = (n[0] * h[0] + n[1] * h[1] + n[2] * h[2]) / hl;
    if (nh > 0) blinn = (e + 8) / (8 * pi) * std::pow(nh, e);
  }
  for (int c = 0; c < 3; ++c)
    out[c] = static_cast<double>((albedo[c] / pi + specular[c] * blinn) * l.color[c] * l.intensity * nl * falloff);
  return out;
}

Image forward_lighting(const GBufferRef& g, const std::vector<Light>& in_lights, double hfov_deg, const Image* ao,
                       bool emissive) {
  const std::vector<Light> lights = checked_lights(in_lights);
  check_and_bind(g, hfov_deg, ao);
  using LD = long double;
  const int w = g.depth->width(), h = g.depth->height();
  const LD f = LD(0.5) * w / std::tan(LD(hfov_deg) * std::numbers::pi_v<long double> / 360);
  Image out(w, h, 3, 0.0f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      LD acc[3] = {0, 0, 0};
      if (emissive && g.emissive)
        for (int c = 0; c < 3; ++c) acc[c] = g.emissive->at(x, y, c);
      const double z = g.depth->at(x, y);
      LD nn[3], nlen = 0;
      for (int c = 0; c < 3; ++c) {
        nn[c] = g.normals->at(x, y, c);
        nlen += nn[c] * nn[c];
      }
      if (!std::isinf(z) && nlen > 0) {
        nlen = std::sqrt(nlen);
        const LD p[3] = {(x + LD(0.5) - LD(0.5) * w) / f * z, -(y + LD(0.5) - LD(0.5) * h) / f * z, -LD(z)};
        const LD plen = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
        const std::array<double, 3> P{double(p[0]), double(p[1]), double(p[2])};
        const std::array<double, 3> N{double(nn[0] / nlen), double(nn[1] / nlen), double(nn[2] / nlen)};
        const std::array<double, 3> V{double(-p[0] / plen), double(-p[1] / plen), double(-p[2] / plen)};
        std::array<double, 3> alb, spec{0, 0, 0};
        for (int c = 0; c < 3; ++c) {
          alb[c] = g.albedo->at(x, y, c);
          if (g.specular) spec[c] = g.specular->at(x, y, c);
        }
        const double gl = g.gloss ? g.gloss->at(x, y) : 0.0;
        const double a = ao ? std::clamp(static_cast<double>(ao->at(x, y)), 0.0, 1.0) : 1.0;
        for (const Light& l : lights) {
          const std::array<double, 3> c3 = shade_light(l, P, N, V, alb, spec, gl);
          const std::array<double, 3> t = l.shadow ? shadow_factor(*l.shadow, P) : std::array<double, 3>{1, 1, 1};
          for (int c = 0; c < 3; ++c) acc[c] += LD(c3[c]) * (l.ao ? a : 1.0) * t[c];
        }
      }
      for (int c = 0; c < 3; ++c) out.at(x, y, c) = static_cast<float>(acc[c]);
    }
  return out;
}

}  // namespace dofkit
