// The fast pipeline: buffers from the workspace, then the passes of fast_*.cpp.
#include "methods/sterna/fast.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "core/parallel.hpp"

namespace dofkit::detail::sterna::fast {

namespace {

typedef float V8 __attribute__((vector_size(32)));

// Running maxima in 8 lanes, folded at the end (max of finite floats: any order, same value;
// only the sign of a zero maximum could differ, and choose_kernel() does not look at it).
STERNA_SIMD void row_range(const float* __restrict r, int n, float* far_max, float* near_max) {
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

}  // namespace

CocRange coc_range(const Image& coc) {
  // The kernel sizing scan of choose_kernel() (sterna.cpp), per block of rows in parallel;
  // the CoC map is finite (clamped), so max is exact and the block order does not matter.
  const int H = coc.height(), W = coc.width();
  constexpr int kRows = 16;
  const int blocks = (H + kRows - 1) / kRows;
  thread_local std::vector<CocRange> part_tls;
  std::vector<CocRange>& part = part_tls;
  part.assign(static_cast<std::size_t>(blocks), CocRange{});
  core::parallel_for(blocks, [&](int b0, int b1) {
    for (int bl = b0; bl < b1; ++bl)
      for (int y = bl * kRows; y < std::min(H, (bl + 1) * kRows); ++y)
        row_range(coc.row(0, y), W, &part[bl].far_max, &part[bl].near_max);
  });
  CocRange out;
  for (const CocRange& p : part) {
    out.far_max = std::max(out.far_max, p.far_max);
    out.near_max = std::max(out.near_max, p.near_max);
  }
  return out;
}

void render(const MethodContext& ctx, const Settings& s, Image& out) {
  Workspace& ws = ctx.workspace;
  Buffers b;
  b.W = ctx.frame.width();
  b.H = ctx.frame.height();
  b.w = (b.W + 1) / 2;
  b.h = (b.H + 1) / 2;
  // Border of the padded sources: the kernel reach (as gather.cpp) + 1 for the bilinear
  // neighbour + 32 so the last, partial 32-texel segment of a row (fast_gather.cpp) can read
  // whole vectors. Rounded
  // up to a multiple of 8 so frames whose kernel differs slightly keep the same allocation.
  float reach = 0.0f;
  for (const Offset& o : s.offsets) reach = std::max(reach, std::max(std::abs(o.x), std::abs(o.y)) * s.kernel_scale);
  b.pad = (static_cast<int>(std::ceil(reach)) + 34 + 7) / 8 * 8;
  const int pw = b.w + 2 * b.pad, ph = b.h + 2 * b.pad;
  b.near_src = &ws.image("sterna.near_src", pw, ph, 4);
  b.far_src = &ws.image("sterna.far_src", pw, ph, 5);
  b.near_h = &ws.image("sterna.near_h", b.w, b.h, 1);
  b.tmp = &ws.image("sterna.dilate_tmp", b.w, b.h, 1);
  b.near_blur = &ws.image("sterna.near_blur", b.w, b.h, 1);
  b.dof_near = &ws.image("sterna.dof_near", b.w, b.h, 4);
  b.dof_far = &ws.image("sterna.dof_far", b.w, b.h, 4);
  b.near_fill = &ws.image("sterna.near_fill", b.w, b.h, 4);
  b.far_fill = &ws.image("sterna.far_fill", b.w, b.h, 4);
  // Tile bits: per rendering thread, grown once.
  thread_local std::vector<std::uint8_t> tiles;
  b.tiles = &tiles;

  prepare(ctx, s, b);
  dilate(s, b);
  gather(s, b);
  fill(b);
  BlendRow blend;
  blend.init(ctx, s);
  out.resize(b.W, b.H, 4);
  composite(ctx, s, blend, b, out);
}

}  // namespace dofkit::detail::sterna::fast
