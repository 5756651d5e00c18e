// Parallel loops over rows/tiles (oneTBB). Work is split into fixed chunks that each write
// disjoint outputs, so results never depend on the thread count.
#pragma once
#include <cstddef>
#include <functional>

namespace dofkit::core {

/// Calls body(begin, end) for disjoint sub-ranges covering [0, n), in parallel.
/// `grain` = minimum items per call.
void parallel_for(int n, const std::function<void(int begin, int end)>& body, int grain = 1);

/// Runs `fn` inside an arena limited to `threads` workers (0 = all hardware threads).
void with_threads(int threads, const std::function<void()>& fn);

/// Number of hardware threads.
int hardware_threads();

/// Size of one core's L2 cache in bytes as the C library reports it (0 where unknown).
std::size_t l2_cache_bytes();

}  // namespace dofkit::core
