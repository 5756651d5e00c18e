// Sample patterns for the thin-lens ground truth: hashing, Owen-scrambled Sobol points in the
// unit square, and area-preserving maps from the square to the lens aperture (disc or regular
// n-gon).
//
// Why Owen-scrambled Sobol: the ground truth integrates the scene's radiance over the lens for
// every pixel. The integrand is piecewise smooth (textures) with discontinuities (silhouettes,
// texture lines). Independent random samples converge as N^-1/2; a (0,2)-sequence in base 2
// with nested uniform (Owen) scrambling is stratified in every dyadic box and converges as
// about N^-3/4 across discontinuities and faster on smooth parts, while staying unbiased. The
// per-pixel scramble seed decorrelates neighbouring pixels (noise, not structured aliasing), so
// two seeds give two independent unbiased estimates whose difference measures the noise.
#pragma once
#include <cmath>
#include <cstdint>
#include <numbers>

#include "core/sampling.hpp"

namespace dofkit::scene::detail {

/// 32-bit integer finaliser (a bijection with good avalanche; from the "lowbias32" family).
inline std::uint32_t hash32(std::uint32_t x) {
  x ^= x >> 16;
  x *= 0x7feb352dU;
  x ^= x >> 15;
  x *= 0x846ca68bU;
  x ^= x >> 16;
  return x;
}

/// Combines a hash with another value (order matters).
inline std::uint32_t hash_combine(std::uint32_t seed, std::uint32_t v) {
  return hash32(seed ^ (v + 0x9e3779b9U + (seed << 6) + (seed >> 2)));
}

inline std::uint32_t reverse_bits(std::uint32_t x) {
  x = ((x >> 1) & 0x55555555U) | ((x & 0x55555555U) << 1);
  x = ((x >> 2) & 0x33333333U) | ((x & 0x33333333U) << 2);
  x = ((x >> 4) & 0x0f0f0f0fU) | ((x & 0x0f0f0f0fU) << 4);
  x = ((x >> 8) & 0x00ff00ffU) | ((x & 0x00ff00ffU) << 8);
  return (x >> 16) | (x << 16);
}

/// First two Sobol dimensions as 32-bit fixed-point fractions. Dimension 0 is the base-2
/// radical inverse; dimension 1 uses the direction numbers of the polynomial x + 1, which in
/// bit-reversed form are v_0 = 2^31, v_k = v_{k−1} XOR (v_{k−1} >> 1) (Pascal's triangle mod 2).
inline std::uint32_t sobol_dim0(std::uint32_t i) { return reverse_bits(i); }
inline std::uint32_t sobol_dim1(std::uint32_t i) {
  std::uint32_t r = 0, v = 0x80000000U;
  for (; i != 0; i >>= 1, v ^= v >> 1)
    if (i & 1U) r ^= v;
  return r;
}

/// Nested uniform (Owen) scramble of a 32-bit fraction. A hash whose every output bit only
/// depends on the same and lower input bits (Laine–Karras style, constants by N. Vegdahl)
/// applied to the bit-reversed value permutes each dyadic interval's halves independently,
/// which is exactly Owen's scrambling.
inline std::uint32_t owen_scramble(std::uint32_t x, std::uint32_t seed) {
  x = reverse_bits(x);
  x += seed;
  x ^= x * 0x6c50b47cU;
  x ^= x * 0xb82f1e52U;
  x ^= x * 0xc7afe638U;
  x ^= x * 0x8d22f6e6U;
  return reverse_bits(x);
}

/// A scrambled, shuffled 2-D Sobol point set for one pixel (seed = the pixel's hash): the index
/// is Owen-scrambled too, so any prefix of the set is a random, still well-stratified subset.
struct SobolSet {
  std::uint32_t index_seed, x_seed, y_seed;
  explicit SobolSet(std::uint32_t seed)
      : index_seed(hash_combine(seed, 0xa511e9b3U)), x_seed(hash_combine(seed, 1)), y_seed(hash_combine(seed, 2)) {}
  /// Sample i in [0,1)².
  void sample(std::uint32_t i, double& u, double& v) const {
    const std::uint32_t idx = owen_scramble(i, index_seed);
    const std::uint32_t a = owen_scramble(sobol_dim0(idx), x_seed);
    const std::uint32_t b = owen_scramble(sobol_dim1(idx), y_seed);
    constexpr double k = 1.0 / 4294967296.0;
    u = (a + 0.5) * k;
    v = (b + 0.5) * k;
  }
};

using core::concentric_disc;  // src/core/sampling.hpp

/// Regular n-gon inscribed in the unit circle, vertices at angles (2k+1)π/n + rot (the
/// Sousa/MJP convention of docs/methods/sterna.md). [0,1)² → polygon, area preserving:
/// u picks the triangle fan sector k = ⌊n u⌋ and the position t = n u − k along its outer
/// edge V_k → V_{k+1}; v the radial position s = √v. The point s·lerp(V_k, V_{k+1}, t) has
/// Jacobian |V_k × V_{k+1}|·s/(2 n), constant in t and proportional to s ds = dv/2, so the
/// density is uniform; the map is continuous across sectors (u is an angle-like coordinate).
inline void polygon_sample(double u, double v, int n, double rot_rad, double& x, double& y) {
  const double fu = u * n;
  int k = static_cast<int>(fu);
  if (k >= n) k = n - 1;
  const double t = fu - k;
  const double a0 = (2 * k + 1) * std::numbers::pi / n + rot_rad;
  const double a1 = a0 + 2 * std::numbers::pi / n;
  const double s = std::sqrt(v);
  x = s * ((1 - t) * std::cos(a0) + t * std::cos(a1));
  y = s * ((1 - t) * std::sin(a0) + t * std::sin(a1));
}

}  // namespace dofkit::scene::detail
