// SPDX-License-Identifier: Apache-2.0
#pragma once
// The camera's object-space scale from a chessboard target in the part's
// place (`lfi calibrate camera`): a board of known squares (a printed one, or
// chrome on glass back-lit by the display), its inner corners found with
// OpenCV's calib3d (calib/chessboard_target.h) and fitted with the affine
// camera of calib/camera_scale.h. One frame, the display all white (the back
// light of a glass target; a target lit from the front is seen the same).
//
// What it gives: the scale (mm per pixel on the part), the pixel's two sides,
// and the lens's residual distortion. Not the camera's rotation or where it
// looks (the target lies where it was put, and a chessboard's symmetry leaves
// its orientation open): those come from `lfi calibrate display`, whose scale
// this one checks with a length that does not depend on the display.
//
// The target must lie flat and square to the axis: a tilt θ shortens one
// side by cos θ (0.015 % at 1°), which the fit reads as a pixel of unequal
// sides. Uncertainty as in camera_scale.h, the corners of one column and of
// one row grouped; with the board's own relative tolerance (a printed board's
// scale, a glass one's pitch error) added to the scale's.
//
// Refusals: Errc::Device when the board is not in the image (calib's
// findChessboard: out of view, unlit, another size, cut by the image's edge,
// squares too small), naming the camera.

#include "lfi/calib/camera_scale.h"
#include "lfi/calib/chessboard_target.h"
#include "lfi/controller/bench_file.h"
#include "lfi/controller/bench_file_edit.h"
#include "lfi/drivers/light_field_capture.h"

#include <functional>
#include <string>

namespace lfi {

struct CameraCalibrationSettings {
  double targetTolerance = 0;  // the board's relative scale uncertainty (standard), 0 .. 0.1
  double coverageFactor = 2;   // k of the expanded uncertainties
};

struct CameraCalibration {
  calib::ChessboardTarget target;
  calib::CameraScaleFit camera;  // in the target's frame: its scale, sides and distortion hold; its map does not
  cv::Size image;
  double coverageFactor = 2;
  double targetTolerance = 0;
  int frames = 0;
  double seconds = 0;         // the whole calibration
  double computeSeconds = 0;  // of it, finding the corners and fitting
};

// Measures through `bench` (Controller::probe()); `camera` names the camera in
// messages. Errc::InvalidArgument for settings out of range; the refusals above.
CameraCalibration calibrateCamera(BenchProbe& bench, const calib::ChessboardTarget& target, const std::string& camera,
                                  const CameraCalibrationSettings& settings = {},
                                  const std::function<void(double)>& progress = {});

// What `lfi calibrate camera` writes into a bench file: [camera]
// object_pixel_mm, its comment naming the calibration, its time, the target
// and its U (k).
void setCameraCalibration(BenchFileEdit& edit, const CameraCalibration& calibration, const std::string& stampUtc);

// The calibration's record (JSON, format "lfi-calibration-record" version 1,
// `what` "camera"): the target, the scale with its uncertainties, the pixel's
// sides, the distortion, the residual, the scale the bench stated before and,
// when the bench holds the display calibration's camera map, that map's scale.
std::string cameraCalibrationRecord(const CameraCalibration& calibration, const BenchFile& bench,
                                    const std::string& stampUtc, const std::string& cameraDescription);

}  // namespace lfi
