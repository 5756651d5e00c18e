#version 450
// P3/P4 of sterna (src/methods/sterna/near_coc_dilate.cpp): running max of the half-res
// near CoC over ±r texels along one axis (window clamped to the image: near >= 0, so this is
// the CPU's zero padding). axis 0 reads coc_h's near plane, axis 1 the x pass's output.
#include "dofkit.glsl"
#include "params.glsl"
DOFKIT_LOCAL_2D

layout(std430, binding = 1) readonly buffer In { float src[]; };
layout(std430, binding = 2) writeonly buffer Out { float dst[]; };

void main() {
  const int x = int(gl_GlobalInvocationID.x), y = int(gl_GlobalInvocationID.y);
  if (x >= p.w || y >= p.h) return;
  float m = 0.0;
  if (p.axis == 0) {
    for (int i = max(x - p.r, 0); i <= min(x + p.r, p.w - 1); ++i) m = max(m, src[y * p.w + i]);
  } else {
    for (int j = max(y - p.r, 0); j <= min(y + p.r, p.h - 1); ++j) m = max(m, src[j * p.w + x]);
  }
  dst[y * p.w + x] = m;
}
