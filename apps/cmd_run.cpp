// SPDX-License-Identifier: Apache-2.0
// lfi run BENCH: parts inspected one after another until stopped (SIGINT or
// SIGTERM, a part count, or a time), by the controller's run (run.h): one
// JSON Lines record per part, a summary page, progress on the terminal.

#include "bench_cli.h"
#include "cli_util.h"
#include "commands.h"

#include "lfi/controller/reference_package.h"
#include "lfi/controller/run.h"
#include "lfi/core/error.h"

#include <fmt/format.h>

#include <algorithm>
#include <memory>

namespace fs = std::filesystem;

namespace lfi::cli {

namespace {

struct RunArgs {
  fs::path bench, part, out;
  long parts = 0;      // 0: no limit
  double seconds = 0;  // 0: no limit
};

int runRun(const RunArgs& a, const GlobalOptions& global) {
  const StopOnSignal stop;  // (from the start: a Ctrl-C while the devices open ends the run before its first part)
  const BenchFile bench = readBenchFile(a.bench);
  // The devices: the bench's, or those of --part's scene on a simulated bench (a bench that cannot take
  // --part is the first thing to say).
  const BenchFile devices = a.part.empty() ? bench : withSimulatedPart(bench, a.part);
  const ReferencePackage package = readReferencePackage(bench.referenceFolder, &bench);
  RunOptions options;
  options.partModel = benchPartModel(bench);
  options.folder = a.out.empty() ? bench.outputFolder / timedFolderName("run", utcNow()) : a.out;
  options.parts = a.parts;
  options.seconds = a.seconds;
  options.stopRequested = [] { return StopOnSignal::stopRequested(); };
  fmt::print(stderr, "run: records in {} (Ctrl-C stops after the part in hand)\n",
             (options.folder / "records.jsonl").string());
  if (!global.quiet)
    options.onPart = [](const RunCounts& c, double seconds) {
      fmt::print(stderr, "\rpart {}: {} passed, {} failed, {} not inspected, {:.2f} parts/s   ", c.parts, c.passed,
                 c.failed, c.errors, c.parts / std::max(seconds, 1e-9));
    };
  const RunResult r = runParts(bench, devices, package, options);
  if (!global.quiet) fmt::print(stderr, "\n");
  fmt::print("{} parts in {:.1f} s ({:.2f} parts/s): {} passed, {} failed, {} not inspected\n{}\n{}\n", r.counts.parts,
             r.seconds, r.counts.parts / std::max(r.seconds, 1e-9), r.counts.passed, r.counts.failed, r.counts.errors,
             r.records.string(), r.page.string());
  // The outputs' trouble ([output.mqtt]) does not fail the run: its records are all in its file.
  for (const std::string& problem : r.outputProblems) fmt::print(stderr, "run: output: {}\n", problem);
  return 0;
}

}  // namespace

Command addRunCommand(CLI::App& app) {
  auto* command =
      app.add_subcommand("run", "Inspect parts one after another until stopped, with records and a summary");
  auto a = std::make_shared<RunArgs>();
  addBenchArgument(*command, a->bench);
  command->add_option("--parts", a->parts, "Stop after this many parts (default: no limit)")
      ->transform(wholeNumberIn(1LL, 1LL << 40));
  command->add_option("--seconds", a->seconds, "Stop after this long (default: no limit)")->check(CLI::PositiveNumber);
  command->add_option("--part", a->part, "Simulated bench: every part is the one of this scene file")
      ->check(CLI::ExistingFile);
  command->add_option("--out", a->out, "Folder for the run (default: a new one in [output] folder)");
  return {command, [a](const GlobalOptions& global) { return runRun(*a, global); }};
}

}  // namespace lfi::cli
