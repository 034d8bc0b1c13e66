// SPDX-License-Identifier: Apache-2.0
#pragma once
// The camera's exposure for the bench (`lfi calibrate exposure`,
// docs/calibration.md): with the intact part in view and the display all
// white, the brightest light any panel image can send through the part to
// each camera pixel, the exposure at which the image's brightest pixels (its
// 99.9th percentile, less the dark image's median) sit at `fraction` of the
// camera's full scale and no pixel saturates. The camera is taken to be
// linear in its exposure: each round scales the exposure by what the
// brightest pixels lack, and a round with saturated pixels halves it first.
//
// Refusals: Errc::Device, naming the camera, when the image does not rise
// above the dark one (the display off, the lens capped), when the camera
// refuses an exposure it would need (its range ends first: more light or a
// gain), or when 8 rounds do not settle within 1 % of the fraction.

#include "lfi/controller/bench_file.h"
#include "lfi/controller/bench_file_edit.h"
#include "lfi/controller/controller.h"
#include "lfi/drivers/camera.h"
#include "lfi/drivers/display.h"

#include <functional>
#include <string>

namespace lfi {

struct ExposureCalibrationSettings {
  double fraction = 0.8;  // of full scale, 0.05 .. 0.98
};

struct ExposureCalibration {
  double exposure_us = 0;   // as the camera applied it
  double brightest_dn = 0;  // the 99.9th percentile at it, less the dark median
  double dark_dn = 0;       // the dark image's median at it
  double fullScale_dn = 0;
  double startExposure_us = 0;  // the bench's before
  int rounds = 0;
  double seconds = 0;
};

// Measures with `camera` (Open or Configured, configured here from `settings`
// with each round's exposure; left Configured at the result) and `display`
// through controllers of `options` (their frame correction left out: dark and
// flat frames belong to one exposure).
ExposureCalibration calibrateExposure(Camera& camera, Display& display, const CameraSettings& settings,
                                      ControllerOptions options, const ExposureCalibrationSettings& calibration = {},
                                      const std::function<void(double)>& progress = {});

// What `lfi calibrate exposure` writes into a bench file: [camera] exposure_us,
// its comment naming the calibration, its time and the fraction; the dark and
// flat frames, taken at another exposure, leave the bench (they must be taken again).
void setExposureCalibration(BenchFileEdit& edit, const ExposureCalibration& calibration, double fraction,
                            const std::string& stampUtc);

// The calibration's record (JSON, "lfi-calibration-record" version 1, `what` "exposure").
std::string exposureCalibrationRecord(const ExposureCalibration& calibration, double fraction, const BenchFile& bench,
                                      const std::string& stampUtc, const std::string& cameraDescription);

}  // namespace lfi
