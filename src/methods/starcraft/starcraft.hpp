// StarCraft II depth of field (Filion & McNaughton, SIGGRAPH 2008 course, §5.6;
// docs/methods/starcraft.md): four fixed blur levels — sharp source, "small" 4-tap blur, "medium"
// full-resolution Gaussian, "large" W/4 × H/4 Gaussian — cross-faded by a per-pixel blur
// level c ∈ [0, 1]. Three rules shape the level:
//   1. sharp pixels do not leak into blurry neighbours: the medium and large blurs weight
//      every tap by its level c (normalised convolution: blur(c·rgba) / blur(c));
//   2. blurry pixels make their neighbours blurry: the quarter-res level map is blurred;
//   3. background never blurs over foreground: a pixel whose blurred (quarter-res)
//      neighbourhood lies behind it keeps its own level instead of the blurred one.
//
// One file per pass: coc.cpp (C1 level map + level geometry), medium_blur.cpp (C2),
// large_blur.cpp (C3), depth_blur.cpp (C4), final.cpp (C5); starcraft.cpp wires them up.
//
// Deviations from the chapter (all documented in docs/methods/starcraft.md):
// * Kernel sizes are not published; here they follow the camera (see LevelGeometry).
// * The depth map is reduced and blurred as inverse depth 1/z, so +inf (sky) stays finite
//   and the average follows the CoC, which is linear in 1/z.
// * RGBA premultiplied throughout; alpha is blurred like colour.
// * A tie in the depth test (flat neighbourhood) keeps the pixel's own level.
#pragma once
#include <cstdint>
#include <algorithm>
#include <vector>

#include "dofkit/image.hpp"
#include "methods/method.hpp"

