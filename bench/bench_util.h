#pragma once
// Timing for the benchmarks: the best of several runs (the least disturbed by
// whatever else the machine does).

#include <algorithm>
#include <chrono>
#include <functional>

namespace lfi::bench {

inline double bestSeconds(int repeats, const std::function<void()>& f) {
  double best = 1e300;
  for (int r = 0; r < repeats; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    f();
    best = std::min(best, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  return best;
}

}  // namespace lfi::bench
