#pragma once
// Runs independent experiment runs on a few threads. Internal to the experiments.
#include <algorithm>
#include <atomic>
#include <thread>
#include <vector>

namespace swarmloc::research::detail {

/// Calls fn(k) for k in [0, count) on `threads` threads. Each call must write only its own slot, so the
/// results do not depend on the thread count.
template <typename Fn>
void parallel_runs(int count, int threads, Fn&& fn) {
  std::atomic<int> next{0};
  std::vector<std::thread> pool;
  for (int t = 0; t < std::max(1, std::min(threads, count)); ++t) {
    pool.emplace_back([&] {
      for (int k = next++; k < count; k = next++) fn(k);
    });
  }
  for (auto& thread : pool) thread.join();
}

}  // namespace swarmloc::research::detail
