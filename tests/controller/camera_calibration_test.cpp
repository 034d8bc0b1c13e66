// SPDX-License-Identifier: Apache-2.0
// The camera's scale measured on a chessboard target through the ray-traced
// bench, camera noise on, against the truth the scene gives (the camera's
// magnification): trials over the camera's scale (±2 %), the board's turn
// (±5°) and place (±1 mm) and the camera's axis (±1 mm); the same bench's
// display calibration agreeing within the two uncertainties; the refusals.

#include "lfi/controller/camera_calibration.h"
#include "lfi/controller/display_calibration.h"
#include "lfi/core/error.h"
#include "lfi/sim/devices/sim_camera.h"

#include "calibration_bench.h"
#include "lfi_test_support.h"
#include "test_folder.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>

namespace camera_calibration_test {
namespace {

using namespace lfi;
using lfi::testing_support::cameraSceneText;
using lfi::testing_support::inspectionBenchCamera;
using lfi::testing_support::kBenchSensorPixel_mm;
using lfi::testing_support::TestFolder;
using lfi::testing_support::throughSimBench;
using lfi::testing_support::throwsError;

// The inspection bench's camera (calibration_bench.h) over a 1000 x 1000 panel (31.5 mm: it fills the camera's 28 mm
// field) of a 1 mm lens array, 30 mm below the camera's focus, where the board lies: 6 x 6 squares of 3 mm (5 x 5 inner
// corners, 6 camera pixels a square), a margin of 4 pixels or more about it at any turn and place of the trials. A
// board of `squares` x `squares` of `square_mm` in its own xy plane, centred, its dark squares opaque (PLY,
// docs/scene-files.md).
std::string chessboardPly(int squares, double square_mm) {
  std::string vertices, faces;
  int count = 0;
  const double start = -0.5 * squares * square_mm;
  for (int j = 0; j < squares; ++j)
    for (int i = 0; i < squares; ++i) {
      if ((i + j) % 2) continue;
      const double x = start + i * square_mm, y = start + j * square_mm;
      vertices += fmt::format("{} {} 0\n{} {} 0\n{} {} 0\n{} {} 0\n", x, y, x + square_mm, y, x + square_mm,
                              y + square_mm, x, y + square_mm);
      faces += fmt::format("4 {} {} {} {}\n", 4 * count, 4 * count + 1, 4 * count + 2, 4 * count + 3);
      ++count;
    }
  return fmt::format(
      "ply\nformat ascii 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\n"
      "element face {}\nproperty list uchar int vertex_indices\nend_header\n{}{}",
      4 * count, count, vertices, faces);
}

struct Truth {
  double sensorPixel_mm = kBenchSensorPixel_mm;
  Vec2 cameraAxis_mm{0, 0};
  double boardTurn_deg = 0;
  Vec2 board_mm{0, 0};
  bool board = true;
  int seed = 1;
  double objectPixel_mm() const { return testing_support::objectPixel_mm(sensorPixel_mm); }
};

class CameraCalibrationTest : public testing::Test {
 protected:
  void SetUp() override {
    sim::registerSimBackends();
    dir_.write("board.ply", chessboardPly(6, 3));
  }

  // 64 samples per pixel: the corners are found on the squares' edges, where with 8 the simulation's own noise
  // (an edge pixel's share of white known to about ±18 %) would outweigh the camera's.
  std::string sceneText(const Truth& t) const {
    std::string text =
        cameraSceneText(inspectionBenchCamera(64, t.seed, t.sensorPixel_mm, t.cameraAxis_mm.x, t.cameraAxis_mm.y)) +
        "[display]\nposition_mm = [0, 0, -30]\noptics = \"lenslet_array\"\n"
        "panel_width_px = 1000\npanel_height_px = 1000\n";
    if (t.board)
      text += fmt::format(
          "[[object]]\nname = \"target\"\nshape = \"mesh\"\nfile = \"board.ply\"\nposition_mm = [{}, {}, 0]\n"
          "rotation_deg = [0, 0, {}]\n",
          t.board_mm.x, t.board_mm.y, t.boardTurn_deg);
    return text;
  }

  template <typename Calibrate>
  auto through(const Truth& truth, Calibrate&& calibrate) {
    const std::string uri = "sim:" + dir_.write("scene.toml", sceneText(truth)).string();
    return throughSimBench(uri, [&](BenchProbe& probe) { return calibrate(probe, uri); });
  }

  CameraCalibration calibrate(const Truth& truth, const std::string& corners = "5x5",
                              const CameraCalibrationSettings& settings = {}) {
    return through(truth, [&](BenchProbe& probe, const std::string& uri) {
      return calibrateCamera(probe, calib::ChessboardTarget::parse(corners, 3), uri, settings);
    });
  }

