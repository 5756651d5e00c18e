#include "core/coc_range.hpp"

#include <algorithm>
#include <cstring>
#include <vector>

#include "core/clones.hpp"
#include "core/parallel.hpp"

namespace dofkit::core {

namespace coc_range_detail {

typedef float V8 __attribute__((vector_size(32)));

// Running maxima in 8 lanes, folded at the end (max of finite floats: any order gives the
// same value; only the sign of a zero maximum could differ, and no caller looks at it).
// With `alpha`, a value whose alpha is not > 0 counts as 0 (a select, so the loop stays
// branch-free; the mask test is hoisted out of the loop by the template parameter).
template <bool kMasked>
__attribute__((always_inline)) inline void row_range_t(const float* __restrict r, const float* __restrict alpha, int n,
                                                       float* far_max, float* near_max) {
  V8 f = V8{} + *far_max, m = V8{} + *near_max;
  int x = 0;
  for (; x + 8 <= n; x += 8) {
    V8 v;
    std::memcpy(&v, r + x, sizeof v);
    if (kMasked) {
      V8 a;
      std::memcpy(&a, alpha + x, sizeof a);
      v = a > V8{} ? v : V8{};
    }
    f = f < -v ? -v : f;
    m = m < v ? v : m;
  }
  float fs = *far_max, ms = *near_max;
  for (int k = 0; k < 8; ++k) {
    fs = std::max(fs, f[k]);
    ms = std::max(ms, m[k]);
  }
  for (; x < n; ++x) {
    const float v = !kMasked || alpha[x] > 0 ? r[x] : 0.0f;
    fs = std::max(fs, -v);
    ms = std::max(ms, v);
  }
  *far_max = fs;
  *near_max = ms;
}

DOFKIT_CLONES
void row_range(const float* __restrict r, const float* __restrict alpha, int n, float* far_max, float* near_max) {
  if (alpha)
    row_range_t<true>(r, alpha, n, far_max, near_max);
  else
    row_range_t<false>(r, nullptr, n, far_max, near_max);
}

}  // namespace coc_range_detail

CocRange coc_range(const Image& coc, int x0, int y0, int w, int h) {
  constexpr int kRows = 16;
  const int blocks = (h + kRows - 1) / kRows;
  thread_local std::vector<CocRange> part_tls;  // kept between frames: no allocation per frame
  std::vector<CocRange>& part = part_tls;
  part.assign(static_cast<std::size_t>(blocks), CocRange{});
  core::parallel_for(blocks, [&](int b0, int b1) {
    for (int bl = b0; bl < b1; ++bl)
      for (int y = y0 + bl * kRows; y < y0 + std::min(h, (bl + 1) * kRows); ++y)
        coc_range_detail::row_range(coc.row(0, y) + x0, nullptr, w, &part[bl].far_max, &part[bl].near_max);
  });
  CocRange out;
  for (const CocRange& p : part) {
    out.far_max = std::max(out.far_max, p.far_max);
    out.near_max = std::max(out.near_max, p.near_max);
  }
  return out;
}

void coc_row_range(const float* r, const float* alpha, int n, float& near_max, float& far_max) {
  coc_range_detail::row_range(r, alpha, n, &far_max, &near_max);
}

}  // namespace dofkit::core
