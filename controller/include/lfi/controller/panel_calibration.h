// SPDX-License-Identifier: Apache-2.0
#pragma once
// The panel's drive-to-light curve and its backlight, measured through the
// camera with nothing in view (`lfi calibrate panel`, docs/calibration.md):
//
//   curve      the panel uniform at each drive level (one curve with every
//              subpixel alike; on a colour panel one per colour, that
//              colour's subpixels alone lit): R(v) = (m(v) - m(0)) / (m(255) - m(0)),
//              m the image's mean over the camera pixels that see the panel
//   backlight  the all-white image less the dark one, each camera pixel at
//              the display point it sees (the display calibration's camera
//              map), fitted by least squares with B(x, y) (panel_response.h)
//              and divided by its value at the panel's centre
//
// Take the camera's dark and flat frames first: vignetting read as backlight
// would be compensated on the panel. The curve's points need only the
// camera's linearity; the backlight needs the camera map.
//
// Uncertainty (standard; U = k times it): the noise of an image's mean, from
// the difference of two full-white images and of two dark ones (the larger,
// over sqrt(2) and the root of the pixels' count), propagated into each
// ratio; the backlight's from the fit's residuals and its normal matrix.
//
// A camera that clips its dark at 0 DN (no black level above its read noise)
// reads its darkest levels low by what it clips; darkClipped says how many
// pixels it clipped, and `lfi calibrate panel` warns from 1 %.
//
// Refusals: Errc::Device, naming the camera, when the light does not rise
// from dark to full drive by 100 times that noise (the display is off or not
// in view), or fewer than 100 camera pixels see the panel.

#include "lfi/calib/camera_scale.h"
#include "lfi/controller/bench_file.h"
#include "lfi/controller/bench_file_edit.h"
#include "lfi/drivers/light_field_capture.h"
#include "lfi/drivers/panel_response.h"

#include <array>
#include <functional>
#include <string>
#include <vector>

namespace lfi {

struct PanelCalibrationSettings {
  int levelStep = 16;         // the levels 0, step, 2 step, .., 255; 1 .. 128
  double coverageFactor = 2;  // k of the expanded uncertainties
};

struct PanelCalibration {
  PanelResponseParams response;
  std::vector<std::vector<double>> lightSigma;  // per curve and level (standard)
  std::array<double, 6> backlightSigma{};
  double backlightResidual = 0;  // rms of the fit's relative residuals
  double meanNoise_dn = 0;       // the noise of an image's mean
  double fullLight_dn = 0;       // m(255) - m(0), every subpixel lit
  int pixels = 0;                // camera pixels that see the panel
  double darkClipped = 0;        // the fraction of them at 0 DN in the dark image
  DisplayInfo display;
  double coverageFactor = 2;
  int frames = 0;
  double seconds = 0;
};

// Measures through `bench` (Controller::probe()); `camera` names the camera
// in messages, `cameraOnDisplay` is the bench's [geometry] camera map.
PanelCalibration calibratePanel(BenchProbe& bench, const calib::CameraMap& cameraOnDisplay, const std::string& camera,
                                const PanelCalibrationSettings& settings = {},
                                const std::function<void(double)>& progress = {});

// What `lfi calibrate panel` writes into a bench file: [display.response]
// levels, light (or red, green, blue), backlight and each one's `_u`
// (expanded, k named in the comment).
void setPanelCalibration(BenchFileEdit& edit, const PanelCalibration& calibration, const std::string& stampUtc);

// The calibration's record (JSON, "lfi-calibration-record" version 1, `what` "panel").
std::string panelCalibrationRecord(const PanelCalibration& calibration, const BenchFile& bench,
                                   const std::string& stampUtc, const std::string& cameraDescription);

}  // namespace lfi
