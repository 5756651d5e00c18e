// The largest near and far blur of a signed CoC map (r > 0 near, r < 0 far), which several
// methods need to size their kernels or buffers for the frame.
#pragma once
#include "dofkit/image.hpp"

namespace dofkit::core {

struct CocRange {
  float near_max = 0.0f;  ///< max(0, largest r), px
  float far_max = 0.0f;   ///< max(0, largest −r), px
};

/// Over the rectangle [x0, x0 + w) × [y0, y0 + h) of plane 0 of `coc` (finite values, as
/// render() guarantees). Rows in parallel blocks, lanes in SIMD; a maximum does not depend on
/// the order, so the result is the same for any thread count.
CocRange coc_range(const Image& coc, int x0, int y0, int w, int h);
inline CocRange coc_range(const Image& coc) { return coc_range(coc, 0, 0, coc.width(), coc.height()); }

/// The same for one row of n values, folded into near_max / far_max (which start at >= 0).
/// With `alpha` (n values, may be nullptr), only values whose alpha is > 0 count (layered's
/// transparent fragments).
void coc_row_range(const float* r, const float* alpha, int n, float& near_max, float& far_max);

}  // namespace dofkit::core
