// Internals of the ambient-occlusion effect (public API: include/dofkit/ao.hpp; the method
// page: docs/methods/ssao.md). One file per pass:
//
//   params.cpp      parameter tables, presets and parsing (what ao_methods() lists)
//   geometry.cpp    pass 1: input checks, camera tables, normals (given, or from the depth)
//   downsample.cpp  pass 2 (sc2): the depth reduced to ceil(W/4) × ceil(H/4)
//   kernel.cpp      sc2's constant offset vectors, the tiled noise, the occlusion tables
//   sc2_sample.cpp  pass 3 (sc2): the raw occlusion term, plain oracle
//   sc2_simd.cpp    pass 3 (sc2): the same, Highway kernels (bit for bit the oracle's values)
//   gtao.cpp        pass 3 (gtao): horizon search + slice integral, plain oracle
//   gtao_simd.cpp   pass 3 (gtao): the same, Highway kernels (within 1e-5 of the oracle)
//   blur.cpp        pass 4: the depth- and normal-aware Gaussian, plain oracle + driver
//   blur_simd.cpp   pass 4: its Highway row kernels (bit for bit the oracle's values)
//   halfres.cpp     resolution=half: the sampled grid (every other pixel) and the
//                   depth-aware upsampling of its AO to the full resolution
//   ao.cpp          the pipeline, debug views, AoRenderer
//
// View space inside the effect is the image's: x right, y DOWN, z forward (metres), so a
// pixel's position is (kx[x]·z, ky[y]·z, z) with kx[x] = (x + 0.5 − W/2)/F, ky likewise.
// Normals given in the file convention (X right, Y up, Z towards the camera) are turned into
// it as (X, −Y, −Z); they then point towards the camera (n.z < 0 for a visible surface).
#pragma once
#include <cstdint>
#include <functional>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "dofkit/ao.hpp"
#include "dofkit/image.hpp"

