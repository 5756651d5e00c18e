// The fast pipeline: buffers from the workspace, then the passes of fast_*.cpp.
#include "methods/sterna/fast.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "core/parallel.hpp"
#include "core/pass_profile.hpp"

namespace dofkit::detail::sterna::fast {

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
  // The gather's fold form sums chunks of up to 128 texels, at x = 0 in a row narrower than
  // that: the border must then hold the rest of the chunk and its reach.
  if (b.w < 128) b.pad = std::max(b.pad, (128 + static_cast<int>(std::ceil(reach)) + 18 - b.w + 7) / 8 * 8);
  // Row stride. The gather reads, per tap, the same columns of up to five consecutive rows
  // (fast_gather.cpp), and the rows of its tap window must not crowd into a few sets of the
  // 8-way, 64-set L1 (sets repeat every 4 KiB). At 3840×2160 the half-res row plus borders
  // came to exactly 2048 floats = 2 × 4 KiB, so every row of the window fell into the same
  // sets and the four-row gather ran 20 % slower than the two-row one. Widen the border (in
  // steps of 8 texels, 32 bytes) until a row starts at least two 64-byte lines away from a
  // multiple of 4 KiB (either way): five consecutive rows, two lines each, then lie in
  // distinct sets, and the window spreads over at least half of them.
  for (int i = 0; i < 64; ++i) {
    const long m = static_cast<long>(b.w + 2 * b.pad) * 4 % 4096;
    if (m >= 128 && m <= 4096 - 128) break;
    b.pad += 8;
  }
  const int pw = b.w + 2 * b.pad, ph = b.h + 2 * b.pad;
  b.near_src = &ws.image("sterna.near_src", pw, ph, 4);
  b.far_src = &ws.image("sterna.far_src", pw, ph, 5);
  b.near_h = &ws.image("sterna.near_h", b.w, b.h, 1);
  b.tmp = &ws.image("sterna.dilate_tmp", b.w, b.h, 1);
  b.near_blur = &ws.image("sterna.near_blur", b.w, b.h, 1);
  b.dof_near = &ws.image("sterna.dof_near", b.w, b.h, 4);
  b.dof_far = &ws.image("sterna.dof_far", b.w, b.h, 4);
  // Tile bits: per rendering thread, grown once.
  thread_local std::vector<std::uint8_t> tiles;
  b.tiles = &tiles;
  thread_local std::vector<Buffers::AlphaRow> alpha_rows;
  alpha_rows.resize(static_cast<std::size_t>(b.h));
  b.alpha_rows = &alpha_rows;

  // The downsample reads every colour sample: it also makes render()'s sanitation check
  // when render() left it to the method (nothing before it depends on colour values).
  bool clean;
  {
    core::PassScope pass("prepare");
    clean = prepare(ctx, s, b);
  }
  if (!clean) {
    ctx.colour_dirty->store(true);
    return;
  }
  {
    core::PassScope pass("dilate");
    dilate(s, b);
  }
  {
    core::PassScope pass("gather");
    gather(s, b);
  }
  // (P8, the fill, runs inside the composite, row by row.)
  BlendRow blend;
  blend.init(ctx, s);
  out.resize(b.W, b.H, 4);
  core::PassScope pass("fill + composite");
  composite(ctx, s, blend, b, out);
}

}  // namespace dofkit::detail::sterna::fast
