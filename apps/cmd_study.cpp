// SPDX-License-Identifier: Apache-2.0
// lfi study: the reference study on the simulated bench (docs/study.md).

#include "cli_util.h"
#include "commands.h"

#include "lfi/core/exr_io.h"
#include "lfi/core/log.h"
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
  bool sweepOn = false, sweepOff = false;
};

int runStudyCommand(const StudyArgs& a, const GlobalOptions& global) {
  const lfi::study::Bench bench = lfi::study::Bench::load(a.benchFile);
  lfi::study::StudyOptions options;
  options.quality = lfi::study::parseQuality(a.quality);
  options.threads = a.threads;
  lfi::setExrThreads(a.threads);  // (the light fields and images it writes)
  options.seed = a.seed;
  options.overwrite = a.force;
  if (a.sweepOn) options.sweep = lfi::study::defaultSweep(), options.limits = lfi::study::defaultLimits();
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
  study->add_option("--out", a->out, "Output folder (study.json, images/, report.html)")->required();
  study->add_option("--bench", a->benchFile, "Bench file (TOML)")->check(CLI::ExistingFile)->capture_default_str();
  study->add_option("--quality", a->quality, "quick | default | high")
      ->check(CLI::IsMember({"quick", "default", "high"}))
      ->capture_default_str();
  study->add_option("--threads", a->threads, "Worker threads (0 = all cores)")->transform(threadCount());
  study->add_option("--seed", a->seed, "Random seed (renders and sensor noise)")
      ->transform(seedValue())
      ->capture_default_str();
  study->add_flag("--force", a->force, "Replace the results of an earlier study in --out");
  auto* sweepFlag = study->add_flag("--sweep", a->sweepOn,
                                    "Run the display-quality sweep, the display classes and the detection limits "
                                    "(default: on, except with --quality quick)");
  study->add_flag("--no-sweep", a->sweepOff, "Skip the sweep, the display classes and the detection limits")
      ->excludes(sweepFlag);
  return {study, [a](const GlobalOptions& global) { return runStudyCommand(*a, global); }};
}

}  // namespace lfi::cli
