#version 450
// P7 of sterna (src/methods/sterna/gather.cpp): the 49-tap ring gather of the near field
// (plain mean of colour_h, where nearBlur_h > 0; else colour_h) and the far field
// (Σ colourFar_h / Σ far_h, where far_h > 0; else 0), bilinear taps clamped to the edge, in
// the CPU's tap order and bilinear split. per_pixel_scale: the far offsets are scaled by the
// texel's own far factor (the CPU's per-texel bilinear). Weights by hand, no sampler.
#include "dofkit.glsl"
#include "params.glsl"
DOFKIT_LOCAL_2D

layout(std430, binding = 1) readonly buffer ColH { float col_h[]; };   // 4 planes w × h
layout(std430, binding = 2) readonly buffer FarH { float far_h[]; };   // 4 planes w × h
layout(std430, binding = 3) readonly buffer CocH { float coc_h[]; };   // 2 planes w × h
layout(std430, binding = 4) readonly buffer NearB { float nblur[]; };  // w × h
layout(std430, binding = 5) readonly buffer Offsets { float offs[]; };  // 2 × 49: x, y (half-res px)
layout(std430, binding = 6) writeonly buffer DofNear { float dof_near[]; };  // 4 planes w × h
layout(std430, binding = 7) writeonly buffer DofFar { float dof_far[]; };    // 4 planes w × h

int m;
// Texel (x, y) of plane c of colour_h (c < 4) or the far source (c < 4: colourFar_h, 4: far_h).
float near_at(int c, int x, int y) { return col_h[c * m + clampi(y, 0, p.h - 1) * p.w + clampi(x, 0, p.w - 1)]; }
float far_at(int c, int x, int y) {
  const int q = clampi(y, 0, p.h - 1) * p.w + clampi(x, 0, p.w - 1);
  return c < 4 ? far_h[c * m + q] : coc_h[m + q];
}

void main() {
  const int x = int(gl_GlobalInvocationID.x), y = int(gl_GlobalInvocationID.y);
  if (x >= p.w || y >= p.h) return;
  m = p.w * p.h;
  const int o = y * p.w + x;
  if (nblur[o] > 0.0) {
    precise vec4 acc = vec4(0.0);
    for (int k = 0; k < p.ntaps; ++k) {
      precise float ox = offs[2 * k] * p.ks, oy = offs[2 * k + 1] * p.ks;
      const float fx0 = floor(ox), fy0 = floor(oy);
      precise float fx = ox - fx0, fy = oy - fy0;
      precise float w00 = (1.0 - fx) * (1.0 - fy), w10 = fx * (1.0 - fy), w01 = (1.0 - fx) * fy, w11 = fx * fy;
      const int dx = int(fx0), dy = int(fy0);
      for (int c = 0; c < 4; ++c) {
        precise float t = w00 * near_at(c, x + dx, y + dy) + w10 * near_at(c, x + dx + 1, y + dy) +
                          w01 * near_at(c, x + dx, y + dy + 1) + w11 * near_at(c, x + dx + 1, y + dy + 1);
        acc[c] += t;
      }
    }
    precise vec4 r = acc * p.inv_taps;
    for (int c = 0; c < 4; ++c) dof_near[c * m + o] = r[c];
  } else {
    for (int c = 0; c < 4; ++c) dof_near[c * m + o] = col_h[c * m + o];
  }
  const float fr = coc_h[m + o];
  if (!(fr > 0.0)) {
    for (int c = 0; c < 4; ++c) dof_far[c * m + o] = 0.0;
    return;
  }
  precise float acc[5] = float[5](0.0, 0.0, 0.0, 0.0, 0.0);
  if (p.per_pixel == 0) {
    for (int k = 0; k < p.ntaps; ++k) {
      precise float ox = offs[2 * k] * p.ks, oy = offs[2 * k + 1] * p.ks;
      const float fx0 = floor(ox), fy0 = floor(oy);
      precise float fx = ox - fx0, fy = oy - fy0;
      precise float w00 = (1.0 - fx) * (1.0 - fy), w10 = fx * (1.0 - fy), w01 = (1.0 - fx) * fy, w11 = fx * fy;
      const int dx = int(fx0), dy = int(fy0);
      for (int c = 0; c < 5; ++c) {
        precise float t = w00 * far_at(c, x + dx, y + dy) + w10 * far_at(c, x + dx + 1, y + dy) +
                          w01 * far_at(c, x + dx, y + dy + 1) + w11 * far_at(c, x + dx + 1, y + dy + 1);
        acc[c] += t;
      }
    }
    precise float inv = div_rn(1.0, acc[4]);
    for (int c = 0; c < 4; ++c) {
      precise float v = acc[c] * inv;
      dof_far[c * m + o] = v;
    }
  } else {
    precise float sc = p.ks * fr;
    const float cx = float(x) + 0.5, cy = float(y) + 0.5;
    for (int k = 0; k < p.ntaps; ++k) {
      precise float px = cx + offs[2 * k] * sc, py = cy + offs[2 * k + 1] * sc;
      precise float fx = px - 0.5, fy = py - 0.5;
      const float x0 = floor(fx), y0 = floor(fy);
      precise float tx = fx - x0, ty = fy - y0;
      const int ix = int(x0), iy = int(y0);
      for (int c = 0; c < 5; ++c) {
        precise float t = (1.0 - ty) * ((1.0 - tx) * far_at(c, ix, iy) + tx * far_at(c, ix + 1, iy)) +
                          ty * ((1.0 - tx) * far_at(c, ix, iy + 1) + tx * far_at(c, ix + 1, iy + 1));
        acc[c] += t;
      }
    }
    for (int c = 0; c < 4; ++c) dof_far[c * m + o] = div_rn(acc[c], acc[4]);
  }
}
