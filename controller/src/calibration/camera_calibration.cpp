// SPDX-License-Identifier: Apache-2.0
#include "lfi/controller/camera_calibration.h"

#include "gray_code_view.h"
#include "optics_table.h"
#include "record_json.h"

#include "lfi/core/error.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>

namespace lfi {

using detail::Clock;
using detail::seconds;

CameraCalibration calibrateCamera(BenchProbe& bench, const calib::ChessboardTarget& target, const std::string& camera,
                                  const CameraCalibrationSettings& settings,
                                  const std::function<void(double)>& progress) {
  if (!(settings.targetTolerance >= 0 && settings.targetTolerance <= 0.1))
    fail(Errc::InvalidArgument, "camera calibration: target_tolerance = {} is outside 0 .. 0.1",
         settings.targetTolerance);
  if (!(settings.coverageFactor > 0 && settings.coverageFactor <= 10))
    fail(Errc::InvalidArgument, "camera calibration: coverage_factor = {} is outside (0, 10]", settings.coverageFactor);
  const auto start = Clock::now();
  CameraCalibration out;
  out.target = target;
  out.coverageFactor = settings.coverageFactor;
  out.targetTolerance = settings.targetTolerance;
  const DisplayInfo info = bench.display();
  detail::FrameTaker take(bench, "camera calibration", info.deviceId, 1, progress);
  const cv::Mat image = take(cv::Mat(info.panelHeight_px, info.panelWidth_px, CV_8UC1, cv::Scalar(255)), "all white");
  const auto computeStart = Clock::now();
  out.image = image.size();
  try {
    out.camera = calib::fitCameraScale(calib::findChessboard(image, target), out.image, {settings.targetTolerance, {}},
                                       calib::kChessboardCornerBias_px);
  } catch (const Error& e) {
    fail(e.code(), "camera calibration of camera '{}': {}", camera, e.what());
  }
  out.frames = take.frames();
  if (progress) progress(1);
  out.computeSeconds = seconds(Clock::now() - computeStart);
  out.seconds = seconds(Clock::now() - start);
  return out;
}

void setCameraCalibration(BenchFileEdit& edit, const CameraCalibration& c, const std::string& stampUtc) {
  const double k = c.coverageFactor;
  detail::setMeasured(edit, "camera", "object_pixel_mm", {c.camera.objectPixel_mm}, {c.camera.objectPixelSigma_mm}, k,
                      fmt::format("lfi calibrate camera {} on a chessboard of {}", stampUtc, c.target.describe()));
}

std::string cameraCalibrationRecord(const CameraCalibration& c, const BenchFile& bench, const std::string& stampUtc,
                                    const std::string& cameraDescription) {
  using detail::measured;
  const double k = c.coverageFactor;
  const calib::CameraScaleFit& m = c.camera;
  nlohmann::json previous = {{"object_pixel_mm", bench.objectPixel_mm}};
  if (bench.cameraOnDisplay) previous["display_calibration_object_pixel_mm"] = bench.cameraOnDisplay->objectPixel_mm();
  nlohmann::json record = {
      {"format", "lfi-calibration-record"},
      {"version", 1},
      {"what", "camera"},
      {"time_utc", stampUtc},
      {"bench", bench.file.string()},
      {"units", "mm, camera pixels (px); lengths on the target's plane, the part's"},
      {"method",
       "a chessboard target in the part's place, the display all white; its inner corners found with OpenCV's "
       "findChessboardCornersSB (sub-pixel) and fitted with an affine camera (docs/calibration.md)"},
      {"coverage_factor", k},
      {"target",
       {{"kind", "chessboard"},
        {"inner_corners", {c.target.corners.width, c.target.corners.height}},
        {"square_mm", c.target.square_mm},
        {"relative_tolerance", c.targetTolerance}}},
      {"camera",
       {{"uri", bench.cameraUri.text()}, {"device", cameraDescription}, {"image_px", {c.image.width, c.image.height}}}},
      {"previous", previous},
      {"camera_scale",
       {{"object_pixel", measured(m.objectPixel_mm, m.objectPixelSigma_mm, k, "mm")},
        {"pixel_x_mm", m.pixelX_mm},
        {"pixel_y_mm", m.pixelY_mm},
        {"distortion_at_corner", measured(m.distortion_px, m.distortionSigma_px, k, "px")},
        {"residual_rms_mm", m.residualRms_mm},
        {"corners", m.points}}},
      {"frames", c.frames},
      {"seconds", c.seconds},
      {"compute_seconds", c.computeSeconds},
  };
  return record.dump(2) + "\n";
}

}  // namespace lfi
