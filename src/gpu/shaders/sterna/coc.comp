#version 450
// P1 of sterna (src/methods/sterna/coc.cpp): near and far blend factors at full resolution.
// Signed CoC r: near = saturate((r − ½)/ramp), far = saturate((−r − ½)/ramp). NearFarBlend
// camera (native): from z, in float here (the CPU uses double for the plane differences).
#include "dofkit.glsl"
#include "params.glsl"
DOFKIT_LOCAL_2D

layout(std430, binding = 1) readonly buffer Coc { float coc[]; };      // W × H signed px
layout(std430, binding = 2) readonly buffer Depth { float depth[]; };  // W × H z (native only)
layout(std430, binding = 3) writeonly buffer Full { float full[]; };   // 2 planes W × H

float sat(float v) { return v > 0.0 ? (v < 1.0 ? v : 1.0) : 0.0; }  // NaN → 0

void main() {
  const int x = int(gl_GlobalInvocationID.x), y = int(gl_GlobalInvocationID.y);
  if (x >= p.W || y >= p.H) return;
  const int i = y * p.W + x, n = p.W * p.H;
  float nr, fr;
  if (p.native != 0) {
    const float z = depth[i];
    nr = sat(div_rn(z - p.ne, p.nb - p.ne));
    fr = isinf(z) ? 1.0 : sat(div_rn(z - p.fb, p.fe - p.fb));
    if (nr > 0.0 && fr > 0.0) fr = 0.0;
  } else {
    const float r = coc[i];
    nr = sat(div_rn(r - 0.5, p.ramp));
    fr = sat(div_rn(-r - 0.5, p.ramp));
  }
  full[i] = nr;
  full[n + i] = fr;
}
