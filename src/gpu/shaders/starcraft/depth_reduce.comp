#version 450
// C4 of starcraft, first step (src/methods/starcraft/depth_blur.cpp, plain form): inverse
// depth 1/z averaged over each 4×4 block (clamped at the border); +inf depth gives 0.
// core/box.comp then blurs it. Float sums (the CPU's are double).
#include "dofkit.glsl"
#include "params.glsl"
DOFKIT_LOCAL_2D

layout(std430, binding = 1) readonly buffer Depth { float depth[]; };
layout(std430, binding = 2) writeonly buffer InvDepth { float inv_depth[]; };  // lw × lh

void main() {
  const int i = int(gl_GlobalInvocationID.x), j = int(gl_GlobalInvocationID.y);
  if (i >= p.lw || j >= p.lh) return;
  precise float s = 0.0;
  int cnt = 0;
  for (int y = j * kDown; y < min(p.H, (j + 1) * kDown); ++y)
    for (int x = i * kDown; x < min(p.W, (i + 1) * kDown); ++x) {
      s += div_rn(1.0, depth[y * p.W + x]);
      ++cnt;
    }
  inv_depth[j * p.lw + i] = div_rn(s, float(cnt));
}
