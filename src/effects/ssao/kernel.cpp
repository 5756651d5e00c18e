// sc2's constants (§5.5 "Sampling Randomization"): the constant set of offset vectors (the
// chapter's pixel-shader constants: not normalised, lengths spread over [0.5, 1] so that no
// sample clusters at the source point), the tiled texture of random unit vectors they are
// reflected through, and the occlusion functions tabulated (the chapter's "small 1D
// texture"), one per sample set.
// Inputs: Sc2Params, the radius, the image width. Output: Sc2Kernel. Oracle: not applicable
// (constants; tested for unit noise vectors, lengths and table values in tests/ssao).
#include <cmath>
#include <numbers>

#include "effects/ssao/ssao.hpp"

namespace dofkit::detail::ao {

namespace {

double unit(std::uint32_t h) { return (h >> 8) * (1.0 / 16777216.0); }

// n directions spread evenly over the sphere (spherical Fibonacci lattice), each scaled to a
// length in [0.5, 1]: the lengths are n strata of that range in a scrambled order, so short
// and long vectors are spread over all directions.
void offset_set(int n, std::uint32_t salt, std::vector<float>& ox, std::vector<float>& oy, std::vector<float>& oz) {
  const double golden = std::numbers::pi * (3.0 - std::sqrt(5.0));
  std::vector<int> order(n);
  for (int i = 0; i < n; ++i) order[i] = i;
  for (int i = n - 1; i > 0; --i) std::swap(order[i], order[hash32(salt + 31u * i) % (i + 1)]);
  for (int i = 0; i < n; ++i) {
    const double z = 1 - 2 * (i + 0.5) / n, r = std::sqrt(1 - z * z), phi = golden * i;
    const double len = 0.5 + 0.5 * (order[i] + 0.5) / n;
    ox.push_back(static_cast<float>(len * r * std::cos(phi)));
    oy.push_back(static_cast<float>(len * r * std::sin(phi)));
    oz.push_back(static_cast<float>(len * z));
  }
}

// The occlusion function of a set at delta a (units of the set's radius): 1 up to the full
// occlusion threshold, then ((none − a) / (none − full))^power down to 0 at the no-occlusion
// threshold, sampled at the centres of kTableSize cells over (0, none).
std::vector<float> occlusion_table(const SampleSet& s, float& scale) {
  std::vector<float> t(kTableSize);
  scale = static_cast<float>(kTableSize / s.no_occlusion);
  for (int i = 0; i < kTableSize; ++i) {
    const double a = (i + 0.5) * s.no_occlusion / kTableSize;
    t[i] = a <= s.full_occlusion ? 1.0f
                                 : static_cast<float>(std::pow(
                                       (s.no_occlusion - a) / (s.no_occlusion - s.full_occlusion), s.occlusion_power));
  }
  return t;
}

}  // namespace

Sc2Kernel make_sc2_kernel(const Sc2Params& p, double radius_m, int width) {
  Sc2Kernel k;
  k.n_small = p.samples / 4;
  k.n_wide = p.samples - k.n_small;
  offset_set(k.n_small, 0x5a11u, k.ox, k.oy, k.oz);
  offset_set(k.n_wide, 0x3b1deu, k.ox, k.oy, k.oz);
  k.noise = p.noise_size_px;
  for (int i = 0; i < k.noise * k.noise; ++i) {
    // Uniform on the sphere: z uniform in [−1, 1], the azimuth uniform.
    const double z = 2 * unit(hash32(0x9e37u + 2u * i)) - 1,
                 phi = 2 * std::numbers::pi * unit(hash32(0x7f4au + 2u * i + 1));
    const double r = std::sqrt(std::max(0.0, 1 - z * z));
    k.nx.push_back(static_cast<float>(r * std::cos(phi)));
    k.ny.push_back(static_cast<float>(r * std::sin(phi)));
    k.nz.push_back(static_cast<float>(z));
  }
  // Longest vector any Highway target uses for floats: 16 lanes (AVX-512); 64 covers wider.
  k.period = k.noise + 64;
  const int n_offsets = static_cast<int>(k.ox.size());
  for (int ty = 0; ty < k.noise; ++ty)
    for (int i = 0; i < n_offsets; ++i)
      for (int c = 0; c < k.period; ++c) {
        const int t = ty * k.noise + c % k.noise;
        const float rx = k.nx[t], ry = k.ny[t], rz = k.nz[t];
        // v = o − 2 (o·r) r, exactly as sc2_sample.cpp computes it.
        const float d = (k.ox[i] * rx + k.oy[i] * ry) + k.oz[i] * rz;
        const float d2 = d + d;
        k.refl_x.push_back(k.ox[i] - d2 * rx);
        k.refl_y.push_back(k.oy[i] - d2 * ry);
        k.refl_z.push_back(k.oz[i] - d2 * rz);
      }
  k.table_small = occlusion_table(p.small, k.scale_small);
  k.table_wide = occlusion_table(p.wide, k.scale_wide);
  k.radius_small = static_cast<float>(radius_m * p.small.radius);
  k.radius_wide = static_cast<float>(radius_m * p.wide.radius);
  k.limit_px = static_cast<float>(p.max_screen_radius * width);
  return k;
}

}  // namespace dofkit::detail::ao
