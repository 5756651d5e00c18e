#version 450
// P2 of sterna (src/methods/sterna/downsample.cpp): per half-res texel the quad mean
// (colour_h), the far-bilateral mean × far(TL) (colourFar_h) and the top-left CoC (coc_h);
// Karis weights 1/(1 + luma) with firefly=karis. Odd sizes clamp the quad to the edge.
#include "dofkit.glsl"
#include "params.glsl"
DOFKIT_LOCAL_2D

layout(std430, binding = 1) readonly buffer Colour { float colour[]; };  // 4 planes W × H
layout(std430, binding = 2) readonly buffer Full { float full[]; };      // 2 planes W × H
layout(std430, binding = 3) writeonly buffer ColH { float col_h[]; };    // 4 planes w × h
layout(std430, binding = 4) writeonly buffer FarH { float far_h[]; };    // 4 planes w × h
layout(std430, binding = 5) writeonly buffer CocH { float coc_h[]; };    // 2 planes w × h

void main() {
  const int i = int(gl_GlobalInvocationID.x), j = int(gl_GlobalInvocationID.y);
  if (i >= p.w || j >= p.h) return;
  const int N = p.W * p.H, m = p.w * p.h, o = j * p.w + i;
  const int xs[2] = int[2](2 * i, clampi(2 * i + 1, 0, p.W - 1));
  const int ys[2] = int[2](2 * j, clampi(2 * j + 1, 0, p.H - 1));
  vec4 c[4];
  float far[4], wk[4];
  for (int k = 0; k < 4; ++k) {
    const int q = ys[k >> 1] * p.W + xs[k & 1];
    c[k] = vec4(colour[q], colour[N + q], colour[2 * N + q], colour[3 * N + q]);
    far[k] = full[N + q];
    precise float l = 0.2126 * c[k].x + 0.7152 * c[k].y + 0.0722 * c[k].z;
    wk[k] = p.karis != 0 ? div_rn(1.0, 1.0 + max(0.0, l)) : 1.0;
  }
  precise float wsum = 0.0;
  precise vec4 acc = vec4(0.0);
  for (int k = 0; k < 4; ++k) {
    wsum += wk[k];
    acc += wk[k] * c[k];
  }
  for (int ch = 0; ch < 4; ++ch) col_h[ch * m + o] = div_rn(acc[ch], wsum);
  precise float bsum = 0.0;
  precise vec4 bacc = vec4(0.0);
  for (int k = 0; k < 4; ++k) {
    precise float wb = (k == 0 ? 1000.0 : div_rn(1.0, abs(far[k] - far[0]) + 0.001)) * wk[k];
    bsum += wb;
    bacc += wb * c[k];
  }
  for (int ch = 0; ch < 4; ++ch) {
    precise float v = div_rn(bacc[ch], bsum) * far[0];
    far_h[ch * m + o] = v;
  }
  coc_h[o] = full[ys[0] * p.W + xs[0]];
  coc_h[m + o] = far[0];
}
