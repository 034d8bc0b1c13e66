// SPDX-License-Identifier: Apache-2.0
#include "lfi/controller/reference_capture.h"

#include "lfi/controller/bench_devices.h"
#include "lfi/controller/inspection_record.h"
#include "lfi/core/error.h"

#include <fmt/format.h>
#include <opencv2/core.hpp>

#include <filesystem>

namespace lfi {

ReferencePackage takeReference(const BenchFile& bench, LightFieldCapture& capture, Display& display, Camera& camera,
                               const Controller::Progress& progress, ReferenceCoverage* coverage) {
  Controller controller(capture, display, camera, controllerOptions(bench, bench.inspectionFrames));
  const auto step = [&](const char* what, double f) {
    if (progress) progress(what, f);
  };
  ReferencePackage package;
  package.lightField = controller.captureReference(progress);
  package.panel = controller.referencePanel();
  controller.emitReference(package.lightField);
  // The golden model learns images as inspections take them: each the mean of the inspection's frames.
  for (int i = 0; i < bench.referenceFrames; ++i) {
    step("golden model", static_cast<double>(i) / bench.referenceFrames);
    package.trainer.add(controller.inspect());
  }
  step("golden model", 1);
  const cv::Mat ideal = package.trainer.mean();
  const PartFrame frame = bench.partFrame(ideal.cols, ideal.rows);
  const double radius_px = bench.maskRadius_mm ? *bench.maskRadius_mm / bench.objectPixel_mm : -1.0;
  package.mask = partMask(ideal, frame.origin_px.x, frame.origin_px.y, radius_px, bench.maskLitFraction);
  if (coverage) {
    coverage->partPixels = cv::countNonZero(partMask(ideal, frame.origin_px.x, frame.origin_px.y, radius_px, 0));
    coverage->inspectedPixels = cv::countNonZero(package.mask);
    cv::Scalar mean, deviation;
    cv::meanStdDev(ideal, mean, deviation, package.mask);
    coverage->mean_dn = mean[0];
    coverage->cv = mean[0] > 0 ? deviation[0] / mean[0] : 0.0;
  }
  ReferenceInfo& info = package.info;
  info.benchFile = std::filesystem::absolute(bench.file).string();
  info.benchHash = bench.referenceHash();
  info.created_utc = info.updated_utc = utcNow();
  info.camera = describeCamera(camera, bench.cameraUri);
  info.display = fmt::format("{} ({})", display.info().deviceId, bench.displayUri);
  info.capture = capture.description();
  info.exposure_us = bench.camera.exposure_us;
  info.gain = bench.camera.gain;
  info.pixelFormat = toString(bench.camera.pixelFormat);
  info.white = controller.white();
  return package;
}

}  // namespace lfi
