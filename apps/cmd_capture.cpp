// SPDX-License-Identifier: Apache-2.0
// lfi capture BENCH: the reference package (reference_package.h) of a bench:
// the reference light field captured (or read), shown with the display, and
// the golden model of the intact part trained from the bench's reference frames.

#include "bench_cli.h"
#include "cli_util.h"
#include "commands.h"

#include "lfi/core/error.h"
#include "lfi/core/log.h"

#include <fmt/format.h>

#include <algorithm>
#include <memory>

namespace fs = std::filesystem;

namespace lfi::cli {

namespace {

struct CaptureArgs {
  fs::path bench;
  bool force = false;
};

int runCapture(const CaptureArgs& a, const GlobalOptions& global) {
  const lfi::BenchFile bench = lfi::readBenchFile(a.bench);
  ProgressBar bar;
  const auto progress = [&](const char* step, double f) {
    if (!global.quiet) bar(step, f);
  };
  const lfi::CaptureResult r =
      lfi::captureReference(bench, a.force ? lfi::Overwrite::Allow : lfi::Overwrite::Refuse, progress);
  bar.finish();
  spdlog::info("capture: {}", r.captureDevice);
  const lfi::ReferenceCoverage& coverage = r.coverage;
  spdlog::info(
      "capture: the reference lights {} of the part's {} pixels ({:.1f} %) to at least {} of its 99th "
      "percentile: defects are looked for there; the intact part's image there: mean {:.1f} DN, cv {:.3f}",
      coverage.inspectedPixels, coverage.partPixels,
      100.0 * coverage.inspectedPixels / std::max(coverage.partPixels, 1), bench.maskLitFraction, coverage.mean_dn,
      coverage.cv);
  fmt::print("{}\n", bench.referenceFolder.string());
  return 0;
}

}  // namespace

Command addCaptureCommand(CLI::App& app) {
  auto* command = app.add_subcommand(
      "capture", "Take a bench's reference package: the reference light field and the intact part's golden model");
  auto a = std::make_shared<CaptureArgs>();
  addBenchArgument(*command, a->bench);
  command->add_flag("--force", a->force, "Replace an existing reference package");
  return {command, [a](const GlobalOptions& global) { return runCapture(*a, global); }};
}

}  // namespace lfi::cli
