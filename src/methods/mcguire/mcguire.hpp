// McGuire et al. depth of field (Skylanders SWAP Force / VVDoF / G3D), docs/methods/mcguire.md.
// Internal interface shared by the four passes of the `mcguire` method:
//   coc_pack.cpp   P1  colour + signed CoC → packed buffer (RGBA + s = r / R_max)
//   blur.cpp       P2/P3 dual separable blur → blurry far/focus buffer + premultiplied near buffer
//   composite.cpp  P4  sharp ↔ blurry lerp by |s|, coverage boost, near field "over"
//   mcguire.cpp    parameters, per-frame constants, the MethodDef
#pragma once
#include <array>

#include "dofkit/image.hpp"

namespace dofkit::detail {
struct MethodContext;
}

namespace dofkit::detail::mcguire {

/// book = GPU Pro 4 chapter (2x, Gaussian table, far occlusion test);
/// demo = 2013 web demo (4x, disc-like table, no far test, far-radius rescale, guard band);
/// g3d  = G3D 10 (2019) rules of docs/methods/mcguire.md.
enum class Variant { book, demo, g3d };

/// Everything the passes need, fixed for one frame. Radii are in full-resolution image pixels.
struct Constants {
  Variant variant = Variant::demo;
  int f = 4;                      ///< reduction factor per axis (1..4)
  int r_max = 0;                  ///< R_max: tap half-width and CoC normaliser, px (integer)
  float r_near = 0;               ///< R_near: fixed near-field blur radius, px (0 = no near field)
  float inv_near = 1e4f;          ///< 1 / max(R_near, 1e-4)
  float far_rescale = 1;          ///< multiplies negative s in the composite (1 = off)
  float coverage_boost = 1.5f;    ///< near alpha gain (book/demo)
  bool far_occlusion = false;     ///< far taps must not be meaningfully farther than the centre
  bool double_coc = false;        ///< composite: s = clamp(2 s, -1, 1) before the near boost
  bool near_alpha_code = true;    ///< near alpha saturate(4 r/R_near)^4 (code) vs min(1, r/R_near)^4 (book prose)
  bool lowres_offset_fix = true;  ///< sample low-res buffers where their point-decimated texels really are
  float focus_px = 0.5f;          ///< |r| <= focus_px packs as exactly sharp (s = 0)
  float g3d_fov_rad = 0.7f;       ///< g3d coverage curve parameter (G3D passes the camera FOV)
};

/// Axis-aligned pixel rectangle.
struct Rect {
  int x = 0, y = 0, w = 0, h = 0;
};

/// Parameters read from --set and the frame's CoC range (mcguire.cpp).
struct Setup {
  Constants k;
  int guard = 0;
  bool guard_taps = true;
};
Setup read_setup(const MethodContext& ctx, float max_near, float max_far);

/// Everything one frame's passes need besides the buffers, shared by the CPU passes and the
/// GPU backend (src/gpu/methods/mcguire.cpp): the setup, the rectangle the passes read
/// (`src`: the image, or the inner rectangle when the guard band is not read), the rendered
/// rectangle `inner`, its origin (ox, oy) inside `src`, and the reduced buffer size wo × ho.
struct FrameSetup {
  Setup st;
  Rect src, inner;
  int ox = 0, oy = 0, wo = 1, ho = 1;
};
/// Throws Error(usage) for a guard band that leaves no inner image.
FrameSetup frame_setup(const MethodContext& ctx);

// Buffer layouts (planar float):
//   packed  5 planes: R, G, B, A (premultiplied colour), s = clamp(r / R_max, -1, 1)
//   t_blur  5 planes: R, G, B, A of the horizontal far/focus blur, s of the centre tap
//   t_near  5 planes: α·R, α·G, α·B, α·A, α (premultiplied by the near coverage α)
//   blur    4 planes: R, G, B, A
//   near    5 planes: as t_near
constexpr int kPacked = 5;

/// P1: packs `src` (a rectangle of the input) into `packed` (src.w × src.h, 5 planes).
void pack_coc(const Image& colour, const Image& coc, const Rect& src, const Constants& k, Image& packed);

/// P2: horizontal dual blur. Output texel (i, y) is centred on packed pixel (ox + f·i, y);
/// `wo` texels per row, every packed row. Taps clamp to the packed buffer.
void blur_horizontal(const Image& packed, const Constants& k, int ox, int wo, Image& t_blur, Image& t_near);
/// P3: vertical dual blur. Output texel (i, j) is centred on row oy + f·j of t_blur/t_near;
/// `ho` rows. Writes blur (4 planes) and near (5 planes).
void blur_vertical(const Image& t_blur, const Image& t_near, const Constants& k, int oy, int ho, Image& blur,
                   Image& near);

/// Plain (unoptimised, obviously-correct) versions of P2 and P3: the test oracle.
void blur_horizontal_plain(const Image& packed, const Constants& k, int ox, int wo, Image& t_blur, Image& t_near);
void blur_vertical_plain(const Image& t_blur, const Image& t_near, const Constants& k, int oy, int ho, Image& blur,
                         Image& near);

/// P4: writes the `inner` rectangle of `out` (RGBA). Packed pixel (ox + x, oy + y) holds
/// inner pixel (x, y), which is output pixel (inner.x + x, inner.y + y). If `weights` is non-null it receives the
/// composite weights (R = near coverage, G = blurry weight, B = sharp weight, A = 1) for
/// the inner rectangle (inner.w × inner.h).
void composite(const Image& packed, int ox, int oy, const Image& blur, const Image& near, const Constants& k,
               const Rect& inner, Image& out, Image* weights);

}  // namespace dofkit::detail::mcguire
