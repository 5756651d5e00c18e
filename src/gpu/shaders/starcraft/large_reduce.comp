#version 450
// C3 of starcraft, first step (src/methods/starcraft/large_blur.cpp, plain form): each 4×4
// block (clamped at the right / bottom border) → c_block · (c-weighted block colour) in
// planes 0-3 and c_block in plane 4, c_block = the block's mean (or max) level. Float sums
// (the CPU's are double). core/box.comp then blurs the 5 planes.
#include "dofkit.glsl"
#include "params.glsl"
DOFKIT_LOCAL_2D

layout(std430, binding = 1) readonly buffer Colour { float colour[]; };
layout(std430, binding = 2) readonly buffer Level { float level[]; };
layout(std430, binding = 3) writeonly buffer Large { float large[]; };  // 5 planes lw × lh

void main() {
  const int i = int(gl_GlobalInvocationID.x), j = int(gl_GlobalInvocationID.y);
  if (i >= p.lw || j >= p.lh) return;
  const int n = p.W * p.H, m = p.lw * p.lh, o = j * p.lw + i;
  precise vec4 wsum = vec4(0.0), psum = vec4(0.0);
  precise float csum = 0.0;
  float cmax = 0.0;
  int cnt = 0;
  for (int y = j * kDown; y < min(p.H, (j + 1) * kDown); ++y)
    for (int x = i * kDown; x < min(p.W, (i + 1) * kDown); ++x) {
      const int q = y * p.W + x;
      const float c = level[q];
      csum += c;
      cmax = max(cmax, c);
      const vec4 v = vec4(colour[q], colour[n + q], colour[2 * n + q], colour[3 * n + q]);
      wsum += c * v;
      psum += v;
      ++cnt;
    }
  precise float cb = p.reduce_max != 0 ? cmax : div_rn(csum, float(cnt));
  for (int ch = 0; ch < 4; ++ch) {
    precise float col = csum > 0.0 ? div_rn(wsum[ch], csum) : div_rn(psum[ch], float(cnt));
    large[ch * m + o] = cb * col;
  }
  large[4 * m + o] = cb;
}
