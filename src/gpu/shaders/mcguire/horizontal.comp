#version 450
// P2 of mcguire (src/methods/mcguire/blur.cpp, blur_horizontal_plain): output texel (i, y)
// centred on packed pixel (ox + f·i, y), taps -R_max .. R_max at full-resolution spacing,
// clamped to the row. t_blur: far/focus blur RGBA + the centre's s; t_near: α·RGBA, α
// (box-averaged, premultiplied by the near coverage). Float accumulators, CPU order.
#include "dofkit.glsl"
#include "params.glsl"
#include "weights.glsl"
DOFKIT_LOCAL_2D

layout(std430, binding = 1) readonly buffer Packed { float packed[]; };  // 5 planes src_w × src_h
layout(std430, binding = 2) writeonly buffer TBlur { float t_blur[]; };  // 5 planes wo × src_h
layout(std430, binding = 3) writeonly buffer TNear { float t_near[]; };  // 5 planes wo × src_h

void main() {
  const int i = int(gl_GlobalInvocationID.x), y = int(gl_GlobalInvocationID.y);
  if (i >= p.wo || y >= p.src_h) return;
  const int W = p.src_w, m = p.src_w * p.src_h, row = y * W;
  const int a = p.ox + p.f * i;
  const float s_a = packed[4 * m + row + a];
  precise float r_a = s_a * p.rmax;
  precise float nearness = saturate(4.0 * r_a);
  precise vec4 blur = vec4(0.0);
  precise float blur_w = 0.0;
  precise vec4 near = vec4(0.0);
  precise float near_a = 0.0, near_w = 0.0;
  for (int d = -p.r_max; d <= p.r_max; ++d) {
    const int b = row + clampi(a + d, 0, W - 1);
    const float fd = float(d);
    precise float r_b = packed[4 * m + b] * p.rmax;
    const vec4 col = vec4(packed[b], packed[m + b], packed[2 * m + b], packed[3 * m + b]);
    precise float wn = far_weight(fd, r_a, r_b);
    precise float w = wn + (1.0 - wn) * nearness;
    blur += w * col;
    blur_w += w;
    precise float alpha = near_alpha_horizontal(fd, r_b);
    precise float v = near_box(fd);
    precise float va = v * alpha;
    near += va * col;
    near_a += va;
    near_w += v;
  }
  const int wo = p.wo, mo = p.wo * p.src_h, o = y * wo + i;
  precise vec4 res = blur / blur_w;
  for (int c = 0; c < 4; ++c) t_blur[c * mo + o] = res[c];
  t_blur[4 * mo + o] = s_a;
  precise float inv = 1.0 / max(near_w, 1e-5);
  precise vec4 nres = near * inv;
  for (int c = 0; c < 4; ++c) t_near[c * mo + o] = nres[c];
  t_near[4 * mo + o] = near_a * inv;
}
