// lfi capture BENCH: the reference package (reference_package.h) of a bench:
// the reference light field captured (or read), shown with the display, and
// the golden model of the intact part trained from the bench's reference frames.

#include "bench_cli.h"
#include "cli_util.h"
#include "commands.h"

#include "lfi/controller/bench_devices.h"
#include "lfi/controller/controller.h"
#include "lfi/controller/inspection_record.h"
#include "lfi/controller/reference_package.h"
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
  refuseExisting({bench.referenceFolder}, a.force, "capture");
  auto capture = lfi::openBenchCapture(bench);
  auto display = lfi::openBenchDisplay(bench);
  auto camera = lfi::openBenchCamera(bench);
  if (!capture->measuresThroughBench() && capture->geometry().distance_mm != bench.distance_mm)
    lfi::fail(lfi::Errc::Config, "{}: the capture ({}) records the light field {} mm below the part, the bench's "
              "[geometry] distance_mm is {} mm", bench.file.string(), capture->description(),
              capture->geometry().distance_mm, bench.distance_mm);
  requireOutputFolder(bench.referenceFolder.parent_path(), "capture", "[reference] folder");
  lfi::Controller controller(*capture, *display, *camera, lfi::controllerOptions(bench, bench.inspectionFrames));
  ProgressBar bar;
  const auto progress = [&](const char* step, double f) {
    if (!global.quiet) bar(step, f);
  };
  lfi::ReferencePackage package;
  package.lightField = controller.captureReference(progress);
  package.panel = controller.referencePanel();
  controller.emitReference(package.lightField);
  // The golden model learns images as inspections take them: each the mean of the inspection's frames.
  for (int i = 0; i < bench.referenceFrames; ++i) {
    progress("golden model", static_cast<double>(i) / bench.referenceFrames);
    package.trainer.add(controller.inspect());
  }
  progress("golden model", 1);
  bar.finish();
  const cv::Mat ideal = package.trainer.mean();
  const lfi::PartFrame frame = bench.partFrame(ideal.cols, ideal.rows);
  const double radius_px = bench.maskRadius_mm ? *bench.maskRadius_mm / bench.objectPixel_mm : -1.0;
  package.mask = lfi::partMask(ideal, frame.origin_px.x, frame.origin_px.y, radius_px, bench.maskLitFraction);
  // How much of the part the reference lets the inspection see: the pixels lit enough, of the part's.
  const int partPixels = cv::countNonZero(lfi::partMask(ideal, frame.origin_px.x, frame.origin_px.y, radius_px, 0));
  const int inspected = cv::countNonZero(package.mask);
  spdlog::info("capture: {}", capture->description());
  cv::Scalar mean, deviation;
  cv::meanStdDev(ideal, mean, deviation, package.mask);
  spdlog::info("capture: the reference lights {} of the part's {} pixels ({:.1f} %) to at least {} of its 99th "
               "percentile: defects are looked for there; the intact part's image there: mean {:.1f} DN, cv {:.3f}",
               inspected, partPixels, 100.0 * inspected / std::max(partPixels, 1), bench.maskLitFraction, mean[0],
               mean[0] > 0 ? deviation[0] / mean[0] : 0.0);
  lfi::ReferenceInfo& info = package.info;
  info.benchFile = fs::absolute(bench.file).string();
  info.benchHash = bench.referenceHash();
  info.created_utc = info.updated_utc = lfi::utcNow();
  info.camera = lfi::describeCamera(*camera, bench.cameraUri);
  info.display = fmt::format("{} ({})", display->info().deviceId, bench.displayUri);
  info.capture = capture->description();
  info.exposure_us = bench.camera.exposure_us;
  info.gain = bench.camera.gain;
  info.pixelFormat = lfi::toString(bench.camera.pixelFormat);
  info.white = controller.white();
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
