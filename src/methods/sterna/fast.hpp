// The optimised form of the sterna passes (impl=fast, the default). The plain passes
// (coc.cpp … composite.cpp) stay as the test oracle; every fast pass performs the same
// floating-point operations in the same order per output value — except the gather's tap
// sums on CPUs with FMA (fast_gather.cpp: a separable form with fused multiply-adds that
// balances the multiply and add pipes, or for small kernels the kernel as texel weights), so
// the two agree bit for bit on a CPU without FMA and to ~3e-6 relative on one with it
// (tests/sterna/sterna_fast_test.cpp). per_pixel_scale's far field is gathered per texel
// (far_per_texel, plain's arithmetic). Otherwise what changes is only the organisation:
//   * no full-resolution near/far planes: the blend factors are recomputed from the CoC (or z)
//     row wherever they are needed (a few flops instead of 16 MB of traffic at 1080p);
//   * the downsample writes straight into the edge-padded planes the gather reads;
//   * the gather is register-blocked (8 texels × all channels accumulate over the 49 taps in
//     registers), runs per 8×8 tile only for the field(s) that tile needs, and walks column
//     strips top to bottom so the ±reach rows it reads stay in L2 — or, on AVX-512 CPUs and
//     for kernels symmetric about the horizontal axis (the usual rings), sums the mirrored
//     source rows first and walks the rows (fold form, fast_gather.cpp);
//   * fill and composite are branch-free row loops (selects instead of per-pixel ifs); the fill
//     runs row by row inside the composite, which consumes its rows at once;
//   * buffers come from ctx.workspace (no allocation per frame in steady state);
//   * hot row functions are compiled for AVX-512 / AVX2 / baseline with runtime dispatch
//     (GCC target_clones). Floating-point contraction is disabled in them so an FMA never
//     merges a multiply and an add that the plain code rounds separately (the gather's FMA
//     kernels write their fused operations explicitly).
// Debug views run the plain passes (every other setting has its fast form).
#pragma once
#include <cstdint>
#include <vector>

#include "core/clones.hpp"
#include "dofkit/image.hpp"
#include "methods/method.hpp"
#include "methods/sterna/passes.hpp"

// The hot row functions: DOFKIT_CLONES (AVX-512 / AVX2 / baseline, no FMA contraction, so
// every copy rounds like the plain form; under clang, the fuzz build, one body for the
// build's own target).
#define STERNA_SIMD DOFKIT_CLONES

namespace dofkit::detail::sterna::fast {

/// Workspace-backed buffers of one frame (w × h = half-res size).
struct Buffers {
  int W = 0, H = 0;            ///< full-res size
  int w = 0, h = 0;            ///< half-res size
  int pad = 0;                 ///< border of the padded source planes (texels)
  Image* near_src = nullptr;   ///< colour_h, 4 planes, (w + 2·pad) × (h + 2·pad), edge replicated
  Image* far_src = nullptr;    ///< colourFar_h ×4 then far_h, 5 planes, padded like near_src
  Image* near_h = nullptr;     ///< near(TL), 1 plane w × h
  Image* tmp = nullptr;        ///< scratch of the dilation, 1 plane w × h
  Image* near_blur = nullptr;  ///< dilated near CoC, 1 plane w × h
  Image* dof_near = nullptr;   ///< gathered near field, 4 planes w × h
  Image* dof_far = nullptr;    ///< gathered far field, 4 planes w × h
  int tiles_x = 0, tiles_y = 0;
  std::vector<std::uint8_t>* tiles = nullptr;  ///< bit 1 near, bit 2 far (as gather.cpp)
  /// Per half-res row, from the downsample: the least and largest colour_h alpha, and whether
  /// some colourFar_h alpha differs from far_h in its bits (the gather's opaque-frame tests).
  struct AlphaRow {
    float lo, hi;
    bool far_differs;
  };
  std::vector<AlphaRow>* alpha_rows = nullptr;

  const float* src_row(const Image& img, int c, int y) const { return img.row(c, y + pad) + pad; }
  float* src_row(Image& img, int c, int y) const { return img.row(c, y + pad) + pad; }
  /// far_h (unpadded coordinates) — plane 4 of far_src.
  const float* far_h_row(int y) const { return src_row(*far_src, 4, y); }
};

/// Near/far blend factors of one full-res row, exactly as compute_full_coc (coc.cpp).
struct BlendRow {
  const MethodContext* ctx = nullptr;
  bool nfb = false;
  double nb = 0, ne = 0, fb = 0, fe = 0;  // near/far blend planes, metres (double: see coc.cpp)
  float ramp = 1;
  void init(const MethodContext& c, const Settings& s);
  /// Writes W values to near (may be null) and far.
  void operator()(int y, float* near, float* far) const;
};

/// P1+P2, padding. With ctx.colour_dirty set it also tests every colour sample against
/// render()'s sanitation rules and returns false (buffers unfinished) if one fails.
bool prepare(const MethodContext& ctx, const Settings& s, Buffers& b);
void dilate(const Settings& s, Buffers& b);  // P3–P6
void gather(const Settings& s, Buffers& b);  // tiles + P7
/// P8 for half-res row y: the 3×3 max fill of the near and far fields, 4 rows of w each.
void fill_rows(const Settings& s, const Buffers& b, int y, float* const* near_out, float* const* far_out);
void composite(const MethodContext& ctx, const Settings& s, const BlendRow& blend, const Buffers& b,
               Image& out);  // P9

/// The whole fast pipeline (buffers from ctx.workspace).
void render(const MethodContext& ctx, const Settings& s, Image& out);

}  // namespace dofkit::detail::sterna::fast
