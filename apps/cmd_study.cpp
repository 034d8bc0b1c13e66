// SPDX-License-Identifier: Apache-2.0
// lfi study: the reference study on the simulated bench (docs/study.md).

#include "cli_util.h"
#include "commands.h"

#include "lfi/core/exr_io.h"
#include "lfi/core/log.h"
#include "lfi/study/grid_sweep.h"
#include "lfi/study/study.h"

#include <fmt/format.h>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <system_error>
#include <vector>

namespace fs = std::filesystem;

namespace lfi::cli {

namespace {

// The reference bench: next to an installed `lfi` (<prefix>/bin/lfi and
// <prefix>/share/lfi, as `cmake --install` lays them out), else in the source
// tree of the build.
fs::path defaultBench() {
  const fs::path relative = fs::path("benches") / "reference.toml";
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  if (!ec)
    if (const fs::path installed = self.parent_path().parent_path() / LFI_INSTALL_DATADIR / "lfi" / relative;
        fs::exists(installed, ec))
      return installed;
  return fs::path(LFI_DATA_DIR) / relative;
}

struct StudyArgs {
  fs::path out;
  fs::path benchFile = defaultBench();
  std::string quality = "default";
  bool force = false;
  int threads = 0;
  std::uint64_t seed = 1;
  bool sweepOff = false;
  fs::path sweepFile;  // --sweep FILE
  std::string shard;   // --shard i/N
  CLI::Option *sweepOption = nullptr, *benchOption = nullptr, *qualityOption = nullptr, *seedOption = nullptr;
  // lfi study merge OUT SHARD...
  CLI::App* merge = nullptr;
  fs::path mergeOut;
  std::vector<fs::path> shards;
};

// A sweep file's grid (--sweep FILE), whole or one shard (--shard i/N): the sweep file states the bench, the
// quality and the seed.
int runSweepCommand(const StudyArgs& a, const GlobalOptions& global) {
  for (const CLI::Option* o : {a.benchOption, a.qualityOption, a.seedOption})
    if (o->count() > 0)
      fail(Errc::InvalidArgument, "study: {} is the sweep file's to say ('{}'), not the command line's", o->get_name(),
           a.sweepFile.string());
  const lfi::study::SweepFile sweep = lfi::study::readSweepFile(a.sweepFile);
  lfi::study::SweepOptions options;
  if (!a.shard.empty()) options.shard = lfi::study::parseShard(a.shard);
  options.threads = a.threads;
  lfi::setExrThreads(a.threads);
  options.overwrite = a.force;
  ProgressBar bar;
  if (!global.quiet) options.progress = [&bar](const std::string& label, double f) { bar(label, f); };
  const auto start = std::chrono::steady_clock::now();
  lfi::study::runSweep(sweep, a.out, options);
  bar.finish();
  const std::size_t points =
      options.shard ? lfi::study::shardPoints(sweep.pointCount(), *options.shard).size() : sweep.pointCount();
  fmt::print("{}\n", (a.out / (options.shard ? "shard.json" : "study.json")).string());
  spdlog::info("{} of {} points written to {} in {:.1f} s", points, sweep.pointCount(), a.out.string(),
               std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  return 0;
}

int runMergeCommand(const StudyArgs& a) {
  const auto results = lfi::study::mergeSweepShards(a.mergeOut, a.shards, a.force);
  fmt::print("{}\n", (a.mergeOut / "study.json").string());
  spdlog::info("{} points of {} shards merged into {}", results["points"].size(), a.shards.size(), a.mergeOut.string());
  return 0;
}

int runStudyCommand(const StudyArgs& a, const GlobalOptions& global) {
  if (a.merge->parsed()) return runMergeCommand(a);
  if (a.out.empty()) fail(Errc::InvalidArgument, "study: --out is required");
  if (!a.shard.empty() && a.sweepFile.empty())
    fail(Errc::InvalidArgument, "study: --shard splits a sweep file's grid (--sweep FILE)");
  if (!a.sweepFile.empty()) return runSweepCommand(a, global);
  const lfi::study::Bench bench = lfi::study::Bench::load(a.benchFile);
  lfi::study::StudyOptions options;
  options.quality = lfi::study::parseQuality(a.quality);
  options.threads = a.threads;
  lfi::setExrThreads(a.threads);  // (the light fields and images it writes)
  options.seed = a.seed;
  options.overwrite = a.force;
  if (a.sweepOption->count() > 0)
    options.sweep = lfi::study::defaultSweep(), options.limits = lfi::study::defaultLimits();
  if (a.sweepOff)
    options.sweep = std::vector<lfi::study::SweepPoint>{}, options.limits = std::vector<lfi::study::LimitPoint>{};
  ProgressBar bar;
  if (!global.quiet) options.progress = [&bar](const std::string& label, double f) { bar(label, f); };
  const auto start = std::chrono::steady_clock::now();
  const auto result = lfi::study::runStudy(bench, a.out, options);
  bar.finish();
  fmt::print("{}", lfi::study::verdictTable(result));
  spdlog::info("study written to {} in {:.1f} s (open {})", a.out.string(),
               std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(),
               (a.out / "report.html").string());
  return 0;
}

}  // namespace

Command addStudyCommand(CLI::App& app) {
  auto* study = app.add_subcommand("study", "Run the reference study on the simulated bench");
  auto a = std::make_shared<StudyArgs>();
  study->add_option("--out", a->out, "Output folder (study.json, images/, report.html; required)");
  a->benchOption =
      study->add_option("--bench", a->benchFile, "Bench file (TOML)")->check(CLI::ExistingFile)->capture_default_str();
  a->qualityOption = study->add_option("--quality", a->quality, "quick | default | high")
                         ->check(CLI::IsMember({"quick", "default", "high"}))
                         ->capture_default_str();
  study->add_option("--threads", a->threads, "Worker threads (0 = all cores)")->transform(threadCount());
  a->seedOption = study->add_option("--seed", a->seed, "Random seed (renders and sensor noise)")
                      ->transform(seedValue())
                      ->capture_default_str();
  study->add_flag("--force", a->force, "Replace the results of an earlier study, sweep or shard in the folder");
  a->sweepOption = study
                       ->add_option("--sweep", a->sweepFile,
                                    "Run the display-quality sweep, the display classes and the detection limits "
                                    "(default: on, except with --quality quick); with a FILE, that sweep file's "
                                    "grid instead (docs/study.md, \"Sweeps\")")
                       ->expected(0, 1);
  study->add_flag("--no-sweep", a->sweepOff, "Skip the sweep, the display classes and the detection limits")
      ->excludes(a->sweepOption);
  study->add_option("--shard", a->shard, "With --sweep FILE: compute shard i of N (i/N) into --out (docs/cluster.md)");
  a->merge = study->add_subcommand("merge", "Merge a sweep's shard folders into one sweep's results");
  a->merge->add_option("out", a->mergeOut, "Output folder (study.json, images/, report.html)")->required();
  a->merge->add_option("shards", a->shards, "The shards' folders (--shard i/N's --out), every one of the sweep's")
      ->required()
      ->check(CLI::ExistingDirectory);
  a->merge->add_flag("--force", a->force, "Replace the results of an earlier merge in OUT");
  return {study, [a](const GlobalOptions& global) { return runStudyCommand(*a, global); }};
}

}  // namespace lfi::cli
