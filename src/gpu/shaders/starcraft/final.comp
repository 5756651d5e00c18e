#version 450
// C5 of starcraft (src/methods/starcraft/final.cpp, final_pass_plain): per full-res pixel the
// depth test (blurred 1/z <= own 1/z · (1 + 1e-5): keep the own level, else the blurred
// one), the chapter's level weights, the 17-tap small blur, the medium level (divided here:
// blurred c·rgba / blurred c, the source where that is <= 1e-6) and the bilinearly
// up-sampled large level, blended over the source.
#include "dofkit.glsl"
#include "params.glsl"
DOFKIT_LOCAL_2D

layout(std430, binding = 1) readonly buffer Colour { float colour[]; };    // 4 planes W × H
layout(std430, binding = 2) readonly buffer Depth { float depth[]; };      // W × H
layout(std430, binding = 3) readonly buffer Level { float level[]; };      // W × H
layout(std430, binding = 4) readonly buffer Medium { float medium[]; };    // 5 planes W × H (not divided)
layout(std430, binding = 5) readonly buffer Large { float large[]; };      // 5 planes lw × lh (not divided)
layout(std430, binding = 6) readonly buffer InvDepth { float inv_depth[]; };  // lw × lh
layout(std430, binding = 7) writeonly buffer Out { float outp[]; };        // 4 planes W × H

int i00, i01, i10, i11;
float w00, w01, w10, w11;
float bilerp_large(int plane) {
  const int m = p.lw * p.lh;
  precise float r = w00 * large[plane * m + i00] + w01 * large[plane * m + i01] + w10 * large[plane * m + i10] +
                    w11 * large[plane * m + i11];
  return r;
}
float bilerp_depth() {
  precise float r = w00 * inv_depth[i00] + w01 * inv_depth[i01] + w10 * inv_depth[i10] + w11 * inv_depth[i11];
  return r;
}

// The small blur's four 2×2 blocks (top-left pixel offsets), final.cpp kTapBlock.
const ivec2 kTapBlock[4] = ivec2[4](ivec2(0, -2), ivec2(-2, -1), ivec2(-1, 1), ivec2(1, 0));

void main() {
  const int x = int(gl_GlobalInvocationID.x), y = int(gl_GlobalInvocationID.y);
  if (x >= p.W || y >= p.H) return;
  const int n = p.W * p.H, q = y * p.W + x;
  // quarter_bilerp: pixel centre on the quarter-res grid.
  precise float fx = (float(x) + 0.5) * 0.25 - 0.5, fy = (float(y) + 0.5) * 0.25 - 0.5;  // / kDown, exact
  const float x0f = floor(fx), y0f = floor(fy);
  precise float tx = fx - x0f, ty = fy - y0f;
  const int x0 = int(x0f), y0 = int(y0f);
  const int xa = clampi(x0, 0, p.lw - 1), xb = clampi(x0 + 1, 0, p.lw - 1);
  const int ya = clampi(y0, 0, p.lh - 1), yb = clampi(y0 + 1, 0, p.lh - 1);
  i00 = ya * p.lw + xa;
  i01 = ya * p.lw + xb;
  i10 = yb * p.lw + xa;
  i11 = yb * p.lw + xb;
  precise float a00 = (1.0 - tx) * (1.0 - ty), a01 = tx * (1.0 - ty), a10 = (1.0 - tx) * ty, a11 = tx * ty;
  w00 = a00;
  w01 = a01;
  w10 = a10;
  w11 = a11;

  const float cown = level[q];
  const float inv_own = div_rn(1.0, depth[q]);
  const float inv_blur = bilerp_depth();
  const float c_blur = bilerp_large(4);
  precise float tie = inv_own * (1.0 + 1e-5);
  float c = inv_blur <= tie ? cown : c_blur;
  if (p.keep_own != 0) c = max(c, cown);
  // level_weights (starcraft.hpp), d0 = 0.5, d1 = d2 = 0.25.
  precise float wx = saturate(1.0 - div_rn(c, 0.5));
  precise float wy = saturate(3.0 - div_rn(c, 0.25));
  precise float wz = saturate(4.0 - div_rn(c, 0.25));
  precise float ww = saturate(-3.0 + div_rn(c, 0.25));
  precise float ys = wy < 1.0 - wx ? wy : 1.0 - wx;
  precise float zs = wz < 1.0 - wy ? wz : 1.0 - wy;
  precise float alpha = (16.0 / 17.0) * ys + zs + ww;
  const float mw = medium[4 * n + q];
  for (int ch = 0; ch < 4; ++ch) {
    const float src = colour[ch * n + q];
    if (alpha == 0.0) {  // in focus: the source, bit for bit
      outp[ch * n + q] = src;
      continue;
    }
    precise float small = 0.0;
    for (int t = 0; t < 4; ++t) {
      const int xa2 = clampi(x + kTapBlock[t].x, 0, p.W - 1), xb2 = clampi(x + kTapBlock[t].x + 1, 0, p.W - 1);
      const int ra = ch * n + clampi(y + kTapBlock[t].y, 0, p.H - 1) * p.W;
      const int rb = ch * n + clampi(y + kTapBlock[t].y + 1, 0, p.H - 1) * p.W;
      small += colour[ra + xa2] + colour[ra + xb2] + colour[rb + xa2] + colour[rb + xb2];
    }
    small *= 1.0 / 17.0;
    const float med = mw > 1e-6 ? div_rn(medium[ch * n + q], mw) : src;
    const float lg = c_blur > 1e-6 ? div_rn(bilerp_large(ch), c_blur) : med;
    precise float mixed = ys * small + zs * med + ww * lg;
    precise float r = mixed + (1.0 - alpha) * src;
    outp[ch * n + q] = r;
  }
}
