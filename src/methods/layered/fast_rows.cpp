// ZeroMap measurement for the reduced accumulators (fast_rows.hpp).
#include "methods/layered/fast_rows.hpp"

#include <atomic>

#include "core/parallel.hpp"

namespace dofkit::detail::layered {

namespace {
// Blocks build_zero_map has marked tiny (code 2), for the tests (tiny_block_count).
std::atomic<std::uint64_t> g_tiny_blocks{0};

}  // namespace

ZeroMap build_zero_map(const Image& img, int factor, int fw, std::uint8_t* nz) {
  ZeroMap z;
  z.nz = nz;
  z.nb = (fw + kBlock - 1) / kBlock;
  z.ch = img.height();
  z.factor = factor;
  const int cw = img.width(), nb = z.nb;
  // Code 2 (tiny) only where the exact multiplies pay (core::exact_tiny_multiplies); elsewhere
  // such blocks are 1 and take the float kernels: the same bits.
  const bool exact = core::exact_tiny_multiplies();
  core::parallel_for(
      img.height(),
      [&](int y0, int y1) {
        std::uint64_t tiny_blocks = 0;
        for (int y = y0; y < y1; ++y)
          for (int b = 0; b < nb; ++b) {
            const int x0 = b * kBlock, n = std::min(kBlock, fw - x0);
            const int lo = std::max(0, x0 / factor - 1), hi = std::min(cw - 1, (x0 + n - 1) / factor + 1);
            bool any = false;
            for (int c = 0; c < 4 && !any; ++c) {
              const float* r = img.row(c, y);
              // A dense accumulator is settled by its first sample; a sparse one needs the scan.
              any = kern::any_bits(r + lo, 1) || kern::any_bits(r + lo, hi - lo + 1);
            }
            bool tiny = false;
            for (int c = 0; c < 4 && any && exact && !tiny; ++c) tiny = kern::any_tiny(img.row(c, y) + lo, hi - lo + 1);
            nz[static_cast<std::size_t>(y) * nb + b] = tiny ? 2 : (any ? 1 : 0);
            tiny_blocks += tiny ? 1 : 0;
          }
        if (tiny_blocks) g_tiny_blocks.fetch_add(tiny_blocks, std::memory_order_relaxed);
      },
      8);
  return z;
}

std::uint64_t tiny_block_count() { return g_tiny_blocks.load(); }

}  // namespace dofkit::detail::layered
