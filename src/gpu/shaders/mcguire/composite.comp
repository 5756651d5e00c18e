#version 450
// P4 of mcguire (src/methods/mcguire/composite.cpp): full-resolution composite over the
// frame; out = lerp(sharp, blurry, |s|)·(1 − α_near) + near. The reduced buffers are read
// bilinearly by hand (four loads, float weights as on the CPU; no sampler) at texel
// coordinate x / f (lowres_fix) or (x + ½)/f − ½. Pixels outside `inner` (guard band) are 0.
#include "dofkit.glsl"
#include "params.glsl"
DOFKIT_LOCAL_2D

layout(std430, binding = 1) readonly buffer Packed { float packed[]; };  // 5 planes src_w × src_h
layout(std430, binding = 2) readonly buffer Blur { float blur[]; };      // 4 planes wo × ho
layout(std430, binding = 3) readonly buffer Near { float near[]; };      // 5 planes wo × ho
layout(std430, binding = 4) writeonly buffer Out { float outp[]; };      // 4 planes W × H

struct Tap2 {
  int i0, i1;
  float w1;
};
Tap2 bilinear_tap(int x, int n_low) {
  // composite.cpp computes t in double and rounds its fraction k / f (lowres_fix) or
  // k / (2f) (centred) to float: the same value as the correctly rounded float quotient.
  Tap2 t;
  int i;
  float w;
  if (p.lowres_fix != 0) {
    i = x / p.f;
    w = div_rn(float(x - i * p.f), float(p.f));
  } else {
    const int num = 2 * x + 1 - p.f, den = 2 * p.f;  // t = num / den, num >= 1 - f > -den
    i = num >= 0 ? num / den : -1;
    w = div_rn(float(num - i * den), float(den));
  }
  t.i0 = clampi(i, 0, n_low - 1);
  t.i1 = clampi(i + 1, 0, n_low - 1);
  t.w1 = w;
  return t;
}

float lerp2(int plane_off, Tap2 vx, Tap2 vy, bool is_blur) {
  const int W = p.wo;
  float a, b, c, d;
  if (is_blur) {
    a = blur[plane_off + vy.i0 * W + vx.i0];
    b = blur[plane_off + vy.i0 * W + vx.i1];
    c = blur[plane_off + vy.i1 * W + vx.i0];
    d = blur[plane_off + vy.i1 * W + vx.i1];
  } else {
    a = near[plane_off + vy.i0 * W + vx.i0];
    b = near[plane_off + vy.i0 * W + vx.i1];
    c = near[plane_off + vy.i1 * W + vx.i0];
    d = near[plane_off + vy.i1 * W + vx.i1];
  }
  precise float top = a + (b - a) * vx.w1;
  precise float bot = c + (d - c) * vx.w1;
  precise float r = top + (bot - top) * vy.w1;
  return r;
}

void main() {
  const int X = int(gl_GlobalInvocationID.x), Y = int(gl_GlobalInvocationID.y);
  if (X >= p.W || Y >= p.H) return;
  const int n = p.W * p.H, o = Y * p.W + X;
  const int x = X - p.inner_x, y = Y - p.inner_y;
  if (x < 0 || y < 0 || x >= p.inner_w || y >= p.inner_h) {
    for (int c = 0; c < 4; ++c) outp[c * n + o] = 0.0;  // guard band: transparent black
    return;
  }
  const int m = p.src_w * p.src_h, q = (p.oy + y) * p.src_w + p.ox + x;
  if (p.identity != 0) {  // everything in the focus field: the input, exactly
    for (int c = 0; c < 4; ++c) outp[c * n + o] = packed[c * m + q];
    return;
  }
  const Tap2 vx = bilinear_tap(x, p.wo), vy = bilinear_tap(y, p.ho);
  const int mo = p.wo * p.ho;
  precise float nr[5];
  for (int c = 0; c < 5; ++c) nr[c] = lerp2(c * mo, vx, vy, false);
  precise float s = packed[4 * m + q];
  if (s < 0.0) s = max(s * p.far_rescale, -1.0);
  precise float blur_amount;
  if (p.variant == kG3d) {
    blur_amount = saturate(-12.0 * s);
  } else {
    if (p.double_coc != 0) s = clamp(2.0 * s, -1.0, 1.0);
    if (p.coverage_boost != 1.0) {
      precise float a = saturate(p.coverage_boost * nr[4]);
      precise float g = nr[4] > 0.0 ? a / nr[4] : 0.0;
      for (int c = 0; c < 4; ++c) nr[c] *= g;
      nr[4] = a;
    }
    if (s > 0.1) s = min(1.5 * s, 1.0);
    blur_amount = abs(s);
  }
  precise float keep = 1.0 - nr[4];
  for (int c = 0; c < 4; ++c) {
    const float sharp = packed[c * m + q];
    precise float v = sharp + (lerp2(c * mo, vx, vy, true) - sharp) * blur_amount;
    if (p.variant == kG3d) v = max(v, 0.0);
    precise float r = v * keep + nr[c];
    outp[c * n + o] = r;
  }
}
