#pragma once
// Timing for the benchmarks: the best of several runs (the least disturbed by
// whatever else the machine does).

#include <algorithm>
#include <chrono>
#include <functional>
#include <vector>

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

// The best of `repeats` runs of each of `fs`, run in turns (f0, f1, ..., f0,
// f1, ...), so that a change in the machine's load falls on all of them
// alike: for ratios between them, such as a speed-up over threads.
inline std::vector<double> bestSecondsInTurns(int repeats, const std::vector<std::function<void()>>& fs) {
  std::vector<double> best(fs.size(), 1e300);
  for (int r = 0; r < repeats; ++r)
    for (size_t i = 0; i < fs.size(); ++i) best[i] = std::min(best[i], bestSeconds(1, fs[i]));
  return best;
}

}  // namespace lfi::bench
