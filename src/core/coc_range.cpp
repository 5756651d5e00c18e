#include "core/coc_range.hpp"

#include <algorithm>
#include <cstring>
#include <vector>

#include "core/parallel.hpp"

namespace dofkit::core {

// A named namespace, not an anonymous one: clang 14 gives the run-time dispatch resolvers of
// target_clones functions external names.
namespace coc_range_detail {

typedef float V8 __attribute__((vector_size(32)));

// Running maxima in 8 lanes, folded at the end (max of finite floats: any order gives the
// same value; only the sign of a zero maximum could differ, and no caller looks at it).
__attribute__((target_clones("avx512f", "avx2", "default")))
void row_range(const float* __restrict r, int n, float* far_max, float* near_max) {
  V8 f = V8{} + *far_max, m = V8{} + *near_max;
  int x = 0;
  for (; x + 8 <= n; x += 8) {
    V8 v;
    std::memcpy(&v, r + x, sizeof v);
    f = f < -v ? -v : f;
    m = m < v ? v : m;
  }
  float fs = *far_max, ms = *near_max;
  for (int k = 0; k < 8; ++k) {
    fs = std::max(fs, f[k]);
    ms = std::max(ms, m[k]);
  }
  for (; x < n; ++x) {
    fs = std::max(fs, -r[x]);
    ms = std::max(ms, r[x]);
  }
  *far_max = fs;
  *near_max = ms;
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
        coc_range_detail::row_range(coc.row(0, y) + x0, w, &part[bl].far_max, &part[bl].near_max);
  });
  CocRange out;
  for (const CocRange& p : part) {
    out.far_max = std::max(out.far_max, p.far_max);
    out.near_max = std::max(out.near_max, p.near_max);
  }
  return out;
}

}  // namespace dofkit::core
