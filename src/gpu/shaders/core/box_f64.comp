#version 450
// core/box.comp with the CPU's double arithmetic (extended_box_x/y_plain): the sum and the
// products in double, each output rounded to float. For passes whose result feeds a hard
// threshold (starcraft's blurred 1/z against the pixel's own), where float sums would decide
// some pixels the other way. Needs shaderFloat64 (the host picks core/box.comp without it).
#include "dofkit.glsl"
DOFKIT_LOCAL_2D

layout(std140, binding = 0) uniform Params {
  int w, h, planes, axis;
  int r, norm_lo, norm_hi, pad2;  // norm: the double 1 / (2r + 1 + 2α), as its two 32-bit halves
  float alpha, norm_f, flush_below, pad3;
} p;
layout(std430, binding = 1) readonly buffer In { float src[]; };
layout(std430, binding = 2) writeonly buffer Out { float dst[]; };

void main() {
  const int x = int(gl_GlobalInvocationID.x), y = int(gl_GlobalInvocationID.y);
  if (x >= p.w || y >= p.h) return;
  const int n = p.w * p.h;
  const double norm = packDouble2x32(uvec2(uint(p.norm_lo), uint(p.norm_hi)));
  for (int c = 0; c < p.planes; ++c) {
    const int base = c * n;
    precise double sum = 0.0LF;
    precise double ends;
    if (p.axis == 0) {
      const int row = base + y * p.w;
      for (int i = -p.r; i <= p.r; ++i) sum += double(src[row + clampi(x + i, 0, p.w - 1)]);
      ends = double(src[row + clampi(x - p.r - 1, 0, p.w - 1)]) + double(src[row + clampi(x + p.r + 1, 0, p.w - 1)]);
    } else {
      for (int i = -p.r; i <= p.r; ++i) sum += double(src[base + clampi(y + i, 0, p.h - 1) * p.w + x]);
      ends = double(src[base + clampi(y - p.r - 1, 0, p.h - 1) * p.w + x]) +
             double(src[base + clampi(y + p.r + 1, 0, p.h - 1) * p.w + x]);
    }
    precise double v = (sum + double(p.alpha) * ends) * norm;
    const float f = float(v);
    dst[base + y * p.w + x] = f < p.flush_below ? 0.0 : f;
  }
}
