// SPDX-License-Identifier: Apache-2.0
#pragma once
// The display-to-part distance scan through a bench's own devices (`lfi
// calibrate-distance`, docs/calibration.md): the reference light field shown
// propagated to each candidate error ε and the part's brightness measured
// (calib/display_distance.h), and the scan's record.

#include "lfi/calib/display_distance.h"
#include "lfi/controller/controller.h"
#include "lfi/drivers/camera.h"
#include "lfi/drivers/device_uri.h"

#include <opencv2/core.hpp>

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace lfi {

struct DistanceScanRun {
  calib::DisplayDistanceScan scan;
  double white = 0;  // the drive scale of every candidate shown (the reference's, Controller::defaultWhite)
};

// Shows `reference` propagated to each candidate (mm) through `controller`
// with one drive scale, so that the brightness compares the display's
// position and not the fields' peaks; `roi` (CV_8UC1, the camera's size, or
// empty: all) selects the part's pixels. `progress(label, fraction)` after
// each image. Throws what calibrateDisplayDistance and the devices throw.
DistanceScanRun scanDisplayDistance(Controller& controller, const LightField& reference,
                                    const std::vector<double>& candidates_mm, const cv::Mat& roi,
                                    const std::function<void(const std::string&, double)>& progress = {});

// What a scan's record names besides the scan.
struct DistanceScanSource {
  std::filesystem::path benchFile;
  std::string capture;                  // the reference's source (LightFieldCapture::description)
  std::filesystem::path referenceFile;  // where the reference light field is kept
  double referenceDistance_mm = 0;      // the Δ it was recorded at
  DeviceUri cameraUri, displayUri;
  CameraInfo camera;
  CameraSettings cameraSettings;
  int frames = 1;           // averaged per image
  int settle_ms = 0;        // the panel's
  std::vector<int> roi_px;  // x, y, width, height; empty: the whole image
};

// The record, format "lfi-display-distance-scan" version 1, as indented JSON
// text (docs/calibration.md lists its fields; text that is not UTF-8 is replaced).
std::string distanceScanRecord(const DistanceScanSource& source, const DistanceScanRun& run);

}  // namespace lfi
