// SPDX-License-Identifier: Apache-2.0
#pragma once
// The simulator's parallel loops (the tile renderer, the camera sensor model):
// body(i) for every i in [0, count), on `threads` threads (0: as many as TBB
// gives this process). An exception from a body ends the loop and is
// rethrown here.
//
// TBB's parallel_for runs them, except in the ThreadSanitizer build
// (LFI_SANITIZE_THREAD): TBB's scheduler is not instrumented, so its hand-over
// of work between threads is invisible there and every body's access would be
// reported. That build runs the same bodies on std::threads, which
// ThreadSanitizer sees created and joined: it checks the bodies' own code,
// whose races do not depend on which pool runs them.

#ifdef LFI_SANITIZE_THREAD
#include <algorithm>
#include <atomic>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>
#else
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>
#endif

namespace lfi::sim::detail {

template <typename Body>
void parallelFor(int count, int threads, Body&& body) {
#ifdef LFI_SANITIZE_THREAD
  const int n =
      std::min(count, threads > 0 ? threads : std::max(2, static_cast<int>(std::thread::hardware_concurrency())));
  std::atomic<int> next{0};
  std::exception_ptr error;
  std::mutex errorMutex;
  auto work = [&] {
    for (int i = next++; i < count; i = next++) {
      try {
        body(i);
      } catch (...) {
        std::lock_guard lock(errorMutex);
        if (!error) error = std::current_exception();
        next = count;
      }
    }
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < n; ++t) pool.emplace_back(work);
  work();
  for (std::thread& t : pool) t.join();
  if (error) std::rethrow_exception(error);
#else
  tbb::task_arena arena(threads > 0 ? threads : tbb::task_arena::automatic);
  arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<int>(0, count, 1), [&](const tbb::blocked_range<int>& range) {
      for (int i = range.begin(); i != range.end(); ++i) body(i);
    });
  });
#endif
}

}  // namespace lfi::sim::detail
