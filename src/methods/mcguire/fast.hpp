// Fast passes of the McGuire method (impl=fast): fast.cpp (P2/P3 for book/demo),
// fast_composite.cpp (P4). Each computes what its plain counterpart in blur.cpp /
// composite.cpp computes, within float rounding (tests/mcguire: FastPathMatchesPlain).
#pragma once
#include "methods/mcguire/mcguire.hpp"
#include "methods/method.hpp"

namespace dofkit::detail::mcguire {

/// Whether blur_horizontal_fast / blur_vertical_fast handle this variant (book, demo).
bool fast_supported(const Constants& k);

/// P2 as blur_horizontal_plain (book/demo only); scratch from `ws`.
void blur_horizontal_fast(const Image& packed, const Constants& k, int ox, int wo, Image& t_blur, Image& t_near,
                          Workspace& ws);
/// P3 as blur_vertical_plain (book/demo only); scratch from `ws`.
void blur_vertical_fast(const Image& t_blur, const Image& t_near, const Constants& k, int oy, int ho, Image& blur,
                        Image& near, Workspace& ws);
/// P4 as composite() (every variant), row-organised and vectorisable; no weights output.
void composite_fast(const Image& packed, int ox, int oy, const Image& blur, const Image& near, const Constants& k,
                    const Rect& inner, Image& out, Workspace& ws);

}  // namespace dofkit::detail::mcguire