namespace dofkit::detail::starcraft {

/// Down-scale factor of the large level, the blurred CoC and the blurred depth
/// ("a quarter of the size on each side").
inline constexpr int kDown = 4;

/// Offsets (source pixels) and weight of the chapter's small 4-tap blur; the missing 1/17
/// is the centre tap, supplied by the source through the final alpha blend.
inline constexpr float kSmallTaps[4][2] = {{0.5f, -1.5f}, {-1.5f, -0.5f}, {-0.5f, 1.5f}, {1.5f, 0.5f}};
inline constexpr float kSmallWeight = 4.0f / 17.0f;

/// How big the blur levels are, in image pixels, and how a signed CoC radius maps onto a
/// level c. Level c = 0 is the source, 0.5 the small blur, 0.75 the medium blur and 1 the
/// large blur (the chapter's breakpoints d0 = 0.5, d1 = d2 = 0.25).
struct LevelGeometry {
  /// Disc radius (px) whose second moment equals that of the small 4-tap kernel (fixed in
  /// pixels, as in the chapter): per axis the 17-tap footprint has variance
  /// 16/17 · mean(0.5, 2.5, 0.5, 2.5) = 24/17 px² (each bilinear tap at ±0.5 / ±1.5 spreads
  /// over two pixels), and a disc of radius R has R²/4 → R = 2·sqrt(24/17) ≈ 2.38 px.
  float r_small = 0;
  float r_medium = 0;      ///< disc radius (px) the medium level stands for
  float r_large = 0;       ///< disc radius (px) the large level stands for
  float sigma_medium = 0;  ///< Gaussian σ of the medium level, full-res px
  float sigma_large = 0;   ///< total Gaussian σ of the large level, full-res px (incl. resampling)
  float sigma_depth = 0;   ///< total Gaussian σ of the blurred depth, full-res px
  bool native = false;     ///< the camera is the StarCraft model: c comes from its formula
  /// Map a signed CoC radius (px) to a level c. The levels are Gaussians, so they are matched
  /// by variance: a disc of radius r has variance r²/4 per axis, and a cross-fade
  /// (1 − t)·A + t·B of two centred kernels has variance (1 − t)·var A + t·var B. Between
  /// two levels the level c therefore moves linearly in r². The in-focus tolerance is
  /// removed first (r² − 0.25), so |r| <= 0.5 px gives c = 0 exactly.
  float level_of_radius(float r) const;
};

// Inline so compute_levels' per-pixel loop is not a call per pixel.
inline float LevelGeometry::level_of_radius(float r) const {
  // Work in v = r² − 0.25 (variance × 4 above the in-focus disc); levels at v_s, v_m, v_l.
  const float v = std::max(0.0f, r * r - 0.25f);
  const float vs = r_small * r_small - 0.25f, vm = r_medium * r_medium - 0.25f, vl = r_large * r_large - 0.25f;
  if (v <= vs) return 0.5f * v / vs;
  if (v <= vm) return 0.5f + 0.25f * (v - vs) / (vm - vs);
  if (v <= vl) return 0.75f + 0.25f * (v - vm) / (vl - vm);
  return 1.0f;
}

/// Tunable parameters (the --set keys; see starcraft.cpp for the documentation).
struct Settings {
  double large_radius_px = 0;     ///< 0 = auto (camera's characteristic radius)
  double medium_fraction = 0.5;   ///< r_medium / r_large
  double sigma_per_radius = 0.6;  ///< Gaussian σ per disc radius (measured best 0.6-0.7)
  double depth_blur = 1.0;        ///< σ of the depth blur relative to the CoC blur
  int medium_boxes = 2;           ///< extended-box passes per axis of the medium level's Gaussian (1-3)
  bool keep_own_blur = false;     ///< c = max(c_used, c_own): a pixel never gets sharper
  bool coc_reduce_max = false;    ///< quarter-res level = block max (else block mean)
  bool plain = false;             ///< impl=plain: the straightforward passes (test oracle)
};

/// The --set parameters (starcraft.cpp; the GPU backend uses it too).
Settings read_settings(const MethodContext& ctx);

LevelGeometry make_geometry(const MethodContext& ctx, const Settings& s);

/// Quarter-resolution size of a full-resolution extent.
inline int down_size(int n) { return (n + kDown - 1) / kDown; }

/// C1: full-resolution level c per pixel (1 plane). plain: level_of_radius per pixel (the
/// oracle); fast: the same formulas as selects, vectorised (within 1 ulp of plain).
void compute_levels(const MethodContext& ctx, const LevelGeometry& g, Image& level, bool plain = false);

/// The medium level's fast sums (core::weighted_gaussian*, float running sums) are replaced by
/// the exact ones (core::weighted_gaussian_at, double, no running sums) at every pixel that
/// the final mix reads the medium level for (level weight > 0, i.e. 0.5 < c < 1) whose fast
/// blurred weight W is below this. Why (docs/methods/starcraft.md, "the medium level's float
/// drift where its weight is small"):
/// medium = N / W, and the float running sums leave in N and W a residue δN, δW of the values
/// that passed through the window since the last re-synchronisation (every 32 outputs), of
/// order u·S, u = 2^-24, S the colour magnitude in the sums' reach (~100 px along each axis).
/// The quotient's error is (δN − medium·δW) / W, so it grows as 1/W: measured
/// |δN − medium·δW| ≈ 5–6e-7 next to highlights of 40 (≈ 0.25·u·S), hence 0.019 at W = 2.4e-4
/// (a sharp hole in blurry foreground whose pixels take the neighbourhood's level).
/// - W < 1/32: exact sums. Their error is relative to the colour under the kernel (n·2^-53,
///   n <= (2R + 1)², weighted_gaussian.hpp) whatever S and W; the plain pass's is its float
///   roundings (~5·2^-24 relative) plus its double sums' drift, so the two agree within
///   ~1e-6 of the colour under the kernel.
/// - W >= 1/32: the fast quotient's error is <= 0.25·u·S·32 ≈ 4.8e-7·S (the measured residue
///   scaled), within 1e-4 for S up to ~200 where the output is ~1, and for larger S wherever
///   the output is itself that bright (the criterion is relative to max(1, |out|)).
/// That is not a bound for every sanitised input: the worst-case residue of float running sums
/// is ~(r + 35)·u·S per pass (a sequential re-sum of 2r + 1 terms plus 31 updates), ~200·u·S
/// over four passes, and S may reach kMaxColorValue (1e18); next to highlights of 1000 a
/// weight of ~0.1 already gives 1.9e-4 (found by a sweep of highlights and weights). Nor is
/// the oracle bounded: its double sums are never re-synchronised, and a highlight of 1e18 in a
/// row shifts its sums after it by the texture itself (~0.5). A bound for any S needs sums whose error is
/// relative to the window (no cancellation; docs/methods/starcraft.md lists the options).
/// 1/32 is below every mixed pixel's weight on the bench frame (min 0.26 at 1080p, 0.38 at
/// 640×360) and the built-in scenes at 640×360 (min 0.055, sky), so their output is the fast
/// sums' bit for bit.
inline constexpr float kExactMediumBelow = 1.0f / 32.0f;

/// What core::weighted_gaussian_at needs to recompute the medium level's sums at a pixel:
/// the planes blurred (nplanes: 3 when the alpha plane is left out, then its sum is W), the
/// level c and the Gaussian. A final row given one recomputes every pixel it mixes the medium
/// level into whose W < kExactMediumBelow.
struct MediumExact {
  const float* const* src;
  int nplanes;
  const float* c;
  int w, h;
  float sigma;
  int boxes;
};

/// C2: medium level, full resolution, RGBA: CoC-weighted Gaussian of σ = sigma_medium,
/// normalised; where no tap carries weight the source colour is kept. `weight` is scratch
/// (the blurred level on return, fast form).
/// `boxes`: extended-box passes per axis (the Gaussian's shape; its variance is σ² for any count).
/// large (fast form; C3's output, plane 4 the blurred level): the sums are recomputed exactly
/// (kExactMediumBelow) at every pixel with W below the threshold that the final pass may mix
/// the medium level into (own level or the larger of the blurred level's four bilinear cells
/// over 0.49: a superset of medium_and_final's pixels, so both give the same output).
void medium_blur(const Image& color, const Image& level, float sigma, int boxes, Image& medium, Image& weight,
                 bool plain = false, const Image* large = nullptr);

/// C3: large level at W/4 × H/4. `large` gets 5 planes: blur(c·rgba) (4 planes, not yet
/// divided) and blur(c) — the blurred CoC, which is also the normaliser. `reduce_max`: the
/// quarter-res level of a block is its max instead of its mean (colour stays c-weighted).
/// alpha_is_one (optional): set to whether every alpha of `color` is exactly 1.
/// check_colour: also test every colour sample against render()'s sanitation rules; returns
/// false (and leaves `large` unfinished) if one fails, else true.
bool large_blur(const Image& color, const Image& level, float sigma_total, bool reduce_max, Image& large,
                bool plain = false, bool* alpha_is_one = nullptr, bool check_colour = false);

/// C4: inverse depth 1/z reduced to W/4 × H/4 (block mean) and blurred (1 plane). The fast
/// form's values are the plain form's bit for bit: the final pass's depth test is a hard
/// threshold on them (see depth_blur.cpp).
void depth_blur(const Image& depth, float sigma_total, Image& inv_depth, bool plain = false);

/// Converts a total (full-res px) Gaussian σ into the σ to apply on the quarter-res grid,
/// removing the variance the 4×4 box reduction and the bilinear up-sampling add.
float quarter_res_sigma(float sigma_total);

/// Optional outputs of the final pass (debug views); null = not wanted.
struct FinalDebug {
  Image* used_level = nullptr;  ///< level c after the depth test (1 plane)
  Image* small = nullptr;       ///< the small level incl. its centre tap (RGBA)
  Image* weights = nullptr;     ///< 4 planes: source, small, medium, large weights
};

/// C5: per full-res pixel — depth test, level weights, mix, blend over the source.
/// final_pass_plain is the straightforward per-pixel form (the oracle of the tests);
/// final_pass gives the same result organised by rows (it uses the plain form when a debug
/// output is wanted).
void final_pass_plain(const Image& color, const Image& depth, const Image& level, const Image& medium,
                      const Image& large, const Image& inv_depth, bool keep_own_blur, Image& out,
                      const FinalDebug& dbg = {});
void final_pass(const Image& color, const Image& depth, const Image& level, const Image& medium, const Image& large,
                const Image& inv_depth, bool keep_own_blur, Image& out, const FinalDebug& dbg = {});

/// What final_pass_row reads and writes for every row of one final pass (final_pass's
/// arguments without the medium level, which comes row by row).
struct FinalPassViews {
  const Image& color;
  const Image& depth;
  const Image& level;
  const Image& large;
  const Image& inv_depth;
  bool keep_own_blur;
  Image& out;  ///< must already have the frame's size
  /// new_final_pass_id() of the pass the rows belong to (a worker keeps the small blur's block
  /// sums of the source rows it read for the next rows of the same pass).
  std::uint64_t pass;
  /// exact (with med_wt): recompute the sums of the pixels the row mixes the medium level
  /// into whose med_wt < kExactMediumBelow (see there). Null: never.
  const MediumExact* exact = nullptr;
  /// With med_wt and med[3] == med_wt: every alpha of `color` is 1 and large's plane 3 is its
  /// plane 4 (large_blur on an opaque frame); the output's alpha then comes from the level
  /// weights alone (same values).
  bool opaque = false;
};
/// One row y of final_pass with the medium level's row given as 4 plane pointers (w floats
/// each). Same result as final_pass's row y.
/// med_wt set: med holds the medium level before its division (blurred c·rgba) and med_wt
/// the blurred weight c; the division (with the source where med_wt <= 1e-6, as in
/// medium_blur) is made in the mix, only for the pixels that are not in focus.
void final_pass_row(const FinalPassViews& v, const float* const med[4], int y, const float* med_wt = nullptr);
/// A number no earlier final pass of the process used.
std::uint64_t new_final_pass_id();

/// C2 and C5 fused (fast form, no debug output): the medium level is streamed row by row
/// (core::weighted_gaussian_rows) into the final pass, so it never exists as full planes.
/// Same result as medium_blur followed by final_pass, bit for bit.
/// opaque: every alpha of `color` is exactly 1 (large_blur's alpha_is_one); the alpha plane
/// is then left out of the medium blur.
void medium_and_final(const Image& color, const Image& depth, const Image& level, float sigma_medium, int boxes,
                      bool opaque, const Image& large, const Image& inv_depth, bool keep_own_blur, Image& out);

/// The chapter's level weights for a level c: {source, small, medium, large}; they sum to 1.
/// x = sat(1 − c/d0), y = sat((1 − d2)/d1 − c/d1), z = sat(1/d2 − c/d2),
/// w = sat((d2 − 1)/d2 + c/d2); y' = min(y, 1 − x), z' = min(z, 1 − y); the source weight is
/// what the final alpha leaves: 1 − (y' + z' + w) (= x).
struct LevelWeights {
  float source, small, medium, large;
};
inline LevelWeights level_weights(float c) {
  constexpr float d0 = 0.5f, d1 = 0.25f, d2 = 0.25f;
  auto sat = [](float v) { return v < 0.0f ? 0.0f : (v > 1.0f ? 1.0f : v); };
  const float x = sat(1.0f - c / d0);
  const float y = sat((1.0f - d2) / d1 - c / d1);
  const float z = sat(1.0f / d2 - c / d2);
  const float w = sat((d2 - 1.0f) / d2 + c / d2);
  const float ys = y < 1.0f - x ? y : 1.0f - x;
  const float zs = z < 1.0f - y ? z : 1.0f - y;
  return {1.0f - (ys + zs + w), ys, zs, w};
}

}  // namespace dofkit::detail::starcraft
