#version 450
// C2 of starcraft, first step (src/methods/starcraft/medium_blur.cpp, plain form): the
// normalised convolution's numerator and denominator, c·rgba (4 planes) and c (plane 4),
// which core/box.comp then blurs (boxes passes per axis); the final pass divides.
#include "dofkit.glsl"
#include "params.glsl"
DOFKIT_LOCAL_2D

layout(std430, binding = 1) readonly buffer Colour { float colour[]; };
layout(std430, binding = 2) readonly buffer Level { float level[]; };
layout(std430, binding = 3) writeonly buffer Weighted { float weighted[]; };  // 5 planes W × H

void main() {
  const int x = int(gl_GlobalInvocationID.x), y = int(gl_GlobalInvocationID.y);
  if (x >= p.W || y >= p.H) return;
  const int n = p.W * p.H, i = y * p.W + x;
  const float c = level[i];
  for (int ch = 0; ch < 4; ++ch) weighted[ch * n + i] = c * colour[ch * n + i];
  weighted[4 * n + i] = c;
}
