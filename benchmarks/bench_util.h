// SPDX-License-Identifier: Apache-2.0
#pragma once
// Timing for the benchmarks: the best of several runs (the least disturbed by
// whatever else the machine does) for speeds, and the median of ratios taken
// turn by turn for ratios between two runs.

#include <stdlib.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>
#include <functional>
#include <stdexcept>
#include <string>
#include <system_error>
#include <vector>

namespace lfi::bench {

// The seconds one call of `f` takes.
inline double secondsOf(const std::function<void()>& f) {
  const auto t0 = std::chrono::steady_clock::now();
  f();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// The nearest-rank percentile of `v` (fraction 0.5: the median, 0.99: the 99th percentile); v not empty.
inline double percentile(std::vector<double> v, double fraction) {
  std::sort(v.begin(), v.end());
  const auto rank = static_cast<size_t>(std::ceil(fraction * static_cast<double>(v.size())));
  return v[std::clamp<size_t>(rank, 1, v.size()) - 1];
}

inline double bestSeconds(int repeats, const std::function<void()>& f) {
  double best = 1e300;
  for (int r = 0; r < repeats; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    f();
    best = std::min(best, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  return best;
}

// Seconds of every run of each of `fs`, run in turns (f0, f1, ..., f0, f1,
// ...): seconds[turn][i].
using TurnSeconds = std::vector<std::vector<double>>;
inline TurnSeconds secondsInTurns(int turns, const std::vector<std::function<void()>>& fs) {
  TurnSeconds seconds(static_cast<size_t>(turns), std::vector<double>(fs.size()));
  for (auto& turn : seconds)
    for (size_t i = 0; i < fs.size(); ++i) turn[i] = bestSeconds(1, fs[i]);
  return seconds;
}

// The best run of function i over the turns (its speed on the quietest machine).
inline double bestOf(const TurnSeconds& seconds, size_t i) {
  double best = 1e300;
  for (const auto& turn : seconds) best = std::min(best, turn[i]);
  return best;
}

// The ratio seconds[a] / seconds[b] of every turn: its two ends ran next to
// each other in time, so the machine's load, which drifts over seconds (a
// shared host), weighs on both alike.
inline std::vector<double> ratiosByTurn(const TurnSeconds& seconds, size_t a, size_t b) {
  std::vector<double> r;
  for (const auto& turn : seconds) r.push_back(turn[a] / turn[b]);
  return r;
}
// The median of values and their range, as the benchmarks print a ratio.
struct Spread {
  double median = 0, low = 0, high = 0;
};
inline Spread spreadOf(std::vector<double> v) {
  if (v.empty()) return {};
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return {n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]), v.front(), v.back()};
}

// The best of `repeats` runs of each of `fs`, run in turns.
inline std::vector<double> bestSecondsInTurns(int repeats, const std::vector<std::function<void()>>& fs) {
  const TurnSeconds seconds = secondsInTurns(repeats, fs);
  std::vector<double> best;
  for (size_t i = 0; i < fs.size(); ++i) best.push_back(bestOf(seconds, i));
  return best;
}

// A fresh folder `<parent>/<prefix>-XXXXXX` for a benchmark's files, removed
// with everything in it at the end.
class TemporaryFolder {
 public:
  TemporaryFolder(const std::filesystem::path& parent, const std::string& prefix) {
    std::string pattern = (parent / (prefix + "-XXXXXX")).string();
    if (!::mkdtemp(pattern.data()))
      throw std::runtime_error("cannot make a folder in '" + parent.string() + "': " + std::strerror(errno));
    path_ = pattern;
  }
  ~TemporaryFolder() {
    std::error_code ignored;
    std::filesystem::remove_all(path_, ignored);
  }
  TemporaryFolder(const TemporaryFolder&) = delete;
  TemporaryFolder& operator=(const TemporaryFolder&) = delete;
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

// A benchmark's main: an error (a device that is missing, a self-check that
// fails) is printed with the benchmark's name and exits 1, rather than abort.
inline int runGuarded(const char* name, const std::function<int()>& body) {
  try {
    return body();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: %s\n", name, e.what());
    return 1;
  }
}

}  // namespace lfi::bench
