// The memory budget (see budget.hpp).
#include "budget.hpp"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <fstream>
#include <string>

#include "dofkit/error.hpp"
#include "dofkit/ranges.hpp"

namespace dofkit::cli {

namespace {

std::atomic<std::uint64_t> g_budget{0};  // 0 = the default

constexpr std::uint64_t kMiB = 1u << 20;
// The process before any image: code, libraries, thread stacks touched, and OpenImageIO's
// module when a file needs it (peak RSS of an 8x8 render: 9 MiB; 134 MiB with the module).
constexpr std::uint64_t kProcessBytes = 160 * kMiB;

// The cgroup (v2, else v1) memory limit of this process, 0 if none is set.
std::uint64_t cgroup_limit() {
  for (const char* path : {"/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"}) {
    std::ifstream f(path);
    std::string v;
    if (f >> v && !v.empty() && v != "max") {
      try {
        const unsigned long long n = std::stoull(v);
        if (n > 0 && n < (1ull << 60)) return n;
      } catch (const std::exception&) {
      }
    }
  }
  return 0;
}

}  // namespace

std::uint64_t default_memory_budget_bytes() {
  const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGE_SIZE);
  std::uint64_t ram = pages > 0 && page > 0 ? static_cast<std::uint64_t>(pages) * static_cast<std::uint64_t>(page)
                                            : std::uint64_t{4} << 30;
  if (const std::uint64_t limit = cgroup_limit(); limit > 0) ram = std::min(ram, limit);
  return ram / 4 * 3;
}

void set_memory_budget_mib(long long mib) {
  if (mib == 0) {
    g_budget.store(0);
    return;
  }
  check_number("--max-memory", static_cast<double>(mib));
  g_budget.store(static_cast<std::uint64_t>(mib) * kMiB);
}

std::uint64_t memory_budget_bytes() {
  const std::uint64_t b = g_budget.load();
  return b ? b : default_memory_budget_bytes();
}

std::string mib_text(std::uint64_t bytes) { return std::to_string((bytes + kMiB - 1) / kMiB) + " MiB"; }

void check_memory(std::uint64_t estimate, const std::string& what, const std::string& hint) {
  const std::uint64_t budget = memory_budget_bytes();
  if (estimate <= budget) return;
  throw_bad_input(what + " needs about " + mib_text(estimate) + " of memory, more than the limit of " +
                  mib_text(budget) + " (--max-memory" + (g_budget.load() ? "" : ", by default 3/4 of this machine's") +
                  "); " + hint);
}

std::uint64_t render_frame_bytes(const RenderSettings& settings, const FrameShape& s, bool sequence) {
  const double px = static_cast<double>(s.width) * s.height;
  // Decoded inputs: colour RGBA float, depth, each kept layer's RGBA + z, mask + mask depth,
  // the channels passed through to an EXR output (at most 4 bytes a sample).
  const double inputs = px * (16 + 4 + 20.0 * s.layers + (s.mask ? 8 : 0) + 4.0 * s.passthrough_channels);
  // While a file is read: a reader's interleaved float buffer and its own decoded samples; a
  // layered EXR's every channel twice (OpenImageIO's buffer and dofkit's); a deep file's
  // samples as stored and as float, and its per-pixel tables.
  const double reading = std::max(px * 32, px * 8.0 * s.layer_file_channels) +
                         static_cast<double>(s.deep_sample_bytes) * 3 + (s.deep_sample_bytes ? px * 16 : 0);
  // Writing: the interleaved (and quantised) copy of the result and the encoder's buffers.
  const double writing = px * 32;
  const double render = static_cast<double>(render_memory_bytes(settings, s.width, s.height, s.layers));
  // --frames reads the next frame while this one renders: two frames of inputs (and a read's
  // buffers) at once.
  const double frames = sequence ? 2 : 1;
  const double total =
      kProcessBytes + frames * inputs + (sequence ? reading : 0.0) + std::max(reading, render + writing);
  return total > 1.8e19 ? ~std::uint64_t{0} : static_cast<std::uint64_t>(total);
}

std::uint64_t scene_bytes(int width, int height, int layers) {
  const double px = static_cast<double>(width) * height;
  // Pinhole colour + depth, its layers, the ground truth (RGBA float) and the ray tracer's
  // per-pixel accumulators, then the EXR writer's buffers for the largest file (the layers).
  const double total = kProcessBytes + px * (20 + 20.0 * layers + 16 + 32) + px * 20.0 * std::max(layers, 1);
  return total > 1.8e19 ? ~std::uint64_t{0} : static_cast<std::uint64_t>(total);
}

}  // namespace dofkit::cli
