// SPDX-License-Identifier: Apache-2.0
// The camera's exposure for the bench (exposure_calibration.h) on the
// ray-traced inspection bench with the intact lens: from an exposure too
// short and one that saturates, the exposure the scene's own numbers give
// for the brightest pixels at the fraction; a view without light is refused.

#include "lfi/controller/exposure_calibration.h"

#include "lfi/drivers/camera_registry.h"
#include "lfi/drivers/display_registry.h"
#include "lfi/sim/devices/sim_bench.h"
#include "lfi/sim/devices/sim_camera.h"

#include "calibration_bench.h"
#include "lfi_test_support.h"
#include "scene_text.h"
#include "test_folder.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace lfi {
namespace {

using testing_support::benchCameraSettings;
using testing_support::cameraSceneText;
using testing_support::inspectionBenchCamera;
using testing_support::TestFolder;
using testing_support::throwsError;

class ExposureCalibrationTest : public testing::Test {
 protected:
  void SetUp() override { sim::registerSimBackends(); }

  // The inspection bench's camera (0.7 e- per unit radiance per µs, 10 500 e-, 12 bits, black level 32 DN) over
  // its lenslet display, the lens in view; `cover`: an absorbing card hides the display.
  std::string scene(bool cover) {
    std::string text =
        cameraSceneText(inspectionBenchCamera(8, 3)) +
        "black_level_dn = 32\n[display]\nposition_mm = [0, 0, -30]\noptics = \"lenslet_array\"\n"
        "panel_width_px = 800\npanel_height_px = 800\n" +
        testing_support::lensObject({.radius_mm = 51.5, .centreThickness_mm = 5, .diameter_mm = 25.4, .ior = 1.5168});
    if (cover)
      text += "[[object]]\nname = \"card\"\nshape = \"rectangle\"\nsize_mm = [60, 60]\nposition_mm = [0, 0, 10]\n";
    return dir_.write(cover ? "covered.toml" : "bench.toml", text).string();
  }

  ExposureCalibration calibrate(const std::string& file, double exposure_us) {
    auto display = openDisplay("sim:" + file);
    auto camera = openCamera("sim:" + file);
    CameraSettings s = benchCameraSettings();
    s.exposure_us = exposure_us;
    return calibrateExposure(*camera, *display, s, {}, {.fraction = 0.8});
  }

  TestFolder dir_{"exposure_calibration"};
};

TEST_F(ExposureCalibrationTest, TheBrightestPixelsSitAtTheFractionFromAboveAndBelow) {
  const std::string file = scene(false);
  // The truth from the scene's numbers: the radiance the display all white sends to the camera, its 99.9th
  // percentile R; the brightest pixels at 0.8 of 4095 DN need 0.8 · 4095 - 32 DN of signal, 10 500 / 4095 e- a DN,
  // 0.7 e- per unit radiance per µs.
  double r = 0;
  {
    sim::SimImager imager(file);
    imager.bench().showPanel(cv::Mat(800, 800, CV_8UC3, cv::Scalar::all(255)));  // (RGB subpixels)
    const cv::Mat radiance = imager.radiance(1);
    std::vector<float> v(radiance.begin<float>(), radiance.end<float>());
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(0.999 * (v.size() - 1)), v.end());
    r = v[static_cast<std::size_t>(0.999 * (v.size() - 1))];
  }
  const double truth_us = (0.8 * 4095 - 32) * 10500 / 4095 / (0.7 * r);
  for (const double start : {2000.0, 60000.0}) {  // a fifth of it, and past the well
    SCOPED_TRACE(fmt::format("from {} us", start));
    const ExposureCalibration c = calibrate(file, start);
    EXPECT_EQ(c.startExposure_us, start);
    EXPECT_EQ(c.fullScale_dn, 4095);
    EXPECT_NEAR(c.dark_dn, 32, 1);
    EXPECT_NEAR(c.brightest_dn + c.dark_dn, 0.8 * 4095, 0.01 * 0.8 * 4095);
    // 3136 pixels: the 99.9th percentile is the brightest three, each known to its shot noise (about 1 %).
    EXPECT_NEAR(c.exposure_us, truth_us, 0.03 * truth_us);
    // A round to scale and one to confirm, one more for noise, and a halving per factor of two above the truth.
    EXPECT_LE(c.rounds, 3 + std::max(0.0, std::ceil(std::log2(start / truth_us))));
  }
}

TEST_F(ExposureCalibrationTest, AViewWithoutLightIsRefusedByName) {
  EXPECT_TRUE(throwsError([&] { calibrate(scene(true), 10000); }, Errc::Device,
                          {"calibrate exposure", "no brighter than dark", "is the display on"}));
}

}  // namespace
}  // namespace lfi
