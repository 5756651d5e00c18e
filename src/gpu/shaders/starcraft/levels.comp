#version 450
// C1 of starcraft (src/methods/starcraft/coc.cpp): the blur level c in [0, 1] per pixel.
// Signed CoC r: linear in v = max(0, r² − ¼) through (0, 0), (v_s, ½), (v_m, ¾), (v_l, 1)
// (LevelGeometry::level_of_radius). StarCraft camera (native): the chapter's
// saturate(α·max(0, |z − F| − R_full)/(R_none − R_full)), in float (the CPU uses double).
#include "dofkit.glsl"
#include "params.glsl"
DOFKIT_LOCAL_2D

layout(std430, binding = 1) readonly buffer Coc { float coc[]; };
layout(std430, binding = 2) readonly buffer Depth { float depth[]; };
layout(std430, binding = 3) writeonly buffer Level { float level[]; };

void main() {
  const int x = int(gl_GlobalInvocationID.x), y = int(gl_GlobalInvocationID.y);
  if (x >= p.W || y >= p.H) return;
  const int i = y * p.W + x;
  precise float c;
  if (p.native != 0) {
    precise float d = abs(depth[i] - p.focus);
    c = isinf(d) ? (p.amount > 0.0 ? 1.0 : 0.0) : clamp(div_rn(p.amount * max(0.0, d - p.full_range), p.range), 0.0, 1.0);
  } else {
    const float r = coc[i];
    precise float v = max(0.0, r * r - 0.25);
    if (v <= p.vs)
      c = div_rn(0.5 * v, p.vs);
    else if (v <= p.vm)
      c = 0.5 + div_rn(0.25 * (v - p.vs), p.vm - p.vs);
    else if (v <= p.vl)
      c = 0.75 + div_rn(0.25 * (v - p.vm), p.vl - p.vm);
    else
      c = 1.0;
  }
  level[i] = c;
}
