#version 450
// P9 of sterna (src/methods/sterna/composite.cpp): far field by the CoC-bilateral 2×2
// upsample blended by blend·far(q), then the near field (bilinear or cubic B-spline) blended
// by blend·min(nearBlur, 1), over the full-res colour. Texels with far_h = 0 carry no far
// colour and get weight 0.
#include "dofkit.glsl"
#include "params.glsl"
DOFKIT_LOCAL_2D

layout(std430, binding = 1) readonly buffer Colour { float colour[]; };  // 4 planes W × H
layout(std430, binding = 2) readonly buffer Full { float full[]; };      // 2 planes W × H
layout(std430, binding = 3) readonly buffer CocH { float coc_h[]; };     // 2 planes w × h
layout(std430, binding = 4) readonly buffer NearB { float nblur[]; };
layout(std430, binding = 5) readonly buffer NearFill { float near_fill[]; };
layout(std430, binding = 6) readonly buffer FarFill { float far_fill[]; };
layout(std430, binding = 7) writeonly buffer Out { float outp[]; };  // 4 planes W × H

struct Axis {
  int i[4];
  float b[2];
  float c[4];
};
// passes.hpp upsample_axis.
Axis upsample_axis(int x, int n) {
  Axis a;
  const bool even = (x % 2) == 0;
  const int i0 = even ? x / 2 - 1 : x / 2;
  const float t = even ? 0.75 : 0.25;
  for (int k = 0; k < 4; ++k) a.i[k] = clampi(i0 - 1 + k, 0, n - 1);
  a.b[0] = 1.0 - t;
  a.b[1] = t;
  precise float s = 1.0 - t;
  precise float c0 = s * s * s, c1 = 3.0 * t * t * t - 6.0 * t * t + 4.0, c2 = -3.0 * t * t * t + 3.0 * t * t + 3.0 * t + 1.0,
                c3 = t * t * t;
  a.c[0] = div_rn(c0, 6.0);
  a.c[1] = div_rn(c1, 6.0);
  a.c[2] = div_rn(c2, 6.0);
  a.c[3] = div_rn(c3, 6.0);
  return a;
}

void main() {
  const int x = int(gl_GlobalInvocationID.x), y = int(gl_GlobalInvocationID.y);
  if (x >= p.W || y >= p.H) return;
  const int N = p.W * p.H, q = y * p.W + x, m = p.w * p.h;
  precise vec4 res = vec4(colour[q], colour[N + q], colour[2 * N + q], colour[3 * N + q]);
  if (p.blend > 0.0) {
    const Axis X = upsample_axis(x, p.w), Y = upsample_axis(y, p.h);
    const float fq = full[N + q];
    if (fq > 0.0) {
      precise float t = p.blend * fq;
      if (p.per_pixel != 0) t = p.blend * min(1.0, div_rn(fq * p.radius_per_far_comp, 2.0));
      precise float wsum = 0.0;
      precise vec4 acc = vec4(0.0);
      for (int b = 0; b < 2; ++b)
        for (int a = 0; a < 2; ++a) {
          const int k = Y.i[1 + b] * p.w + X.i[1 + a];
          const float fk = coc_h[m + k];
          if (!(fk > 0.0)) continue;
          precise float wk = div_rn(X.b[a] * Y.b[b], abs(fq - fk) + 0.001);
          wsum += wk;
          acc += wk * vec4(far_fill[k], far_fill[m + k], far_fill[2 * m + k], far_fill[3 * m + k]);
        }
      if (wsum > 0.0)
        for (int c = 0; c < 4; ++c) res[c] += (div_rn(acc[c], wsum) - res[c]) * t;
    }
    precise float nb = 0.0;
    precise vec4 nf = vec4(0.0);
    if (p.bicubic != 0) {
      for (int b = 0; b < 4; ++b)
        for (int a = 0; a < 4; ++a) {
          const int k = Y.i[b] * p.w + X.i[a];
          precise float wk = X.c[a] * Y.c[b];
          nb += wk * nblur[k];
          nf += wk * vec4(near_fill[k], near_fill[m + k], near_fill[2 * m + k], near_fill[3 * m + k]);
        }
    } else {
      for (int b = 0; b < 2; ++b)
        for (int a = 0; a < 2; ++a) {
          const int k = Y.i[1 + b] * p.w + X.i[1 + a];
          precise float wk = X.b[a] * Y.b[b];
          nb += wk * nblur[k];
          nf += wk * vec4(near_fill[k], near_fill[m + k], near_fill[2 * m + k], near_fill[3 * m + k]);
        }
    }
    precise float t = p.blend * min(nb, 1.0);
    if (t > 0.0) res += (nf - res) * t;
  }
  for (int c = 0; c < 4; ++c) outp[c * N + q] = res[c];
}
