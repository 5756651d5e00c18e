// Pass 3 (gtao) — ground-truth-based ambient occlusion after Jimenez, Wu, Pesce & Jarabo,
// "Practical Real-Time Strategies for Accurate Indirect Occlusion" (2016), plain oracle.
// Inputs: the full-res depth, internal normals, GtaoKernel. Output: the visibility (AO).
// The Highway kernels (gtao_simd.cpp) compute the same values bit for bit: every step below
// is a single IEEE float operation (+, −, ×, ÷, √, min, max, floor) in the same order — the
// arc cosine is a polynomial (acos_poly), the sines and cosines the paper's formula needs are
// rewritten with exact identities — and both files are compiled without FMA contraction.
//
// The visibility of a point with unit normal n, seen along the unit view vector V (towards the
// camera), is A = (1/π) ∫ over the half-turn of slice angles φ of the cosine-weighted
// visibility inside the slice plane spanned by V and the screen direction (cos φ, sin φ).
// In the slice, with θ the angle from V and γ the angle of the normal projected into the
// plane (length |n_p|), the visibility is ∫ cos(θ − γ) |sin θ| dθ over the directions that
// are not occluded, within the normal's hemisphere θ ∈ [γ − π/2, γ + π/2]; A ≈ the mean over
// the slices of |n_p| × that integral. Per pixel:
//  1. P = (kx·z, ky·z, z), V = −P / |P|; the screen radius r_px = radius·F / z, at most the
//     limiter's limit_px (and at least 1);
//  2. per slice s (φ = (s + ξ1)·π / slices, ξ1 from the tiled noise): the slice frame (the
//     screen direction made orthogonal to V, the plane's normal), n_p and γ;
//  3. per side (±) and step j: the pixel at distance 1 + t_j·(r_px − 1) along ±(cos φ, sin φ),
//     t_j = ((j + ξ2) / steps)^step_power (off screen: the nearest edge pixel, or skipped), and
//     its view position S on the depth (the sky is skipped);
//  4a. horizon mode (occluder_thickness_m = 0, the paper): every sample is an infinitely thick
//     occluder; each side keeps its highest horizon cosine c = (S − P)·V / |S − P|, blended
//     towards the tangent plane's by a weight that is 1 within (1 − falloff)·radius and 0 at
//     the radius; the horizons h0 <= 0 <= h1 are clamped to the hemisphere and the integral is
//     the paper's closed form (eq. 10)
//         ¼(−cos(2h0 − γ) + cos γ + 2 h0 sin γ) + ¼(−cos(2h1 − γ) + cos γ + 2 h1 sin γ);
//  4b. sector mode (occluder_thickness_m > 0, our extension, after the visibility bitmasks of
//     Therrien et al. 2023): a sample stands for a segment of that thickness behind S along
//     its eye ray; the part of the segment within the radius of P occludes the sectors
//     between its ends' angles (32 sectors over the hemisphere); the integral is the closed
//     form over the whole hemisphere, cos γ + γ sin γ, times the open sectors' share of the
//     integrand (midpoint weights cos φ_i |sin(γ + φ_i)|). A thin object then occludes only
//     what lies near it, and an occluder closer to the camera than the radius still hides
//     what its thickness covers behind it;
//  5. A = the sum over slices / slices, clamped to [0, 1].
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "effects/ssao/gtao_math.hpp"
#include "effects/ssao/ssao.hpp"

