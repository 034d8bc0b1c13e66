// SPDX-License-Identifier: Apache-2.0
// lfi capture BENCH: the reference package (reference_package.h) of a bench:
// the reference light field captured (or read), shown with the display, and
// the golden model of the intact part trained from the bench's reference frames.

#include "bench_cli.h"
#include "cli_util.h"
#include "commands.h"

#include "lfi/controller/bench_devices.h"
#include "lfi/controller/reference_capture.h"
#include "lfi/core/error.h"
#include "lfi/core/log.h"
#include "lfi/core/output_folder.h"

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
  refuseExisting({bench.referenceFolder}, a.force ? Overwrite::Allow : Overwrite::Refuse, "capture");
  auto capture = lfi::openBenchCapture(bench);
  auto display = lfi::openBenchDisplay(bench);
  auto camera = lfi::openBenchCamera(bench, lfi::BenchExposures::OnRequest);
  requireOutputFolder(bench.referenceFolder.parent_path(), "capture", "[reference] folder");
  ProgressBar bar;
  const auto progress = [&](const char* step, double f) {
    if (!global.quiet) bar(step, f);
  };
  lfi::ReferenceCoverage coverage;
  const lfi::ReferencePackage package = lfi::takeReference(bench, *capture, *display, *camera, progress, &coverage);
  bar.finish();
  spdlog::info("capture: {}", capture->description());
  spdlog::info(
      "capture: the reference lights {} of the part's {} pixels ({:.1f} %) to at least {} of its 99th "
      "percentile: defects are looked for there; the intact part's image there: mean {:.1f} DN, cv {:.3f}",
      coverage.inspectedPixels, coverage.partPixels,
      100.0 * coverage.inspectedPixels / std::max(coverage.partPixels, 1), bench.maskLitFraction, coverage.mean_dn,
      coverage.cv);
  lfi::writeReferencePackage(bench.referenceFolder, package, a.force ? lfi::Overwrite::Allow : lfi::Overwrite::Refuse);
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
