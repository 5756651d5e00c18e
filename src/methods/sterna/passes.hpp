// Sterna gather-based bokeh (GPU Zen, "Practical Gather-based Bokeh Depth of Field") with
// Sousa 2013's polygonal kernel and Karis firefly weighting — the passes of
// docs/methods/sterna.md, one file each. All buffers are float planes; colour is RGBA
// premultiplied and alpha is filtered exactly like R, G and B.
#pragma once
#include <cstdint>
#include <vector>

#include "dofkit/image.hpp"
#include "methods/method.hpp"
#include "methods/sterna/kernel.hpp"

namespace dofkit::detail::sterna {

/// Half-res tiles (8 × 8 half-res px = 16 × 16 full-res px) used for early-outs.
inline constexpr int kTile = 8;

/// Per-frame settings derived from the parameters and the camera.
struct Settings {
  /// Multiplies the half-res offsets; ring 3 lies at 6·kernel_scale half-res px.
  float kernel_scale = 1.0f;
  /// Multiplies the near/far blend factors in the composite (strength < 0.25 fades out).
  float composite_blend = 1.0f;
  /// Full-res radius (px) a blend factor of 1 stands for; converts signed CoC → near/far.
  float blend_radius_px = 12.0f;
  bool bicubic_near = false;
  bool per_pixel_scale = false;
  bool karis = false;
  /// Half-res radius of the near-CoC max and box filters (6 at kernel_scale 1).
  int dilate_radius = 6;
  /// The 49 unscaled offsets (centre first), half-res px.
  std::vector<Offset> offsets;
};

/// Full-resolution near/far blend factors (2 planes: 0 = near, 1 = far), each in [0, 1] and at
/// most one non-zero per pixel.
struct FullCoc {
  Image coc;  // W × H × 2
};

/// Everything at half resolution, w = ceil(W/2), h = ceil(H/2).
struct HalfRes {
  int w = 0, h = 0;
  Image color;      ///< colour_h: mean (or Karis mean) of the 2×2 quad, 4 planes
  Image color_far;  ///< colourFar_h: far-bilateral mean × far(TL), 4 planes
  Image coc;        ///< coc_h: near/far of the top-left full-res pixel, 2 planes
  Image near_blur;  ///< nearBlur_h: max-then-box dilated near CoC, 1 plane
  Image dof_near;   ///< near field after the gather, 4 planes
  Image dof_far;    ///< far field after the gather, 4 planes
  Image near_fill;  ///< near field after the 3×3 max fill, 4 planes
  Image far_fill;   ///< far field after the 3×3 max fill, 4 planes
  int tiles_x = 0, tiles_y = 0;
  /// Per tile: 1 when some nearBlur_h or far_h in it is > 0 (gather and fill run there).
  std::vector<std::uint8_t> tile_active;
};

/// The frame's settings from --set and the camera (sterna.cpp; the GPU backend uses it too).
Settings read_settings(const MethodContext& ctx);

/// P1: near/far blend factors at full resolution. NearFarBlend cameras use their own planes
/// (native); every other model maps the signed CoC r to near = saturate((r − ½)/(R − ½)),
/// far = saturate((−r − ½)/(R − ½)) with R = settings.blend_radius_px.
void compute_full_coc(const MethodContext& ctx, const Settings& s, FullCoc& out);

/// P2: colour_h, colourFar_h (premultiplied by far) and coc_h.
void downsample(const Image& color, const FullCoc& full, const Settings& s, HalfRes& h);

/// P3–P6: nearBlur_h = box(max(near_h)) with radius s.dilate_radius, separable.
void dilate_near_coc(const Settings& s, HalfRes& h);

/// Classifies tiles (tile_active), then P7: near and far fields by the 49-tap gather.
void gather(const Settings& s, HalfRes& h);

/// P8: 3×3 max fill of both fields.
void fill(const Settings& s, HalfRes& h);

/// P9: far field (CoC-bilateral upsample) then near field over the full-res colour.
void composite(const Image& color, const FullCoc& full, const Settings& s, const HalfRes& h, Image& out);

/// Luma used by the Karis weights (Rec. 709 on premultiplied linear RGB).
inline float luma(float r, float g, float b) { return 0.2126f * r + 0.7152f * g + 0.0722f * b; }

inline int clampi(int v, int lo, int hi) { return v < lo ? lo : (v > hi ? hi : v); }

/// P9's footprint along one axis for full-res coordinate x (n half-res texels): the texels
/// i0 − 1 … i0 + 2 with i0 = x/2 − 1 (x even) or ⌊x/2⌋ (x odd), clamped; the fraction t of
/// the pixel centre past texel i0 is ¾ (even) or ¼ (odd). Shared by composite.cpp and
/// fast_composite.cpp so that both compute the weights with the same operations.
struct UpsampleAxis {
  int i[4];    // texel indices (bilinear uses i[1], i[2])
  float b[2];  // bilinear weights
  float c[4];  // cubic B-spline weights
};
inline UpsampleAxis upsample_axis(int x, int n) {
  UpsampleAxis a;
  const int i0 = (x % 2 == 0) ? x / 2 - 1 : x / 2;
  const float t = (x % 2 == 0) ? 0.75f : 0.25f;
  for (int k = 0; k < 4; ++k) a.i[k] = clampi(i0 - 1 + k, 0, n - 1);
  a.b[0] = 1.0f - t;
  a.b[1] = t;
  const float s = 1.0f - t;
  a.c[0] = s * s * s / 6.0f;
  a.c[1] = (3 * t * t * t - 6 * t * t + 4) / 6.0f;
  a.c[2] = (-3 * t * t * t + 3 * t * t + 3 * t + 1) / 6.0f;
  a.c[3] = t * t * t / 6.0f;
  return a;
}

}  // namespace dofkit::detail::sterna
