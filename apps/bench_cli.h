// SPDX-License-Identifier: Apache-2.0
#pragma once
// What the subcommands that take a bench file share (capture, train, inspect,
// run, emit, devices): the BENCH argument, the simulated part to inspect, the
// exit status of a verdict, and a stop request from the terminal.

#include "lfi/controller/bench_file.h"
#include "lfi/core/part_model.h"

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

// "<prefix>-<time>": the folder of one inspection or run, named by its UTC
// time (ISO 8601 without its colons, for other file systems' sake).
std::string timedFolderName(const char* prefix, const std::string& timeUtc);

// --part SCENE: the part under a simulated bench's camera is the one of this
// scene file (its camera and display URIs' scene replaced; the reference is
// still the bench's). Throws Errc::Config for a bench whose camera or display
// is not sim: (a physical bench inspects the part that is under its camera).
BenchFile withSimulatedPart(BenchFile bench, const std::filesystem::path& scene);

// The part's model the bench names ([geometry] part_model, a scene file), or null.
std::shared_ptr<const PartModel> benchPartModel(const BenchFile& bench);

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
