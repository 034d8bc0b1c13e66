// SPDX-License-Identifier: Apache-2.0
#pragma once
// What the subcommands that take a bench file share (capture, train, inspect,
// run, emit, devices): the BENCH argument, the exit status of a verdict, and a
// stop request from the terminal; the flows themselves are the session
// library's (lfi/session/bench_session.h).

#include "lfi/controller/bench_file.h"
#include "lfi/session/bench_session.h"  // --part SCENE: withSimulatedPart; benchPartModel; timedFolderName

#include <CLI/CLI.hpp>

#include <atomic>
#include <filesystem>
#include <memory>
#include <string>

namespace lfi::cli {

// Exit status of `lfi inspect` for a part that failed its verdict (0: it
// passed; 1: an error; docs/inspection.md).
inline constexpr int kExitPartFailed = 3;

void addBenchArgument(CLI::App& command, std::filesystem::path& file);

// Turns SIGINT and SIGTERM into a request that stopRequested() reports, so
// that a loop ends after the part in hand; a second signal ends the process.
// The handlers stay until the guard is destroyed.
class StopOnSignal {
 public:
  StopOnSignal();
  ~StopOnSignal();
  StopOnSignal(const StopOnSignal&) = delete;
  StopOnSignal& operator=(const StopOnSignal&) = delete;
  static bool stopRequested();
};

}  // namespace lfi::cli
