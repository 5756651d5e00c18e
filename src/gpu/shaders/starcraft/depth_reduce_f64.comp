#version 450
// starcraft/depth_reduce.comp with the CPU's double arithmetic (depth_blur.cpp: Σ 1.0/z in
// double, divided by the count, rounded to float): the blurred 1/z decides rule 3 by a hard
// comparison. Needs shaderFloat64.
#include "dofkit.glsl"
#include "params.glsl"
DOFKIT_LOCAL_2D

layout(std430, binding = 1) readonly buffer Depth { float depth[]; };
layout(std430, binding = 2) writeonly buffer InvDepth { float inv_depth[]; };

// a / b correctly rounded in double (GPU double division need not be).
double div_rn_d(double a, double b) {
  precise double q = a / b;
  precise double r = fma(-q, b, a);
  precise double res = fma(r, 1.0LF / b, q);
  return isnan(res) ? q : res;
}

void main() {
  const int i = int(gl_GlobalInvocationID.x), j = int(gl_GlobalInvocationID.y);
  if (i >= p.lw || j >= p.lh) return;
  precise double s = 0.0LF;
  int cnt = 0;
  for (int y = j * kDown; y < min(p.H, (j + 1) * kDown); ++y)
    for (int x = i * kDown; x < min(p.W, (i + 1) * kDown); ++x) {
      s += div_rn_d(1.0LF, double(depth[y * p.W + x]));
      ++cnt;
    }
  inv_depth[j * p.lw + i] = float(div_rn_d(s, double(cnt)));
}
