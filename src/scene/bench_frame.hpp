// The synthetic frame `dofkit bench` times, shared with the profiling harnesses in the tests
// so that they measure exactly what the bench reports.
#pragma once
#include "dofkit/coc.hpp"
#include "dofkit/frame.hpp"

namespace dofkit::scene {

/// Textured colour (with a sparse grid of HDR fireflies of radiance 40) and a depth layout
/// with a realistic CoC spread: a far wall receding to +inf at the top, an in-focus subject
/// in the middle, a ground plane from near to far along the bottom and a near bar on the left.
Frame bench_frame(int width, int height);

/// The camera the bench uses with that frame: focus 4 m, K = 1.5 % of the width, CoC clamp
/// 3 % of the width (57.6 px at 1920 wide), radii given at the frame's own width.
CameraModel bench_camera(int width);

}  // namespace dofkit::scene