namespace dofkit::detail::ao {

// ---------------------------------------------------------------------------------------------
// Parameters (params.cpp)

/// The blur (pass 4), shared by both methods.
struct BlurParams {
  int passes = 2;                 ///< blur_passes: each pass = horizontal + vertical sweep
  int radius_px = 4;              ///< blur_radius_px: taps −r … r per sweep; σ = r / 2
  double depth_threshold = 0.03;  ///< blur_depth_threshold: |z_tap − z_centre| / z_centre above it → weight 0
  double normal_threshold = 0.8;  ///< blur_normal_threshold: dot(n_tap, n_centre) below it → weight 0
};

/// One of sc2's two sample sets: its radius and occlusion function (deltas in units of the
/// set's radius).
struct SampleSet {
  double radius = 1;           ///< × radius_m
  double full_occlusion = 0;   ///< deltas in (0, full] occlude fully
  double no_occlusion = 1;     ///< deltas >= it occlude nothing
  double occlusion_power = 1;  ///< the linear fall-off between them raised to this power
};

struct Sc2Params {
  std::string preset = "chapter";
  int samples = 16;  ///< 8..32, a multiple of 4: a quarter in the small set
  SampleSet small, wide;
  double max_screen_radius = 0.3;            ///< limiter: wide radius at most this × image width, px
  int noise_size_px = 8;                     ///< side of the tiled random-vector texture
  std::string depth_downsample = "nearest";  ///< min | max | mean | nearest (4×4 block → 1)
  BlurParams blur;
  bool half = false;   ///< resolution=half: passes 1–4 on every other pixel, then upsampled
  bool plain = false;  ///< impl=plain: the oracle
};

struct GtaoParams {
  int slices = 3;                     ///< screen directions per pixel
  int steps = 24;                     ///< depth samples per slice side
  double step_power = 1.6;            ///< step j at ((j + jitter) / steps)^power of the screen radius
  double occluder_thickness_m = 0.2;  ///< metres; 0: the paper's horizons, > 0: sector visibility
  double falloff = 0;                 ///< horizon mode: weight fades to 0 over the last falloff × radius
  bool clamp_edges = true;            ///< off-screen samples read the nearest edge pixel (else skipped)
  double max_screen_radius = 1;       ///< × image width, px
  int noise_size_px = 4;
  BlurParams blur{2, 2, 0.03, 0.8};
  bool half = false;
  bool plain = false;
};

std::vector<MethodInfo> method_infos();
/// Parses and validates `params` by the method's table (Error(usage) naming the key);
/// keys_read: where to put the keys the parser looked up (the table test).
Sc2Params parse_sc2(const std::map<std::string, std::string>& params, std::set<std::string>* keys_read = nullptr);
GtaoParams parse_gtao(const std::map<std::string, std::string>& params, std::set<std::string>* keys_read = nullptr);
/// The debug view names of a method (for validation).
std::vector<std::string> debug_view_names(const std::string& method);

// ---------------------------------------------------------------------------------------------
// Geometry (geometry.cpp)

struct Camera {
  int w = 0, h = 0;
  float f = 0;                ///< focal length, px
  float inv_f = 0;            ///< 1 / f
  float cx = 0, cy = 0;       ///< W/2, H/2
  std::vector<float> kx, ky;  ///< (x + 0.5 − cx)·inv_f, (y + 0.5 − cy)·inv_f
};
Camera make_camera(int w, int h, double hfov_deg);
/// kx, ky from w, h, cx, cy and inv_f (the kernels that recompute them use the same formula).
void fill_rays(Camera& c);

/// Checks the depth (z > 0 or +inf) and the normals (3 planes of the same size, finite where
/// z is finite): Error(bad_input) naming the first bad pixel.
void check_inputs(const Image& depth, const Image* normals);
/// Internal-convention unit normals (3 planes) from given file-convention normals, or
/// reconstructed from the depth (the smaller of the two one-sided differences per axis,
/// turned towards the camera). 0 where z is +inf.
void normals_from_input(const Image& normals, const Image& depth, Image& out);
void normals_from_depth(const Image& depth, const Camera& cam, Image& out);

// ---------------------------------------------------------------------------------------------
// sc2 (downsample.cpp, kernel.cpp, sc2_sample.cpp, sc2_simd.cpp)

/// ceil(W/4) × ceil(H/4) reduction of the depth (blocks clipped at the border).
void downsample_depth(const Image& depth, const std::string& how, Image& out);

constexpr int kTableSize = 2048;  ///< entries of a tabulated occlusion function

/// A 32-bit integer hash (two multiply-xorshift rounds) for the fixed pseudo-random constants
/// (offset order, noise vectors, GTAO's noise tile): the same values on every machine.
inline std::uint32_t hash32(std::uint32_t x) {
  x ^= x >> 16;
  x *= 0x7feb352dU;
  x ^= x >> 15;
  x *= 0x846ca68bU;
  x ^= x >> 16;
  return x;
}

/// Everything the raw pass reads besides the buffers, shared by the oracle and the kernels.
struct Sc2Kernel {
  int n_small = 4, n_wide = 12;
  /// Offset vectors (unit-radius sets, lengths in [0.5, 1]): small first, then wide;
  /// x, y, z in separate arrays.
  std::vector<float> ox, oy, oz;
  int noise = 4;                  ///< tile side
  std::vector<float> nx, ny, nz;  ///< noise tile, row-major, unit vectors
  /// The offsets reflected through each noise vector (the kernels' table, the same float
  /// operations as the oracle's per-pixel reflection), laid out so that a vector of columns
  /// starting at x loads them contiguously: for noise row ty and offset i, the run
  /// refl?[(ty · n_offsets + i) · period + c], c = 0 … period − 1, holds the reflection through
  /// the noise vector of column phase c % noise; a vector at x starts at c = x % noise.
  int period = 0;
  std::vector<float> refl_x, refl_y, refl_z;
  /// Occlusion functions: value at delta a (units of the set radius), a in (0, no_occlusion):
  /// table[int(a · scale)], scale = kTableSize / no_occlusion; 0 for a <= 0 or beyond.
  std::vector<float> table_small, table_wide;
  float scale_small = 0, scale_wide = 0;
  float radius_small = 0, radius_wide = 0;  ///< metres, before the limiter
  float limit_px = 0;                       ///< largest wide radius on screen, px
  /// The quarter-res texel under grid coordinate u: int(u · q_scale + q_offset); 0.25, 0 at
  /// full resolution; 0.5, −0.125 on the half-res grid (whose u is the full-res u / 2 + 0.25).
  float q_scale = 0.25f, q_offset = 0.0f;
};
Sc2Kernel make_sc2_kernel(const Sc2Params& p, double radius_m, int width);

/// Output planes of the raw pass: AO (1 − the darker set's mean occlusion) and, optionally,
/// each set's AO (null = not wanted).
struct Sc2Out {
  float* ao;
  float* small;
  float* wide;
};
/// Columns [x0, x1) of row y of the raw term (the oracle's arithmetic; the kernels' tails).
void sc2_span_plain(const Camera& cam, const Image& depth, const Image& n, const Image& quarter, const Sc2Kernel& k,
                    const Sc2Out& out, int y, int x0, int x1);
/// Rows [y0, y1) of the raw term. depth: full res; quarter: downsample_depth; n: internal normals.
void sc2_rows_plain(const Camera& cam, const Image& depth, const Image& n, const Image& quarter, const Sc2Kernel& k,
                    const Sc2Out& out, int y0, int y1);
void sc2_rows_fast(const Camera& cam, const Image& depth, const Image& n, const Image& quarter, const Sc2Kernel& k,
                   const Sc2Out& out, int y0, int y1);

// ---------------------------------------------------------------------------------------------
// gtao (gtao.cpp, gtao_simd.cpp)

constexpr int kSectors = 32;  ///< sectors of a slice's hemisphere in gtao's sector mode

struct GtaoKernel {
  int slices = 3, steps = 12, noise = 4;
  /// Per noise-tile texel t and slice s: the slice's screen direction (cos φ, sin φ) at
  /// [t·slices + s].
  std::vector<float> dir_x, dir_y;
  /// Per texel t and step j: the step's fraction of the screen radius at [t·steps + j].
  std::vector<float> step_t;
  std::vector<int> col_t;   ///< x % noise per column
  float radius = 0;         ///< metres
  float inv_falloff = 0;    ///< horizon mode: 1 / (falloff · radius) (1e30: a hard cut)
  float limit_px = 0;       ///< largest screen radius, px
  float thickness_m = 0;    ///< > 0: the sector mode, occluders this thick (metres)
  bool clamp_edges = true;  ///< off-screen samples read the nearest edge pixel
  /// Sector mode: cos and sin of each sector's centre φ_i relative to the normal's angle,
  /// and low_mask[k] = the bits 0 … k − 1 (k = 0 … kSectors).
  std::vector<float> cos_phi, sin_phi;
  std::vector<std::uint32_t> low_mask;
};
GtaoKernel make_gtao_kernel(const GtaoParams& p, double radius_m, int width);
void gtao_span_plain(const Camera& cam, const Image& depth, const Image& n, const GtaoKernel& k, float* ao, int y,
                     int x0, int x1);
void gtao_rows_plain(const Camera& cam, const Image& depth, const Image& n, const GtaoKernel& k, float* ao, int y0,
                     int y1);
void gtao_rows_fast(const Camera& cam, const Image& depth, const Image& n, const GtaoKernel& k, float* ao, int y0,
                    int y1);

// ---------------------------------------------------------------------------------------------
// Blur (blur.cpp, blur_simd.cpp)

/// The Gaussian taps g[0 … r] (g[k] for offsets ±k), not normalised (renormalised per pixel).
std::vector<float> blur_taps(int radius_px);
/// Columns [x0, x1) of row y of one sweep (the oracle's arithmetic; the kernels' borders).
void blur_h_span_plain(const Image& depth, const Image& n, const float* in, float* out, const std::vector<float>& taps,
                       float depth_t, float normal_t, int y, int x0, int x1);
void blur_v_span_plain(const Image& depth, const Image& n, const float* in, float* out, const std::vector<float>& taps,
                       float depth_t, float normal_t, int y, int x0, int x1);
/// One horizontal sweep of rows [y0, y1): out = Σ w·in / Σ w over the taps whose depth and
/// normal pass the thresholds; 1 where z is +inf.
void blur_h_rows_plain(const Image& depth, const Image& n, const float* in, float* out, const std::vector<float>& taps,
                       float depth_t, float normal_t, int y0, int y1);
void blur_v_rows_plain(const Image& depth, const Image& n, const float* in, float* out, const std::vector<float>& taps,
                       float depth_t, float normal_t, int y0, int y1);
/// Highway versions of one row's interior [x0, x1) (horizontal: every tap inside the row);
/// return the first column not processed.
int blur_h_row_simd(const float* z, const float* const n[3], const float* in, float* out, const float* taps, int r,
                    float depth_t, float normal_t, int x0, int x1);
/// Vertical: rows[k] = the rows y − r + k (null outside the image), for z, n and in.
struct VRows {
  const float* const* z;
  const float* const* n0;
  const float* const* n1;
  const float* const* n2;
  const float* const* in;
};
int blur_v_row_simd(const VRows& rows, int r, const float* taps, float depth_t, float normal_t, float* out, int x0,
                    int x1);

/// The whole blur: `passes` × (horizontal, vertical) from `ao` (overwritten with the result),
/// `tmp` scratch of the same size; after pass p (1-based) `on_pass(p, plane)` may copy it.
void blur(const Image& depth, const Image& n, const BlurParams& p, bool plain, float* ao, float* tmp,
          const std::function<void(int, const float*)>& on_pass);

// ---------------------------------------------------------------------------------------------
// resolution=half (halfres.cpp)

/// The sampled grid of resolution=half: pixel (i, j) is the full-res pixel (2i, 2j);
/// ceil(W/2) × ceil(H/2), every channel of `in`.
void subsample2(const Image& in, Image& out);
/// The camera of that grid: F halved and the centre at cx / 2 + 0.25, so that grid pixel i's
/// eye ray is the full-res pixel 2i's (to rounding) and a point at full-res coordinate u
/// projects to u / 2 + 0.25.
Camera half_camera(const Camera& full);
/// The full-res AO from the grid's: a grid pixel keeps its value; any other pixel mixes its 2
/// or 4 nearest grid pixels with equal (bilinear) weights, those whose depth differs from the
/// pixel's by more than depth_t × its depth left out; none left: the grid pixel of nearest
/// depth (1 where the pixel or every candidate is +inf). `depth` full res, `half_depth` = subsample2(depth).
void upsample_ao(const Image& depth, const Image& half_depth, const float* half_ao, float depth_t, float* ao);
/// A grid-sized plane shown at full size (nearest grid pixel), for the debug views.
Image upsample_nearest(const Image& half, int w, int h);

}  // namespace dofkit::detail::ao
