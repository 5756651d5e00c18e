// What the sterna gather shares between its files (impl=fast, fast_gather*.cpp): a tap's
// bilinear split, the texel and fold forms of the kernel (built in fast_gather_forms.cpp, used
// by the gather's FMA copies in fast_gather.cpp) and the per-texel far field of
// per_pixel_scale (fast_gather_per_texel.cpp). Oracle: gather.cpp (tests/sterna).
#pragma once
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "methods/sterna/fast.hpp"

namespace dofkit::detail::sterna::fast {

struct Tap {
  std::ptrdiff_t off;        // dy·pitch + dx, floats
  float w00, w10, w01, w11;  // bilinear weights (gather.cpp split())
  float fx, fy;              // fractional parts of the offset, [0, 1)
};

// gather.cpp's split(): integer part and bilinear weights of an offset.
inline Tap split(float ox, float oy, int pitch) {
  const float fx0 = std::floor(ox), fy0 = std::floor(oy);
  const float fx = ox - fx0, fy = oy - fy0;
  return {static_cast<std::ptrdiff_t>(fy0) * pitch + static_cast<std::ptrdiff_t>(fx0),
          (1 - fx) * (1 - fy),
          fx * (1 - fy),
          (1 - fx) * fy,
          fx * fy,
          fx,
          fy};
}

// The texel form of the kernel (FMA copies): a texel both rows of a pair read, with its
// weight for the first (even) row and for the second; a texel only one of them reads.
struct TexelPair {
  std::ptrdiff_t off;  // s·pitch + dx from the pair's first row
  float w0, w1;
};
struct Texel {
  std::ptrdiff_t off;
  float w;
};
struct TexelKernel {
  std::vector<TexelPair> both;
  std::vector<Texel> only0, only1;
};

// Builds the texel form of the taps (offsets already scaled): each texel's weight rounded once
// from texel_sums.
void build_texel_kernel(const std::vector<std::pair<float, float>>& offsets, int pitch, TexelKernel& k);

// The fold form (AVX-512 copy), the usual case there. Sterna's rings (and every kernel symmetric
// about the horizontal axis: anamorphic, even polygons without rotation) give texel weights
// with K(dx, s) = K(dx, −s) bit for bit, so the gather of row y is
//   Σ_{e ≥ 0} Σ_dx K(dx, e)·V_e(x + dx),   V_0 = src(·, y),  V_e = src(·, y + e) + src(·, y − e),
// where the rows V_e of output row y serve all the taps of that row: one add per distance e and
// texel (~15 at the bench frame's scale 2.4) halves the FMAs, from one per texel of the kernel
// (181 there) to one per (dx, e) pair (91, plus 12 texels whose mirror is missing or differs:
// the taps at 90° and 180° have offsets of ±1e-16 instead of 0, which touch a neighbour texel
// with a weight ~1e-16; they stay single texels, read from the plane). So the gather is ~120
// FP operations per output vector, against ~135 FMAs + ~110 adds in the separable form.
// It walks the frame row by row (the other forms walk column strips): each source row is read
// from L3 once per plane as a stream and then from L2 by the 31 output rows that use it, where
// the column walks wait on every row's first line (a 4 kB stride defeats the hardware
// prefetchers). 16-lane vectors: an AVX2 copy of it (8 lanes, 2 rows of 32 texels per pass)
// ran 10 % slower than the separable form there (gather CPU 32.3 against 29.4 ms per 1080p
// frame, same AVX-512 machine, AVX2 code), so the AVX2 copy keeps the strip forms. Same real-number sum as gather.cpp,
// rounded differently (each weight rounded once from its double sum, one rounding per V add and per FMA), in the same
// order for every row: pairs by (e, dx), then the single texels by (s, dx).
struct FoldTerm {
  std::int32_t off;  // pairs: V-buffer offset e_index·vstride + dx − bx; single texels: s·pitch + dx
  float w;
};
struct FoldKernel {
  bool ok = false;        // the fold form needs fewer operations than the texel form
  std::vector<int> e;     // the distinct e ≥ 0 of the pairs, ascending
  std::vector<int> e_of;  // per pair: its e
  std::vector<FoldTerm> pairs, single;
  std::vector<int> e_slot;  // for e = 0 … max e: its index in `e`, or −1
  int bx = 0;               // first buffer column, relative to the chunk (a multiple of 16, ≤ dx_min)
  int vstride = 0;          // floats per V row in the buffer
  int vspan = 0;            // dx_max − bx: V columns beyond a chunk's own texels that its pairs read
};

// The fold kernel for output chunks of cw texels (offsets already scaled).
void build_fold_kernel(const std::vector<std::pair<float, float>>& offsets, int pitch, int cw, FoldKernel& k);

// per_pixel_scale's far field, gathered per texel into b.dof_far (fast_gather_per_texel.cpp).
void far_per_texel(const Settings& s, Buffers& b);

}  // namespace dofkit::detail::sterna::fast
