// The fused stack's layer generator (render_gaussian_fused, one fragment per pixel): layer k
// produced row block by row block from the per-pixel codes of the code pass (fused_code.cpp)
// instead of being stored — the matte of matting.cpp and, at hole pixels, the push-pull fill
// of inpaint.cpp (the oracles: matte_layer / push_pull_fill; tests/layered compare the fused
// stack with impl=plain bit for bit) — and the pull of its push-pull level 1 (fused_pull.cpp).
#pragma once
#include <cstdint>
#include <utility>

#include "dofkit/image.hpp"
#include "methods/layered/fast_rows.hpp"

namespace dofkit::detail::layered {

constexpr unsigned kNoLayer = 31;

// Layer k of the single-fragment input, produced row block by row block from the per-pixel
// codes (the only layers with a non-zero matte, see render_gaussian_fused) instead of being
// stored: the matte of matting.cpp and, at hole pixels, the push-pull fill of inpaint.cpp.
struct FusedLayer {
  const Image* color = nullptr;
  const float* w0 = nullptr;            // matte in the pixel's first layer j0
  const std::uint16_t* code = nullptr;  // j0 | (second layer j0 + 1 at weight 1) << 5 | hk << 6
  int w = 0, h = 0, k = 0;
  bool fill = false;          // fill the holes (k >= hk)
  const Image* l1 = nullptr;  // pushed pyramid level 1 (null: 1×1 image, fill = self)
  bool opaque = false, under = false;
  // Per row block of kBlock pixels (row y, block x0 / kBlock): the layers any pixel has a
  // non-zero matte in, and the smallest / largest hk (hole from layer hk on) in the block.
  const std::uint32_t* bpres = nullptr;
  const std::uint32_t* bhk = nullptr;
  // Per row block and layer j < 16 (index 16·block + j), for the layers in bpres only: the
  // span lo | hi << 16 of columns (relative to the block) outside which layer j's matte is
  // zero (block_spans).
  const std::uint32_t* bspan = nullptr;
  // Per row block and layer j < 16 (index 16·block + j), for the j with hmin <= j < hmax
  // (bhk) only: the span lo | hi << 16 of columns (relative to the block) outside which no
  // pixel is a hole of layer j (hole_spans; it holds at least one).
  const std::uint32_t* bhole = nullptr;
  int nb = 0;

  enum Cls { kGeneral, kEmptyKnown, kEmptyHole };
  // kEmptyKnown: the layer is 0 and no pixel is a hole in this block; kEmptyHole: 0 and every
  // pixel is a hole. (Their values are exactly what the general code computes there.)
  Cls cls(int y, int x0) const {
    const std::size_t i = static_cast<std::size_t>(y) * nb + x0 / kBlock;
    if ((bpres[i] >> k) & 1u) return kGeneral;
    const int hmin = static_cast<int>(bhk[i] & 255u), hmax = static_cast<int>(bhk[i] >> 8);
    if (k < hmin) return kEmptyKnown;
    if (k >= hmax) return kEmptyHole;
    return kGeneral;
  }