  TestFolder dir_{"camera_calibration"};
};

// What a calibration must get right: a point at the field's edge (28 px out) within a tenth of a camera pixel,
// as the display calibration's scale (display_calibration_test.cpp).
constexpr double kScaleTolerance = 0.1 / 28;

TEST_F(CameraCalibrationTest, RecoversTheCameraScaleOverItsRange) {
  std::mt19937 random(20261128);
  std::uniform_real_distribution<double> unit(-1, 1);
  const int trials = 10;
  int covered = 0, distortionCovered = 0;
  for (int trial = 0; trial < trials; ++trial) {
    Truth truth;
    truth.seed = trial + 1;
    truth.sensorPixel_mm = kBenchSensorPixel_mm * (1 + 0.02 * unit(random));
    truth.cameraAxis_mm = {unit(random), unit(random)};
    truth.boardTurn_deg = 5 * unit(random);
    truth.board_mm = {unit(random), unit(random)};
    SCOPED_TRACE(
        fmt::format("trial {}: object pixel {:.5f} mm, axis [{:.2f}, {:.2f}], board {:.2f}° at [{:.2f}, "
                    "{:.2f}]",
                    trial, truth.objectPixel_mm(), truth.cameraAxis_mm.x, truth.cameraAxis_mm.y, truth.boardTurn_deg,
                    truth.board_mm.x, truth.board_mm.y));
    const CameraCalibration c = calibrate(truth);
    EXPECT_EQ(c.camera.points, 25);
    EXPECT_EQ(c.frames, 1);
    const double error = c.camera.objectPixel_mm - truth.objectPixel_mm();
    EXPECT_LE(std::abs(error), kScaleTolerance * truth.objectPixel_mm());
    // Square pixels (to the same tolerance) and no distortion in the simulated camera.
    EXPECT_LE(std::abs(c.camera.pixelX_mm - c.camera.pixelY_mm), kScaleTolerance * truth.objectPixel_mm());
    covered += std::abs(error) <= c.coverageFactor * c.camera.objectPixelSigma_mm;
    distortionCovered += std::abs(c.camera.distortion_px) <= c.coverageFactor * c.camera.distortionSigma_px;
  }
  // The k = 2 uncertainties cover the errors in at least 90 % of the trials. Not held here: the other side (U not
  // much larger than the errors). The scale's U is set by the detector's corner bias, taken as an error shared by
  // a column (row) of corners and independent between columns; on a board of 6-pixel squares neighbouring columns
  // sit at nearly one phase, so much of the bias is probably common to the board and moves it rather than scaling
  // it: the errors spread less than U says (60 trials: rms z 0.70 for the scale, 0.80 for the distortion,
  // docs/calibration.md), by a factor the uncertainty's model does not bound. chessboard_target_test.cpp holds
  // that model from the other side instead: the bias's size on held-out boards, and its spread through the fit.
  EXPECT_GE(covered, 9);
  EXPECT_GE(distortionCovered, 9);
}

TEST_F(CameraCalibrationTest, AgreesWithTheDisplayCalibrationOfTheSameBench) {
  Truth truth;
  truth.sensorPixel_mm = kBenchSensorPixel_mm * 1.013;
  const CameraCalibration onTarget = calibrate(truth);
  truth.board = false;
  const DisplayCalibration onDisplay =
      through(truth, [](BenchProbe& probe, const std::string&) { return calibrateDisplay(probe); });
  const double u = std::hypot(onTarget.coverageFactor * onTarget.camera.objectPixelSigma_mm,
                              onDisplay.coverageFactor * onDisplay.camera.objectPixelSigma_mm);
  EXPECT_LE(std::abs(onTarget.camera.objectPixel_mm - onDisplay.camera.objectPixel_mm), u);
}

TEST_F(CameraCalibrationTest, TheTargetsToleranceGoesIntoTheScalesUncertainty) {
  const CameraCalibration c = calibrate({}, "5x5", {.targetTolerance = 0.01});
  EXPECT_GE(c.camera.objectPixelSigma_mm, 0.01 * c.camera.objectPixel_mm);
  EXPECT_LE(c.camera.objectPixelSigma_mm, 0.0101 * c.camera.objectPixel_mm);
}

TEST_F(CameraCalibrationTest, RefusesABenchWithoutTheBoardAndABoardOfAnotherSize) {
  Truth empty;
  empty.board = false;
  EXPECT_TRUE(
      throwsError([&] { calibrate(empty); }, Errc::Device,
                  {"camera calibration of camera 'sim:", "no chessboard of 5 x 5 inner corners, 3 mm squares"}));
  EXPECT_TRUE(throwsError([&] { calibrate({}, "6x5"); }, Errc::Device, {"no chessboard of 6 x 5 inner corners"}));
  EXPECT_TRUE(throwsError([&] { calibrate({}, "5x5", {.targetTolerance = 0.5}); }, Errc::InvalidArgument,
                          {"target_tolerance = 0.5"}));
}

}  // namespace
}  // namespace camera_calibration_test
