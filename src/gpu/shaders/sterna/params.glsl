// Per-frame constants of the sterna passes (src/gpu/methods/sterna.cpp fills them from
// sterna::read_settings). std140, scalars only.
layout(std140, binding = 0) uniform Params {
  int W, H, w, h;  // full-res and half-res size
  int native, per_pixel, bicubic, karis;
  int r, axis, ntaps, pad0;  // dilation radius; axis of the max pass; taps (49)
  float ramp, nb, ne, fb;    // blend ramp (px); NearFarBlend planes (native)
  float fe, ks, blend, radius_per_far_fill;
  float radius_per_far_comp, inv_taps, pad1, pad2;
} p;