  // The span matte() returns for row y, block x0, without computing the values.
  std::pair<int, int> span(int y, int x0, int n) const {
    const std::size_t bi = static_cast<std::size_t>(y) * nb + x0 / kBlock;
    if (!((bpres[bi] >> k) & 1u)) return {n, 0};
    const std::uint32_t sp = bspan[16 * bi + static_cast<std::size_t>(k)];
    return {static_cast<int>(sp & 0xffffu), static_cast<int>(sp >> 16)};
  }
  // matting.cpp's values of row y, columns [x0, x0 + n); hole flags into hb if non-null.
  // Returns the span [lo, hi) (relative to x0; lo >= hi if empty) outside which the values
  // are +0.
  //
  // Why only the span is evaluated: matte_row gives 0 + t·I with t = w_k, and w_k is non-zero
  // only at pixels whose code names layer k (j0 = k, or j0 + 1 = k with the second-layer
  // bit): the code pass stores every other layer's matte as exactly 0 (see
  // render_gaussian_fused). Elsewhere t = 0 and I is finite (checked before this pass), so
  // 0·I = ±0 and 0 + (±0) = +0: the +0 written outside the span is bit for bit what
  // matte_row computes there. Every pixel whose code names k lies in the span (block_spans:
  // the chunk masks cover all columns), so no non-zero value lies outside; a layer not in
  // bpres has no such pixel in the block.
  // With zero_outside false, o outside the span is left as it was (the caller fills what it
  // reads there).
  std::pair<int, int> matte(int y, int x0, int n, float (*o)[kBlock], std::uint8_t* hb, bool zero_outside = true) const;
  // The layer with its holes filled.
  //
  // The fill (fill_row, or finish_fill for a 1×1 image) changes hole pixels only and leaves
  // every other pixel's matte value as it is, so it runs on the block's hole span [a0, a1)
  // only (bhole: every hole pixel of layer k lies in it), and the hole flags are needed
  // (hole_row) only there: the columns outside hold no hole and keep the matte's values,
  // what the fill over the whole block leaves there.
  void get(int y, int x0, int n, float (*o)[kBlock], HCache* cache = nullptr) const;
};

// Pyramid level 1 of the layer (pull_level's arithmetic, children from the generator): coarse
// row yc. r / hb: scratch for two fine rows.
//
// skip_hole_values: a block of four holes gets its confidences (0) but not its values (+0):
// only for a level the push then runs over (a pyramid above level 1), which writes +0 + up
// wherever w = 0 without reading v (push_rows4_simd); before it, v is read where w = 0 only by
// the pull of level 2, which skips such children (their products are masked to +0), so no
// value depends on what v held there. Saves 4 of the 5 plane fills of such blocks.
void pull_row(const FusedLayer& L, int yc, Image& cv, Image& cwt, float (*r)[4][kBlock], std::uint8_t (*hb)[kBlock],
              bool skip_hole_values = false);

// Pyramid level 1 of the layer (cv, cwt) and, if cv2 is non-null, level 2 from it (cv2,
// cwt2): row y of level 2 right after the level-1 rows 2y, 2y + 1 it reads, while they are
// in cache (pull_upper_row; the values do not depend on when a row is pulled).
void pull_from_layer(const FusedLayer& L, Image& cv, Image& cwt, Image* cv2, Image* cwt2);

// The spans of FusedLayer::bspan for one row block of n <= kBlock pixels, from its chunk
// masks (kern::code_summary): for each layer k named in the block, [lo, hi) from the start
// of the first to the end of the last 16-pixel chunk naming k. Every pixel whose code names k
// lies in one of those chunks, so in the span (it may also hold pixels that do not: their
// matte is computed, and is 0, as before).
void block_spans(const std::uint32_t* cm, int n, std::uint32_t* span);

// FusedLayer::bhole for one row block of n <= kBlock pixels, from the smallest hk of each
// 16-pixel chunk (kern::code_summary), for the layers k in [hmin, min(hmax, 16)) only (the
// block's smallest / largest hk: below, no pixel is a hole, from hmax on every pixel is, and
// FusedLayer decides those from bhk without reading bhole): [lo, hi) from the start of the
// first to the end of the last chunk with a pixel of hk <= k (a hole of layer k). Every hole
// pixel of k lies in such a chunk, so in the span, and at least one chunk (one holding hk =
// hmin) qualifies. The first chunk for k comes no later than for k − 1 (more chunks
// qualify), so one pass in each direction sets each layer once: a chunk sets the layers from
// its own smallest hk up to (not including) the smallest hk of the chunks before it.
void hole_spans(const std::uint32_t* ch, int n, std::uint32_t hk, std::uint32_t* span);

}  // namespace dofkit::detail::layered