namespace dofkit::detail::ao {

namespace {

// A permutation of 0 … n − 1 (Fisher–Yates driven by a fixed hash).
std::vector<int> shuffled(int n, std::uint32_t salt) {
  std::vector<int> v(n);
  for (int i = 0; i < n; ++i) v[i] = i;
  for (int i = n - 1; i > 0; --i) std::swap(v[i], v[hash32(salt + 977u * i) % (i + 1)]);
  return v;
}

}  // namespace

GtaoKernel make_gtao_kernel(const GtaoParams& p, double radius_m, int width) {
  GtaoKernel k;
  k.slices = p.slices;
  k.steps = p.steps;
  k.noise = p.noise_size_px;
  const int texels = k.noise * k.noise;
  // Slice rotation and step jitter: each a stratified value per texel of the tile, in two
  // independent orders, so that a tile holds every rotation and every jitter once.
  const std::vector<int> rot = shuffled(texels, 0x61c8u), jit = shuffled(texels, 0x2f3bu);
  for (int t = 0; t < texels; ++t) {
    const double xi1 = (rot[t] + 0.5) / texels, xi2 = (jit[t] + 0.5) / texels;
    for (int s = 0; s < k.slices; ++s) {
      const double phi = (s + xi1) * std::numbers::pi / k.slices;
      k.dir_x.push_back(static_cast<float>(std::cos(phi)));
      k.dir_y.push_back(static_cast<float>(std::sin(phi)));
    }
    for (int j = 0; j < k.steps; ++j)
      k.step_t.push_back(static_cast<float>(std::pow((j + xi2) / k.steps, p.step_power)));
  }
  k.col_t.resize(width);
  for (int x = 0; x < width; ++x) k.col_t[x] = x % k.noise;
  k.radius = static_cast<float>(radius_m);
  k.inv_falloff = p.falloff > 0 ? static_cast<float>(1.0 / (p.falloff * radius_m)) : 1e30f;
  k.limit_px = static_cast<float>(p.max_screen_radius * width);
  k.thickness_m = static_cast<float>(p.occluder_thickness_m);
  k.clamp_edges = p.clamp_edges;
  for (int i = 0; i < kSectors; ++i) {
    const double phi = (i + 0.5) * std::numbers::pi / kSectors - std::numbers::pi / 2;
    k.cos_phi.push_back(static_cast<float>(std::cos(phi)));
    k.sin_phi.push_back(static_cast<float>(std::sin(phi)));
  }
  for (int i = 0; i <= kSectors; ++i) k.low_mask.push_back(i >= 32 ? 0xffffffffu : (1u << i) - 1u);
  return k;
}

void gtao_span_plain(const Camera& cam, const Image& depth, const Image& n, const GtaoKernel& k, float* ao, int y,
                     int x0, int x1) {
  const int w = cam.w;
  const float fw = static_cast<float>(w), fh = static_cast<float>(cam.h);
  const float inf = std::numeric_limits<float>::infinity();
  const float* zr = depth.row(0, y);
  const float *n0 = n.row(0, y), *n1 = n.row(1, y), *n2 = n.row(2, y);
  const int trow = (y % k.noise) * k.noise;
  const float inv_slices = 1.0f / static_cast<float>(k.slices);
  const float r2 = k.radius * k.radius;
  const bool sectors = k.thickness_m > 0;
  const float sector_scale = static_cast<float>(kSectors) * kInvPi;
  for (int x = x0; x < x1; ++x) {
    const float z = zr[x];
    float* o = ao + static_cast<std::size_t>(y) * w + x;
    if (!(z < inf)) {
      *o = 1.0f;
      continue;
    }
    const float px = cam.kx[x] * z, py = cam.ky[y] * z, pz = z;
    const float inv_len = 1.0f / std::sqrt((px * px + py * py) + pz * pz);
    const float vx = -px * inv_len, vy = -py * inv_len, vz = -pz * inv_len;
    const float nx = n0[x], ny = n1[x], nz = n2[x];
    const float r_px = std::max(1.0f, std::min((k.radius * cam.f) / z, k.limit_px));
    const int t = trow + k.col_t[x];
    const float cxp = static_cast<float>(x) + 0.5f, cyp = static_cast<float>(y) + 0.5f;
    float vis = 0.0f;
    for (int s = 0; s < k.slices; ++s) {
      const float dx = k.dir_x[t * k.slices + s], dy = k.dir_y[t * k.slices + s];
      // Slice frame: the screen direction made orthogonal to V, and the plane's normal a.
      const float dv = dx * vx + dy * vy;
      const float ox = dx - dv * vx, oy = dy - dv * vy, oz = -(dv * vz);
      float ax = oy * vz - oz * vy, ay = oz * vx - ox * vz, az = ox * vy - oy * vx;
      const float inv_a = 1.0f / std::sqrt((ax * ax + ay * ay) + az * az);
      ax = ax * inv_a;
      ay = ay * inv_a;
      az = az * inv_a;
      const float an = (nx * ax + ny * ay) + nz * az;
      const float pnx = nx - ax * an, pny = ny - ay * an, pnz = nz - az * an;
      const float pl = std::sqrt((pnx * pnx + pny * pny) + pnz * pnz);
      const float cos_g = std::min(std::max(((pnx * vx + pny * vy) + pnz * vz) / pl, -1.0f), 1.0f);
      const float sgn = (pnx * ox + pny * oy) + pnz * oz < 0.0f ? -1.0f : 1.0f;
      const float gamma = sgn * acos_poly(cos_g);
      const float sin_g = sgn * std::sqrt(1.0f - cos_g * cos_g);
      const float base = gamma - kHalfPiF;
      float hc0 = -sin_g, hc1 = sin_g;  // cos(γ ± π/2): the tangent plane on each side
      std::uint32_t bits = 0;           // sector mode: the occluded sectors
      for (int j = 0; j < k.steps; ++j) {
        const float off = 1.0f + k.step_t[t * k.steps + j] * (r_px - 1.0f);
        for (int side = 0; side < 2; ++side) {
          const float sdx = side == 0 ? dx * off : -(dx * off), sdy = side == 0 ? dy * off : -(dy * off);
          float sxp = cxp + sdx, syp = cyp + sdy;
          if (k.clamp_edges) {
            sxp = std::min(std::max(sxp, 0.0f), fw - 0.5f);
            syp = std::min(std::max(syp, 0.0f), fh - 0.5f);
          }
          if (!(sxp >= 0.0f && sxp < fw && syp >= 0.0f && syp < fh)) continue;
          const int ix = static_cast<int>(std::floor(sxp)), iy = static_cast<int>(std::floor(syp));
          const float zs = depth.row(0, iy)[ix];
          if (!(zs < inf)) continue;
          const float sx = cam.kx[ix] * zs, sy = cam.ky[iy] * zs;
          const float ddx = sx - px, ddy = sy - py, ddz = zs - pz;
          const float d2 = (ddx * ddx + ddy * ddy) + ddz * ddz;
          if (!(d2 > 0.0f)) continue;  // an edge-clamped sample on the pixel itself
          const float side_sign = side == 0 ? 1.0f : -1.0f;
          if (sectors) {
            // The segment S + ŝ·u, u in [0, thickness], ŝ the unit eye ray through S; the part
            // with |S + ŝ·u − P| <= radius: u² + 2 b u + (d2 − R²) <= 0.
            const float inv_ls = 1.0f / std::sqrt((sx * sx + sy * sy) + zs * zs);
            const float ex = sx * inv_ls, ey = sy * inv_ls, ez = zs * inv_ls;
            const float b = (ddx * ex + ddy * ey) + ddz * ez;
            const float disc = b * b - (d2 - r2);
            if (!(disc >= 0.0f)) continue;
            const float q = std::sqrt(disc);
            const float u0 = std::max(0.0f, -b - q), u1 = std::min(k.thickness_m, -b + q);
            if (!(u0 <= u1)) continue;
            const float f0x = ddx + ex * u0, f0y = ddy + ey * u0, f0z = ddz + ez * u0;
            const float f1x = ddx + ex * u1, f1y = ddy + ey * u1, f1z = ddz + ez * u1;
            const float l0 = (f0x * f0x + f0y * f0y) + f0z * f0z, l1 = (f1x * f1x + f1y * f1y) + f1z * f1z;
            if (!(l0 > 0.0f && l1 > 0.0f)) continue;
            const float c0 = std::min(std::max(((f0x * vx + f0y * vy) + f0z * vz) / std::sqrt(l0), -1.0f), 1.0f);
            const float c1 = std::min(std::max(((f1x * vx + f1y * vy) + f1z * vz) / std::sqrt(l1), -1.0f), 1.0f);
            const float ta = side_sign * acos_poly(c0), tb = side_sign * acos_poly(c1);
            const float ua = (std::min(ta, tb) - base) * sector_scale, ub = (std::max(ta, tb) - base) * sector_scale;
            const float kmax = static_cast<float>(kSectors);
            // Sectors whose centres lie in [ua, ub].
            const int a = static_cast<int>(std::min(std::max(std::floor(ua + 0.5f), 0.0f), kmax));
            const int e = static_cast<int>(std::min(std::max(std::floor(ub + 0.5f), 0.0f), kmax));
            bits |= k.low_mask[e] & ~k.low_mask[a];
            continue;
          }
          const float dist = std::sqrt(d2);
          const float c = ((ddx * vx + ddy * vy) + ddz * vz) / dist;
          const float wgt = std::min(std::max((k.radius - dist) * k.inv_falloff, 0.0f), 1.0f);
          if (!(wgt > 0.0f)) continue;
          const float low = side == 0 ? -sin_g : sin_g;
          float& hc = side == 0 ? hc0 : hc1;
          hc = std::max(hc, low + (c - low) * wgt);
        }
      }
      if (sectors) {
        float open = 0.0f, all = 0.0f;
        for (int i = 0; i < kSectors; ++i) {
          const float wi = k.cos_phi[i] * std::abs(sin_g * k.cos_phi[i] + cos_g * k.sin_phi[i]);
          all = all + wi;
          if (!((bits >> i) & 1u)) open = open + wi;
        }
        vis = vis + pl * ((cos_g + gamma * sin_g) * (open / all));
        continue;
      }
      // The closed form with the horizons' sines and cosines from their cosines: for
      // h = ±acos(c), cos(2h − γ) = (2c² − 1) cos γ + 2 c sin h sin γ with sin h = ±√(1 − c²);
      // a horizon clamped to γ ± π/2 gives cos(2h − γ) = −cos γ.
      const float two_sin = 2.0f * sin_g;
      float arc0, arc1;
      {
        const float c = std::min(std::max(hc0, -1.0f), 1.0f);
        const float h = acos_poly(c);
        if (h - gamma > kHalfPiF)
          arc1 = (cos_g + (gamma + kHalfPiF) * two_sin) + cos_g;
        else
          arc1 = (cos_g + h * two_sin) - ((2.0f * c * c - 1.0f) * cos_g + (2.0f * c * std::sqrt(1.0f - c * c)) * sin_g);
      }
      {
        const float c = std::min(std::max(hc1, -1.0f), 1.0f);
        const float h = -acos_poly(c);
        if (h - gamma < -kHalfPiF)
          arc0 = (cos_g + (gamma - kHalfPiF) * two_sin) + cos_g;
        else
          arc0 =
              (cos_g + h * two_sin) - ((2.0f * c * c - 1.0f) * cos_g + (2.0f * c * -std::sqrt(1.0f - c * c)) * sin_g);
      }
      vis = vis + pl * ((arc0 + arc1) * 0.25f);
    }
    *o = std::min(std::max(vis * inv_slices, 0.0f), 1.0f);
  }
}

void gtao_rows_plain(const Camera& cam, const Image& depth, const Image& n, const GtaoKernel& k, float* ao, int y0,
                     int y1) {
  for (int y = y0; y < y1; ++y) gtao_span_plain(cam, depth, n, k, ao, y, 0, cam.w);
}

}  // namespace dofkit::detail::ao
