#version 450
// P8 of sterna (src/methods/sterna/fill.cpp): 3×3 per-channel max of each field where its
// early-out failed (nearBlur_h > 0, far_h > 0), a copy elsewhere; with per_pixel_scale a far
// neighbour counts only if its kernel radius is within one texel of the centre's.
#include "dofkit.glsl"
#include "params.glsl"
DOFKIT_LOCAL_2D

layout(std430, binding = 1) readonly buffer DofNear { float dof_near[]; };
layout(std430, binding = 2) readonly buffer DofFar { float dof_far[]; };
layout(std430, binding = 3) readonly buffer CocH { float coc_h[]; };
layout(std430, binding = 4) readonly buffer NearB { float nblur[]; };
layout(std430, binding = 5) writeonly buffer NearFill { float near_fill[]; };
layout(std430, binding = 6) writeonly buffer FarFill { float far_fill[]; };

void main() {
  const int x = int(gl_GlobalInvocationID.x), y = int(gl_GlobalInvocationID.y);
  if (x >= p.w || y >= p.h) return;
  const int m = p.w * p.h, o = y * p.w + x;
  const int xs[3] = int[3](max(x - 1, 0), x, min(x + 1, p.w - 1));
  const int ys[3] = int[3](max(y - 1, 0), y, min(y + 1, p.h - 1));
  const bool near_on = nblur[o] > 0.0;
  const float fr = coc_h[m + o];
  for (int c = 0; c < 4; ++c) {
    float mn = dof_near[c * m + o];
    if (near_on)
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) mn = max(mn, dof_near[c * m + ys[a] * p.w + xs[b]]);
    near_fill[c * m + o] = mn;
    float mf = dof_far[c * m + o];
    if (fr > 0.0)
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) {
          const int q = ys[a] * p.w + xs[b];
          precise float dr = abs(coc_h[m + q] - fr) * p.radius_per_far_fill;
          if (p.per_pixel == 0 || dr <= 1.0) mf = max(mf, dof_far[c * m + q]);
        }
    far_fill[c * m + o] = mf;
  }
}
