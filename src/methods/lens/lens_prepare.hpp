// Pass 1 of the fast form of `lens` (lens_fast.cpp), the prep: per fragment its depth slice
// and hat weight, the direct / exists / highlight flags, the slices' mean inverse depths and
// the rows and columns their members occupy, and the highlights by padded row. Inputs: the
// sources (colour, depth, layers), the slice plan and the options; output: Prep. Oracle:
// lens_plain.cpp's per-fragment classification (tests/lens compare the whole render).
#pragma once
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "methods/lens/lens.hpp"

namespace dofkit::detail::lens {

constexpr std::uint8_t kExists = 1, kDirect = 2, kHighlight = 4, kSmall = 8;
constexpr int kRowBlock = 16;  // prep rows per task

inline float inv_depth(float z) { return std::isinf(z) ? 0.0f : 1.0f / z; }

// Per fragment (f·n + pixel) what the passes need; the rest is recomputed from the inputs.
struct Prep {
  int w = 0, h = 0, nf = 1, k = 0;
  std::size_t n = 0;
  std::vector<std::int16_t> slice;
  std::vector<float> t;
  std::vector<std::uint8_t> flags;     // kExists, kDirect, kHighlight (direct, radius >= direct_px),
                                       // kSmall (direct, 0.5 < radius < direct_px, or hidden)
  std::vector<float> weight, trans;    // layers >= 1 only: index (f − 1)·n + i
  std::vector<float> inv_z;            // layer 0's inverse depth
  std::vector<int> row_hl, row_small;  // per frame row: highlights, small direct sources (every layer)
  float rho_max = 0.5f;
  int pad = 1;
  std::vector<double> mass, u_sum;
  // Per set and slice: rows and columns holding members, and whether any is scattered at the
  // slice's level (not direct).
  std::vector<int> ylo[2], yhi[2], xlo[2], xhi[2];
  std::vector<std::uint8_t> sliced[2];
  // Highlights per padded row y' in [−pad, h + pad): their padded x' and fragment index, in
  // order of x' (CSR: row y' at hl_start[y' + pad]).
  std::vector<int> hl_start, hl_x;
  std::vector<std::size_t> hl_q;
  std::vector<std::vector<double>> block_sums;  // mark_direct's scratch

  float weight_of(std::size_t q) const { return q < n ? 1.0f : weight[q - n]; }
  float trans_of(std::size_t q) const { return q < n ? 1.0f : trans[q - n]; }
};

void prepare(const Sources& src, const SlicePlan& plan, const LensOptions& opt, Prep& pr);

}  // namespace dofkit::detail::lens
