#version 450
// P1 of mcguire (src/methods/mcguire/coc_pack.cpp): colour and s = clamp(r / R_max, -1, 1)
// (0 where |r| <= focus_px) for the rectangle the passes read. Packed: 5 planes src_w × src_h.
#include "dofkit.glsl"
#include "params.glsl"
DOFKIT_LOCAL_2D

layout(std430, binding = 1) readonly buffer Colour { float colour[]; };  // 4 planes W × H
layout(std430, binding = 2) readonly buffer Coc { float coc[]; };        // W × H, signed px
layout(std430, binding = 3) writeonly buffer Packed { float packed[]; };

void main() {
  const int x = int(gl_GlobalInvocationID.x), y = int(gl_GlobalInvocationID.y);
  if (x >= p.src_w || y >= p.src_h) return;
  const int n = p.W * p.H, m = p.src_w * p.src_h;
  const int i = (p.src_y + y) * p.W + p.src_x + x, o = y * p.src_w + x;
  for (int c = 0; c < 4; ++c) packed[c * m + o] = colour[c * n + i];
  const float r = coc[i];
  precise float s = abs(r) <= p.focus_px ? 0.0 : clamp(r * p.inv_rmax, -1.0, 1.0);
  packed[4 * m + o] = s;
}
