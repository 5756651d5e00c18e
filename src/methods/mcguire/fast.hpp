// Fast passes of the McGuire method (impl=fast): fast.cpp (P2/P3 for book/demo),
// fast_composite.cpp (P4). Each computes what its plain counterpart in blur.cpp /
// composite.cpp computes, within float rounding (tests/mcguire: FastPathMatchesPlain).
#pragma once
#include "methods/mcguire/mcguire.hpp"
#include "methods/method.hpp"

namespace dofkit::detail::mcguire {

/// Whether blur_horizontal_fast / blur_vertical_fast handle this variant (book, demo).
bool fast_supported(const Constants& k);

/// P2 as blur_horizontal_plain (book/demo only) on the buffer pack_coc(colour, coc, src)
/// would produce, read straight from colour and CoC (s computed as pack_coc does, so the
/// packed copy is never written); scratch per thread (grown once and reused by later calls,
/// so it stays in the core's cache; `ws` is not used). colour_dirty set: every colour sample
/// of `src` is also tested as its row is read (render/sanitize.hpp) and the flag is set if
/// one fails (see MethodContext::colour_dirty); the outputs are then meaningless.
/// near_span (2·src.h ints, if given): per t_near row y, the outputs [near_span[2y],
/// near_span[2y + 1]] outside which the row is +0 (lo > hi: all of it), for P3.
void blur_horizontal_fast(const Image& colour, const Image& coc, const Rect& src, const Constants& k, int ox, int wo,
                          Image& t_blur, Image& t_near, Workspace& ws, std::atomic<bool>* colour_dirty = nullptr,
                          int* near_span = nullptr);
/// P3 as blur_vertical_plain (book/demo only); scratch from `ws`. near_span: as written by
/// blur_horizontal_fast for this t_near (its near sums then skip the columns that are +0
/// in every row they read), or null (every column).
void blur_vertical_fast(const Image& t_blur, const Image& t_near, const Constants& k, int oy, int ho, Image& blur,
                        Image& near, Workspace& ws, const int* near_span = nullptr);
/// P4 as composite() (every variant), row-organised and vectorisable; no weights output.
/// Reads the sharp colour and s from colour/CoC like blur_horizontal_fast (packed pixel
/// (x, y) = source pixel (src.x + x, src.y + y)).
void composite_fast(const Image& colour, const Image& coc, const Rect& src, int ox, int oy, const Image& blur,
                    const Image& near, const Constants& k, const Rect& inner, Image& out, Workspace& ws);

}  // namespace dofkit::detail::mcguire
