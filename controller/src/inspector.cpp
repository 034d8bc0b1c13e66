// SPDX-License-Identifier: Apache-2.0
#include "lfi/controller/inspector.h"

#include "lfi/controller/bench_devices.h"
#include "lfi/core/error.h"

#include <chrono>
#include <cmath>

namespace lfi {

CameraNoise noiseOfMean(const CameraNoise& perFrame, int frames) {
  return {perFrame.read_dn / std::sqrt(frames), perFrame.gain_dnPerElectron / frames};
}

Inspector::Inspector(const BenchFile& bench, const ReferencePackage& package, Display& display, Camera& camera,
                     std::shared_ptr<const PartModel> part)
    : bench_(bench),
      white_(package.info.white),
      mask_(package.mask),
      frame_(bench.partFrame(package.mask.cols, package.mask.rows)),
      part_(std::move(part)),
      finder_(package.trainer.model(noiseOfMean(bench.noise, bench.inspectionFrames)), package.mask, bench.detection()),
      panel_(package.panel),
      reference_(std::make_unique<StoredLightField>(package.lightField, "the reference package's light field")),
      controller_(*reference_, display, camera, controllerOptions(bench, bench.inspectionFrames)) {
  if (panel_.empty()) return;
  const DisplayInfo info = display.info();
  if (panel_.cols != info.panelWidth_px || panel_.rows != info.panelHeight_px)
    fail(Errc::Config,
         "{}: the reference package's panel image is {} x {}, display '{}' has a {} x {} panel (another "
         "display at the same URI?): take a new reference with `lfi capture {} --force`",
         bench.file.string(), panel_.cols, panel_.rows, info.deviceId, info.panelWidth_px, info.panelHeight_px,
         bench.file.string());
}

Inspector::~Inspector() = default;

void Inspector::showReference() {
  if (panel_.empty())
    controller_.emit(reference_->lightField(), white_);
  else
    controller_.showPanel(panel_);
}

cv::Mat Inspector::takeImage() {
  cv::Mat image = controller_.inspect();
  controller_.requireShowing();  // (after the exposures: the display showed the reference all through them)
  return image;
}

PartInspection Inspector::inspectPart() {
  PartInspection result;
  result.image = takeImage();
  const auto start = std::chrono::steady_clock::now();
  result.verdict = judge(result.image);
  result.analysis_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return result;
}

PartVerdict Inspector::judge(const cv::Mat& image) const {
  if (image.size() != mask_.size())
    fail(Errc::Device,
         "inspect: the camera's image is {} x {}, the reference's {} x {} (a changed camera region or "
         "binning? take a new reference with `lfi capture`)",
         image.cols, image.rows, mask_.cols, mask_.rows);
  PartVerdict verdict = judgePart(finder_.find(image), frame_, bench_.rules);
  if (part_)
    for (PartDefect& d : verdict.defects) d.inside_mm = part_->atDepth(d.centroid_mm, bench_.defectDepth_mm);
  return verdict;
}

}  // namespace lfi
