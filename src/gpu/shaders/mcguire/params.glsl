// Per-frame constants of the mcguire passes (src/gpu/methods/mcguire.cpp fills them from
// mcguire::FrameSetup). std140 with scalars only: the C++ struct has the same layout.
layout(std140, binding = 0) uniform Params {
  int W, H;                           // frame size
  int src_x, src_y, src_w, src_h;     // rectangle the passes read (the packed buffer)
  int inner_x, inner_y, inner_w, inner_h;  // rectangle rendered
  int ox, oy, wo, ho;                 // inner origin in packed; reduced buffer size
  int variant;                        // 0 book, 1 demo, 2 g3d
  int f, r_max, far_occlusion;
  int double_coc, near_alpha_code, lowres_fix, identity;  // identity: r_max = 0, out = colour
  float r_near, inv_near, far_rescale, coverage_boost;
  float focus_px, g3d_fov, inv_rmax, rmax;
} p;

const int kBook = 0, kDemo = 1, kG3d = 2;
