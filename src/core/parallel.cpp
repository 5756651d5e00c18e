#include "core/parallel.hpp"

#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>
#include <unistd.h>

#include <optional>

namespace dofkit::core {

void parallel_for(int n, const std::function<void(int, int)>& body, int grain) {
  if (n <= 0) return;
  if (grain < 1) grain = 1;
  if (n <= grain) {
    body(0, n);
    return;
  }
  tbb::parallel_for(tbb::blocked_range<int>(0, n, grain),
                    [&](const tbb::blocked_range<int>& r) { body(r.begin(), r.end()); });
}

void with_threads(int threads, const std::function<void()>& fn) {
  if (threads <= 0) {
    fn();
    return;
  }
  // More threads than the machine has: oneTBB caps its workers at the hardware's count and
  // prints a multi-line warning on stderr unless the cap is raised for the call (the callers
  // check threads <= kMaxThreads = 1024). The output is the same for any count.
  std::optional<tbb::global_control> cap;
  if (threads > hardware_threads()) cap.emplace(tbb::global_control::max_allowed_parallelism, threads);
  tbb::task_arena arena(threads);
  arena.execute(fn);
}

int hardware_threads() { return tbb::info::default_concurrency(); }

std::size_t l2_cache_bytes() {
  static const std::size_t bytes = [] {
#ifdef _SC_LEVEL2_CACHE_SIZE
    const long v = sysconf(_SC_LEVEL2_CACHE_SIZE);  // glibc: from CPUID
    return v > 0 ? static_cast<std::size_t>(v) : std::size_t{0};
#else
    return std::size_t{0};
#endif
  }();
  return bytes;
}

}  // namespace dofkit::core
