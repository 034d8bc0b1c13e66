// SPDX-License-Identifier: Apache-2.0
// lfi calibrate-distance BENCH: the display-to-part distance scan with the
// bench's devices (docs/calibration.md), its table on stdout and its result
// file (JSON).

#include "bench_cli.h"
#include "cli_util.h"
#include "commands.h"

#include "lfi/calib/display_distance.h"
#include "lfi/controller/bench_devices.h"
#include "lfi/controller/controller.h"
#include "lfi/controller/distance_scan.h"
#include "lfi/core/atomic_file.h"
#include "lfi/core/error.h"
#include "lfi/core/exr_io.h"
#include "lfi/core/output_folder.h"

#include <fmt/format.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <memory>
#include <system_error>
#include <vector>

namespace fs = std::filesystem;

namespace lfi::cli {

namespace {

// --from, --to and --step as the candidate errors; Errc::Config naming them.
std::vector<double> scanCandidates(double from, double to, double step) {
  const double count = std::isfinite(from) && std::isfinite(to) && step > 0 ? (to - from) / step : -1;
  // (Whole steps within rounding: 0.1 to 0.3 by 0.1 is 1.9999999999999998 steps.)
  if (!(std::round(count) >= 2 && std::round(count) <= 1000) || !(std::abs(count - std::round(count)) <= 1e-6))
    lfi::fail(lfi::Errc::Config,
              "calibrate-distance: --from {} --to {} --step {} must give 3 to 1001 candidates, the range a whole "
              "number of steps",
              from, to, step);
  std::vector<double> candidates;
  for (int i = 0; i <= static_cast<int>(std::round(count)); ++i) candidates.push_back(from + i * step);
  return candidates;
}

struct DistanceArgs {
  fs::path bench;
  fs::path part;        // a simulated bench's scene during the scan
  fs::path lightField;  // the reference light field, in place of the bench's [capture]
  int frames = 0;       // 0: the bench's [inspection] frames
  double scanFrom = -6, scanTo = 6, scanStep = 1;
  std::vector<int> roiBox;
  fs::path out;
  bool force = false;
};

// The part's pixels in the camera's image (--roi), or empty: all. Errc::Config for a box outside it.
cv::Mat roiMask(const std::vector<int>& box, const lfi::CameraSettings& settings) {
  if (box.empty()) return {};
  const cv::Rect r(box[0], box[1], box[2], box[3]);
  if (r.x < 0 || r.y < 0 || r.width < 1 || r.height < 1 || r.width > settings.roiWidth_px - r.x ||
      r.height > settings.roiHeight_px - r.y)
    lfi::fail(lfi::Errc::Config, "calibrate-distance: --roi {},{},{},{} is not inside the camera's {} x {} image", r.x,
              r.y, r.width, r.height, settings.roiWidth_px, settings.roiHeight_px);
  cv::Mat roi = cv::Mat::zeros(settings.roiHeight_px, settings.roiWidth_px, CV_8UC1);
  roi(r).setTo(255);
  return roi;
}

void printScan(const lfi::calib::DisplayDistanceScan& scan, double referenceDistance_mm) {
  fmt::print("with the display dark: {:.6g} (noise of a mean {:.2g})\n", scan.dark, scan.noise);
  for (size_t i = 0; i < scan.candidates_mm.size(); ++i)
    fmt::print("{:+8.3f} mm  {:.6g}\n", scan.candidates_mm[i], scan.brightness[i]);
  fmt::print("estimate {:+.3f} mm (the display {:.3f} mm {} the part than the reference's {} mm)\n", scan.estimate_mm,
             std::abs(scan.estimate_mm), scan.estimate_mm >= 0 ? "further from" : "nearer to", referenceDistance_mm);
}

// lfi calibrate-distance: the display-to-part distance scan (docs/calibration.md).
void calibrateDistance(const DistanceArgs& a, const std::vector<double>& candidates, bool quiet) {
  const fs::path& out = a.out;
  const auto overwrite = a.force ? lfi::Overwrite::Allow : lfi::Overwrite::Refuse;
  if (std::error_code ec; out.filename().empty() || fs::is_directory(out, ec))
    lfi::fail(lfi::Errc::InvalidArgument, "calibrate-distance: --out '{}' must name a file, not a folder",
              out.string());
  const lfi::BenchFile bench = lfi::readBenchFile(a.bench);
  const lfi::BenchFile devices = a.part.empty() ? bench : withSimulatedPart(bench, a.part);
  // A reference captured for the scan is kept beside it (scan.json: scan.lightfield.exr), as `inspect` keeps its
  // own; a stored one (--light-field, or the bench's [capture] light_field) is named.
  const bool captures = a.lightField.empty() && bench.captureUri.has_value();
  const fs::path referenceFile = captures               ? fs::path(out).replace_extension(".lightfield.exr")
                                 : a.lightField.empty() ? bench.lightFieldFile
                                                        : a.lightField;
  std::vector<fs::path> outputs{out};
  if (captures) outputs.push_back(referenceFile);
  refuseExisting(outputs, overwrite, "calibrate-distance");
  auto capture = a.lightField.empty() ? lfi::openBenchCapture(devices)
                                      : std::make_unique<lfi::StoredLightField>(lfi::readLightFieldExr(a.lightField),
                                                                                "file " + a.lightField.string());
  auto display = lfi::openBenchDisplay(devices);
  auto camera = lfi::openBenchCamera(devices, lfi::BenchExposures::OnRequest);
  // Where the result goes must take it before the scan, not after (and a bad device leaves no folder behind).
  requireOutputFolder(out.parent_path(), "calibrate-distance", "--out");
  const cv::Mat roi = roiMask(a.roiBox, camera->settings());
  const lfi::ControllerOptions options =
      lfi::controllerOptions(bench, a.frames > 0 ? a.frames : bench.inspectionFrames);
  // The candidates against the reference's distance before a capture, not after it.
  lfi::calib::checkDisplayDistanceCandidates(capture->geometry(), candidates);
  lfi::Controller controller(*capture, *display, *camera, options);
  ProgressBar bar;
  const auto progress = [&](const std::string& step, double f) {
    if (!quiet) bar(step, f);
  };
  const lfi::LightField reference = controller.captureReference([&](const char* step, double f) { progress(step, f); });
  if (captures) lfi::writeLightFieldExr(referenceFile, reference, overwrite);
  lfi::DistanceScanRun run;
  try {
    run = lfi::scanDisplayDistance(controller, reference, candidates, roi, progress);
  } catch (const lfi::Error& e) {
    if (!captures) throw;
    throw lfi::Error(e.code(), fmt::format("{} (the captured reference is kept: --light-field {} scans again "
                                           "without capturing)",
                                           e.what(), referenceFile.string()));
  }
  bar.finish();
  // The table first: should the file fail to be written, the scan is not lost.
  printScan(run.scan, reference.geometry().distance_mm);
  const lfi::DistanceScanSource source{.benchFile = a.bench,
                                       .capture = capture->description(),
                                       .referenceFile = referenceFile,
                                       .referenceDistance_mm = reference.geometry().distance_mm,
                                       .cameraUri = devices.cameraUri,
                                       .displayUri = devices.displayUri,
                                       .camera = camera->info(),
                                       .cameraSettings = camera->settings(),
                                       .frames = options.frames,
                                       .settle_ms = bench.settle_ms,
                                       .roi_px = a.roiBox};
  lfi::writeFileAtomically(out, overwrite, lfi::distanceScanRecord(source, run));
  fmt::print("{}\n", out.string());
}

}  // namespace

Command addCalibrateDistanceCommand(CLI::App& app) {
  auto* command = app.add_subcommand("calibrate-distance",
                                     "Scan the display-to-part distance error with the bench's devices by showing the "
                                     "reference light field propagated to candidate distances (docs/calibration.md)");
  auto a = std::make_shared<DistanceArgs>();
  addBenchArgument(*command, a->bench);
  command
      ->add_option("--part", a->part,
                   "A simulated bench: the scene under its camera during the scan (a physical bench scans the "
                   "intact part in its place)")
      ->check(CLI::ExistingFile);
  command
      ->add_option("--light-field", a->lightField,
                   "Scan with this reference light field (EXR) instead of the bench's [capture]")
      ->check(CLI::ExistingFile);
  command->add_option("--frames", a->frames, "Frames averaged per image (default: the bench's [inspection] frames)")
      ->check(CLI::Range(1, 100000));
  command->add_option("--from", a->scanFrom, "First candidate error (mm)")->capture_default_str();
  command->add_option("--to", a->scanTo, "Last candidate error (mm)")->capture_default_str();
  command->add_option("--step", a->scanStep, "Candidate spacing (mm)")->capture_default_str();
  command->add_option("--roi", a->roiBox, "The part's pixels in the camera image: x,y,width,height (default: all)")
      ->delimiter(',')
      ->expected(4);
  command->add_option("--out", a->out, "Result file (JSON)")->required();
  command->add_flag("--force", a->force,
                    "Replace an existing result file, and the captured reference kept beside it (scan.json: "
                    "scan.lightfield.exr)");
  return {command, [a](const GlobalOptions& global) {
            calibrateDistance(*a, scanCandidates(a->scanFrom, a->scanTo, a->scanStep), global.quiet);
            return 0;
          }};
}

}  // namespace lfi::cli
