// SPDX-License-Identifier: Apache-2.0
#include "lfi/controller/distance_scan.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <cmath>

namespace fs = std::filesystem;

namespace lfi {

DistanceScanRun scanDisplayDistance(Controller& controller, const LightField& reference,
                                    const std::vector<double>& candidates_mm, const cv::Mat& roi,
                                    const std::function<void(const std::string&, double)>& progress) {
  DistanceScanRun run;
  run.white = Controller::defaultWhite(reference);
  std::size_t done = 0;
  const std::size_t images = candidates_mm.size() + 3;  // and two with the display dark, and the brightest again
  run.scan = calib::calibrateDisplayDistance(
      reference,
      [&](const LightField& shown) {
        if (progress) progress(fmt::format("image {} of {}", done + 1, images), static_cast<double>(done) / images);
        ++done;
        controller.emit(shown, run.white);
        return controller.inspect();
      },
      candidates_mm, roi, 1 / std::sqrt(12.0));  // a digital number's quantisation (alike frames keep it)
  if (progress) progress("scan", 1);
  return run;
}

std::string distanceScanRecord(const DistanceScanSource& s, const DistanceScanRun& run) {
  const calib::DisplayDistanceScan& scan = run.scan;
  nlohmann::ordered_json r;
  r["format"] = "lfi-display-distance-scan";
  r["version"] = 1;
  r["units"] = "mm; brightness in the camera's digital numbers";
  r["convention"] =
      "epsilon > 0: the display is further from the part than the reference light field's distance_mm; the "
      "estimate is the centre of the brightness peak, half-way between where it falls below `level` on either "
      "side (docs/calibration.md)";
  r["bench"] = fs::absolute(s.benchFile).lexically_normal().string();
  r["reference"] = {
      {"source", s.capture}, {"file", fs::absolute(s.referenceFile).string()}, {"distance_mm", s.referenceDistance_mm}};
  r["camera"] = {{"uri", s.cameraUri.text()},
                 {"vendor", s.camera.vendor},
                 {"model", s.camera.model},
                 {"serial", s.camera.serial},
                 {"exposure_us", s.cameraSettings.exposure_us},
                 {"gain", s.cameraSettings.gain},
                 {"pixel_format", toString(s.cameraSettings.pixelFormat)},
                 {"binning", s.cameraSettings.binning},
                 {"frames", s.frames},
                 {"settle_ms", s.settle_ms}};
  r["display"] = {{"uri", s.displayUri.text()}, {"white", run.white}};
  r["roi_px"] = s.roi_px.empty() ? nlohmann::ordered_json(nullptr) : nlohmann::ordered_json(s.roi_px);
  r["dark"] = scan.dark;
  r["noise"] = scan.noise;
  r["dark_noise"] = scan.darkNoise;
  r["candidates_mm"] = scan.candidates_mm;
  r["brightness"] = scan.brightness;
  r["level"] = scan.level;
  r["estimate_mm"] = scan.estimate_mm;
  r["peak_width_mm"] = scan.width_mm;
  // Device strings and paths need not be UTF-8: replace what is not.
  return r.dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace) + "\n";
}

}  // namespace lfi
