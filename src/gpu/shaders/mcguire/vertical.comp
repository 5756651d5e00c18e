#version 450
// P3 of mcguire (src/methods/mcguire/blur.cpp, blur_vertical_plain): output texel (i, j)
// centred on row oy + f·j of t_blur / t_near; same far rule, the near layer box-averaged
// again (premultiplied); g3d applies its smoothstep coverage curve at the end.
#include "dofkit.glsl"
#include "params.glsl"
#include "weights.glsl"
DOFKIT_LOCAL_2D

layout(std430, binding = 1) readonly buffer TBlur { float t_blur[]; };  // 5 planes wo × src_h
layout(std430, binding = 2) readonly buffer TNear { float t_near[]; };  // 5 planes wo × src_h
layout(std430, binding = 3) writeonly buffer Blur { float blur[]; };    // 4 planes wo × ho
layout(std430, binding = 4) writeonly buffer Near { float near[]; };    // 5 planes wo × ho

void main() {
  const int i = int(gl_GlobalInvocationID.x), j = int(gl_GlobalInvocationID.y);
  if (i >= p.wo || j >= p.ho) return;
  const int W = p.wo, H = p.src_h, m = W * H;
  const int a = p.oy + p.f * j;
  precise float r_a = t_blur[4 * m + a * W + i] * p.rmax;
  precise float nearness = saturate(4.0 * r_a);
  precise vec4 acc = vec4(0.0);
  precise float acc_w = 0.0;
  precise vec4 nacc = vec4(0.0);
  precise float nacc_a = 0.0, nacc_w = 0.0;
  for (int d = -p.r_max; d <= p.r_max; ++d) {
    const int b = clampi(a + d, 0, H - 1) * W + i;
    const float fd = float(d);
    precise float r_b = t_blur[4 * m + b] * p.rmax;
    precise float wn = far_weight(fd, r_a, r_b);
    precise float w = wn + (1.0 - wn) * nearness;
    acc += w * vec4(t_blur[b], t_blur[m + b], t_blur[2 * m + b], t_blur[3 * m + b]);
    acc_w += w;
    precise float v = near_box(fd);
    nacc += v * vec4(t_near[b], t_near[m + b], t_near[2 * m + b], t_near[3 * m + b]);
    nacc_a += v * t_near[4 * m + b];
    nacc_w += v;
  }
  const int mo = p.wo * p.ho, o = j * p.wo + i;
  precise vec4 res = acc / acc_w;
  for (int c = 0; c < 4; ++c) blur[c * mo + o] = res[c];
  precise float inv = 1.0 / max(nacc_w, 1e-5);
  precise vec4 n = nacc * inv;
  precise float na = nacc_a * inv;
  if (p.variant == kG3d) {
    // blur_weights.hpp g3d_coverage_curve: t = saturate(1 - 0.025/(fov·α)), α' = t²(3 - 2t).
    precise float fa = p.g3d_fov * na;
    precise float t = fa > 0.0 ? saturate(1.0 - 0.025 / fa) : 0.0;
    precise float a2 = min(t * t * (3.0 - 2.0 * t), 1.0);
    precise float g = na > 0.0 ? a2 / na : 0.0;
    n *= g;
    na = a2;
  }
  for (int c = 0; c < 4; ++c) near[c * mo + o] = n[c];
  near[4 * mo + o] = na;
}
