#pragma once
// The core's one parallel loop, on oneTBB (Debian's libtbb-dev). Private to the core.

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cstddef>

namespace flexcloud {

/// Number of worker threads for a request (0: all cores, at least 1).
inline int threadCount(int requested) {
  return requested > 0 ? requested : std::max(1, tbb::this_task_arena::max_concurrency());
}

/// How many contiguous ranges a loop over n map points runs in: one a thread, at most one per
/// 64 K points (a range keeps its previous point's state as its guess for the next).
inline std::size_t pointRanges(std::size_t n, int threads) {
  return static_cast<std::size_t>(
      std::max(1, std::min<int>(threadCount(threads), static_cast<int>(n / 65536 + 1))));
}

/// Runs f(part, begin, end) over [0, n) split into `parts` contiguous ranges, on at most `threads`
/// threads (0: all cores). Contiguous ranges keep the locality a caller relies on (a map stored
/// scan by scan, a grid walked slab by slab). An exception in f reaches the caller.
template <typename F>
void parallelRanges(std::size_t n, std::size_t parts, int threads, F&& f) {
  parts = std::max<std::size_t>(1, std::min(parts, n));
  const int t = std::min<int>(threadCount(threads), static_cast<int>(parts));
  if (t <= 1 || n < 2) {
    for (std::size_t k = 0; k < parts; ++k) f(k, n * k / parts, n * (k + 1) / parts);
    return;
  }
  tbb::task_arena arena(t);
  arena.execute([&] {
    tbb::parallel_for(std::size_t{0}, parts,
                      [&](std::size_t k) { f(k, n * k / parts, n * (k + 1) / parts); });
  });
}

}  // namespace flexcloud
