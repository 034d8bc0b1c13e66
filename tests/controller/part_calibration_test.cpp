// SPDX-License-Identifier: Apache-2.0
// Δ, the part's lateral position and the display's gap measured through the
// intact part on the ray-traced bench, camera noise on, against the truth the
// scene gives: the display's height below the lens, the lens's place across
// the axis and the display's gap. The camera's map on the display comes from
// the display calibration with the lens taken away, as on a bench. Trials over
// the ranges (Δ ±20 %, lateral ±1 mm, gap ±10 %), each its own noise
// draw; the refusals.

#include "lfi/controller/part_calibration.h"
#include "lfi/controller/display_calibration.h"
#include "lfi/core/error.h"
#include "lfi/sim/devices/sim_camera.h"
#include "lfi/sim/scene_part_model.h"

#include "calibration_bench.h"
#include "lfi_test_support.h"
#include "test_folder.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <optional>
#include <random>
#include <string>

namespace {

using namespace lfi;
using lfi::testing_support::cameraSceneText;
using lfi::testing_support::chiSquareLower1e3;
using lfi::testing_support::inspectionBenchCamera;
using lfi::testing_support::lensObject;
using lfi::testing_support::maxOfEstimatesInflation;
using lfi::testing_support::NormalisedErrors;
using lfi::testing_support::TestFolder;
using lfi::testing_support::throughSimBench;
using lfi::testing_support::throwsError;

constexpr double kStatedDistance_mm = 30, kStatedGap_mm = 1.37;

struct Truth {
  double distance_mm = kStatedDistance_mm;
  Vec2 lateral_mm{0, 0};
  double gap_mm = kStatedGap_mm;
  int seed = 1;
  bool part = true;
  double partIor = 1.5168;
  double tilt_deg = 0;  // about the x axis
  // The display: the lenslet array of data/scenes/inspection_bench.toml, or a lenticular sheet of the same 1 mm
  // pitch (32 panel pixels), slant 0.1 rad (a line barrier, refused: 1 mm pitch, 0.25 mm slits).
  std::string optics = "lenslet_array";
  double offset_px = 0;
};

// data/scenes/inspection_bench.toml's bench: the lens (its reference point, the centre, at the origin when in
// place) over the 800 x 800 lenslet display, 56 x 56 camera of 0.5 mm object pixels.
std::string sceneText(const Truth& t) {
  const bool barrier = t.optics == "line_barrier";
  std::string text = cameraSceneText(inspectionBenchCamera(8, t.seed)) +
                     fmt::format(
                         "[display]\nposition_mm = [0, 0, {:.17g}]\noptics = \"{}\"\npanel_width_px = 800\n"
                         "panel_height_px = 800\npixel_pitch_mm = 0.0315\ngap_mm = {:.17g}\n",
                         -t.distance_mm, t.optics, t.gap_mm);
  if (t.optics != "lenslet_array")
    text += fmt::format("lens_pitch_px = 32\nslant_rad = 0.1\noffset_px = {:.17g}\n", t.offset_px);
  if (barrier) text += "slit_width_mm = 0.25\n";
  if (t.part) {
    text += lensObject({.radius_mm = 51.5, .centreThickness_mm = 5, .diameter_mm = 25.4, .ior = t.partIor});
    text += fmt::format("position_mm = [{:.17g}, {:.17g}, 0]\nrotation_deg = [{}, 0, 0]\n", t.lateral_mm.x,
                        t.lateral_mm.y, t.tilt_deg);
  }
  return text;
}

class PartCalibrationTest : public testing::Test {
 protected:
  void SetUp() override {
    sim::registerSimBackends();
    model_ = std::make_unique<sim::ScenePartModel>(dir_.write("model.toml", sceneText(Truth{})));
  }

  template <typename Measure>
  auto measure(const Truth& truth, Measure&& f) {
    CameraSettings settings;  // 8 bits, free-running
    settings.exposure_us = 10000;
    return throughSimBench("sim:" + dir_.write("scene.toml", sceneText(truth)).string(), f, settings);
  }

  // The camera's map on the display, measured with the lens taken away (as `lfi calibrate display` does).
  calib::CameraMap cameraMap(const Truth& truth) {
    Truth empty = truth;
    empty.part = false;
    const DisplayCalibration d = measure(empty, [](BenchProbe& probe) { return calibrateDisplay(probe); });
    return d.camera.map;
  }

  // The camera's map is the same on every bench here (the camera and the display's place across the axis do not
  // change; a telecentric camera sees the display's plane at one scale whatever its height): measured once.
  PartCalibration calibrate(const Truth& truth, const PartCalibrationSettings& settings = {}) {
    if (!camera_) camera_ = cameraMap(Truth{});  // (through the lens array: a sheet's calibration wants focus)
    const calib::CameraMap camera = *camera_;
    return measure(truth, [&](BenchProbe& probe) {
      return calibratePart(probe, *model_, camera, kStatedDistance_mm, std::nullopt, settings);
    });
  }

