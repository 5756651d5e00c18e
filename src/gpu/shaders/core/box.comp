#version 450
// One extended-box pass along x or y (src/core/filters.cpp, extended_box_x/y_plain):
//   out[x] = (Σ_{|i| <= r} in[x + i] + α·(in[x − r − 1] + in[x + r + 1])) · norm,
// norm = 1 / (2r + 1 + 2α), samples clamped to the edge; a plain box for α = 0. Several of
// them in a row make the Gaussians of starcraft (exact variance for any σ) and sterna's
// near-CoC box. The CPU sums with running sums in double; here every output sums its own
// window in float (no running-sum drift, ~(2r + 1)·2^-24 relative). Values below
// flush_below become 0 (sterna: "nearBlur > 0" must mean a near pixel is within reach).
#include "dofkit.glsl"
DOFKIT_LOCAL_2D

layout(std140, binding = 0) uniform Params {
  int w, h, planes, axis;  // axis 0 = x, 1 = y
  int r, pad0, pad1, pad2;
  float alpha, norm, flush_below, pad3;
} p;
layout(std430, binding = 1) readonly buffer In { float src[]; };
layout(std430, binding = 2) writeonly buffer Out { float dst[]; };

void main() {
  const int x = int(gl_GlobalInvocationID.x), y = int(gl_GlobalInvocationID.y);
  if (x >= p.w || y >= p.h) return;
  const int n = p.w * p.h;
  for (int c = 0; c < p.planes; ++c) {
    const int base = c * n;
    precise float sum = 0.0;
    precise float ends;
    if (p.axis == 0) {
      const int row = base + y * p.w;
      for (int i = -p.r; i <= p.r; ++i) sum += src[row + clampi(x + i, 0, p.w - 1)];
      ends = src[row + clampi(x - p.r - 1, 0, p.w - 1)] + src[row + clampi(x + p.r + 1, 0, p.w - 1)];
    } else {
      for (int i = -p.r; i <= p.r; ++i) sum += src[base + clampi(y + i, 0, p.h - 1) * p.w + x];
      ends = src[base + clampi(y - p.r - 1, 0, p.h - 1) * p.w + x] + src[base + clampi(y + p.r + 1, 0, p.h - 1) * p.w + x];
    }
    precise float v = (sum + p.alpha * ends) * p.norm;
    dst[base + y * p.w + x] = v < p.flush_below ? 0.0 : v;
  }
}
