// Per-frame constants of the starcraft passes (src/gpu/methods/starcraft.cpp fills them from
// starcraft::make_geometry). std140, scalars only.
layout(std140, binding = 0) uniform Params {
  int W, H, lw, lh;  // full-res and quarter-res size
  int native, keep_own, reduce_max, pad0;
  float vs, vm, vl, focus;          // level breakpoints in v = r² − 0.25; native: focus F (m)
  float full_range, range, amount, pad1;  // native: R_full, R_none − R_full, α
} p;

const int kDown = 4;