  TestFolder dir_{"part_calibration"};
  std::unique_ptr<sim::ScenePartModel> model_;
  std::optional<calib::CameraMap> camera_;
};

// Tolerances, each what the bench needs: Δ and the lateral position off by so little that the rays the display
// sends reach the part within a tenth of a camera pixel (0.05 mm) of where they should, at the steepest slope the
// part gives (0.27, 15°): Δ within 0.05 / 0.27 mm, L within 0.05 mm; the gap scales every direction the display
// sends by its error: the steepest, over Δ = 30 mm, within 0.05 mm: δg / g within 0.05 / (30 · 0.27).
constexpr double kCameraTenth_mm = 0.05, kSteepest = 0.27;
constexpr double kDistanceTolerance_mm = kCameraTenth_mm / kSteepest;
constexpr double kLateralTolerance_mm = kCameraTenth_mm;
constexpr double kGapTolerance = kCameraTenth_mm / (kStatedDistance_mm * kSteepest);  // relative

TEST_F(PartCalibrationTest, RecoversDistanceLateralPositionAndGapOverTheirRanges) {
  std::mt19937 random(20261128);
  std::uniform_real_distribution<double> unit(-1, 1);
  const int trials = 20;
  int coveredDistance = 0, coveredLateral = 0, coveredGap = 0;
  NormalisedErrors spread;  // Δ's (below)
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (int trial = 0; trial < trials; ++trial) {
    Truth truth;
    truth.seed = trial + 1;
    truth.distance_mm = kStatedDistance_mm * (1 + 0.2 * unit(random));
    truth.lateral_mm = {unit(random), unit(random)};
    truth.gap_mm = kStatedGap_mm * (1 + 0.1 * unit(random));
    SCOPED_TRACE(fmt::format("trial {}: Δ {} mm, lateral ({}, {}) mm, gap {} mm", trial, truth.distance_mm,
                             truth.lateral_mm.x, truth.lateral_mm.y, truth.gap_mm));
    const PartCalibration c = calibrate(truth);
    const double k = c.coverageFactor;
    const double distanceError = c.distance_mm - truth.distance_mm, gapError = c.gap_mm - truth.gap_mm;
    const Vec2 lateralError = c.lateral_mm - truth.lateral_mm;
    EXPECT_LE(std::abs(distanceError), kDistanceTolerance_mm);
    EXPECT_LE(lateralError.length(), kLateralTolerance_mm);
    EXPECT_LE(std::abs(gapError), kGapTolerance * truth.gap_mm);
    coveredDistance += std::abs(distanceError) <= k * c.distanceSigma_mm;
    coveredLateral +=
        std::abs(lateralError.x) <= k * c.lateralSigma_mm.x && std::abs(lateralError.y) <= k * c.lateralSigma_mm.y;
    coveredGap += std::abs(gapError) <= k * c.gapSigma_mm;
    spread.add(distanceError, c.distanceSigma_mm);
    sx += truth.distance_mm, sy += c.distance_mm, sxx += truth.distance_mm * truth.distance_mm;
    sxy += truth.distance_mm * c.distance_mm;
  }
  // The stated uncertainties (k = 2) cover the errors in at least 90 % of the trials; Δ is unbiased: the
  // estimates follow the truth with a slope within 0.98 .. 1.02.
  const int least = static_cast<int>(std::ceil(0.9 * trials));
  EXPECT_GE(coveredDistance, least);
  EXPECT_GE(coveredLateral, least);
  EXPECT_GE(coveredGap, least);
  const double slope = (trials * sxy - sx * sy) / (trials * sxx - sx * sx);
  EXPECT_GE(slope, 0.98);
  EXPECT_LE(slope, 1.02);

  // Δ's U is not stated much larger than its errors: Σ z² over the 20 trials is chi-square(20) where σ is right.
  // σ is a bootstrap's (100 resamplings, ν = 99): on average up to maxOfEstimatesInflation(99) = 1.06 times the
  // truth. The camera's map, measured once, may add an error all trials share: Σ z² noncentral, larger. Held to
  // chi-square's lower 10⁻³ quantile (5.83) over 1.06, 5.52: a U twice too large quarters Σ z² and fails with
  // probability P(χ²₂₀ < 4 · 5.52) = 0.66 only (40 trials: 0.996; docs/calibration.md says why not yet). Left
  // out: the lateral position and the gap, whose σ is the floor of a panel pixel's quantisation shared by the
  // pixels of a lens, not a spread the residuals measure: the rays that land in one lens leave the part at slopes
  // that spread their panel points over two or three panel pixels, their errors are not one, and they spread 0.4
  // of σ (docs/calibration.md).
  std::printf("[ info     ] rms z of Δ: %.2f over %d\n", spread.rms(), spread.n);
  EXPECT_GE(spread.sum2, chiSquareLower1e3(spread.n) / maxOfEstimatesInflation(99)) << "rms z " << spread.rms();
}

// A lenticular sheet over the same ranges, its axes' offset anywhere in a pitch; the same tolerances for Δ and
// the gap. The code across the axes (calib/axis_code.h) is what a camera focused 30 mm above it decodes; the
// part's place is a step of the fit, across the axes only, and not written: its error across (x, the axes 0.1
// rad off the panel's columns) within its U.
TEST_F(PartCalibrationTest, RecoversDistanceAndGapThroughALenticularSheet) {
  std::mt19937 random(20261205);
  std::uniform_real_distribution<double> unit(-1, 1);
  const int trials = 10;
  int coveredDistance = 0, coveredLateral = 0, coveredGap = 0;
  for (int trial = 0; trial < trials; ++trial) {
    Truth truth;
    truth.optics = "lenticular";
    truth.seed = trial + 1;
    truth.distance_mm = kStatedDistance_mm * (1 + 0.2 * unit(random));
    truth.lateral_mm = {unit(random), unit(random)};
    truth.gap_mm = kStatedGap_mm * (1 + 0.1 * unit(random));
    truth.offset_px = 16 * unit(random);
    SCOPED_TRACE(fmt::format("trial {}: Δ {} mm, lateral ({}, {}) mm, gap {} mm, offset {} px", trial,
                             truth.distance_mm, truth.lateral_mm.x, truth.lateral_mm.y, truth.gap_mm, truth.offset_px));
    const PartCalibration c = calibrate(truth);
    const double k = c.coverageFactor;
    const double distanceError = c.distance_mm - truth.distance_mm, gapError = c.gap_mm - truth.gap_mm;
    const Vec2 lateralError = c.lateral_mm - truth.lateral_mm;
    EXPECT_LE(std::abs(distanceError), kDistanceTolerance_mm);
    EXPECT_LE(std::abs(gapError), kGapTolerance * truth.gap_mm);
    EXPECT_FALSE(c.lateralMeasured);
    coveredDistance += std::abs(distanceError) <= k * c.distanceSigma_mm;
    coveredLateral += std::abs(lateralError.x) <= k * c.lateralSigma_mm.x;
    coveredGap += std::abs(gapError) <= k * c.gapSigma_mm;
    std::printf("[ info     ] Δ err %+.4f (U %.4f) mm, across err %+.4f (U %.4f) mm, gap err %+.5f (U %.5f) mm\n",
                distanceError, k * c.distanceSigma_mm, lateralError.x, k * c.lateralSigma_mm.x, gapError,
                k * c.gapSigma_mm);
  }
  const int least = static_cast<int>(std::ceil(0.9 * trials));
  EXPECT_GE(coveredDistance, least);
  EXPECT_GE(coveredLateral, least);
  EXPECT_GE(coveredGap, least);
}

TEST_F(PartCalibrationTest, ALineBarrierIsRefusedByName) {
  Truth truth;
  truth.optics = "line_barrier";
  EXPECT_TRUE(throwsError([&] { calibrate(truth); }, Errc::Device, {"line barrier", "not built"}));
}

TEST_F(PartCalibrationTest, NoPartInViewIsRefused) {
  Truth truth;
  const calib::CameraMap camera = cameraMap(truth);
  truth.part = false;
  EXPECT_TRUE(throwsError(
      [&] { measure(truth, [&](BenchProbe& p) { return calibratePart(p, *model_, camera, kStatedDistance_mm); }); },
      Errc::Device, {"is the part missing"}));
}

TEST_F(PartCalibrationTest, APartTheModelCannotExplainIsRefused) {
  Truth truth;
  truth.tilt_deg = 20;  // tilted that far, the rays land in other lenses than any Δ puts them in
  EXPECT_TRUE(throwsError([&] { calibrate(truth); }, Errc::Device, {"too large for the model"}));
}

TEST_F(PartCalibrationTest, ADistanceOutsideTheSearchIsRefused) {
  Truth truth;
  truth.distance_mm = 40;  // the stated 30 mm ± 25 % ends at 37.5 mm
  EXPECT_TRUE(throwsError([&] { calibrate(truth); }, Errc::Device, {"did not converge", "edge of the search"}));
}

TEST_F(PartCalibrationTest, APartOfAnotherPowerThanTheModelsScalesDistanceAndGapAlike) {
  // What the light tells is Δ / f and g / f of the part's focal length f: a part 16 % stronger than its model
  // (n 1.6 for 1.5168: (n − 1) 0.6 for 0.5168) reads as a Δ and a gap 16 % longer. The model must be right.
  Truth truth;
  truth.partIor = 1.6;
  const PartCalibration c = calibrate(truth);
  const double ratio = (1.6 - 1) / (1.5168 - 1);
  EXPECT_NEAR(c.distance_mm / truth.distance_mm, ratio, 0.02 * ratio);
  EXPECT_NEAR(c.gap_mm / truth.gap_mm, ratio, 0.02 * ratio);
}

}  // namespace
