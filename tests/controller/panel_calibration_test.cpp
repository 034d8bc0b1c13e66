// SPDX-License-Identifier: Apache-2.0
// The panel's drive-to-light curves and backlight measured through the
// ray-traced bench (panel_calibration.h): on randomised benches (a power-law
// panel, a backlight falling towards the corners, a camera with a black level)
// every value within its U in at least 90 % of them, and U not more than
// twice the errors' spread; the drive it makes emits the light it means
// (panel_response.h); a camera that cannot see the panel is refused.

#include "lfi/controller/panel_calibration.h"

#include "lfi/drivers/panel_response.h"
#include "lfi/sim/devices/sim_camera.h"

#include "calibration_bench.h"
#include "lfi_test_support.h"
#include "scene_text.h"
#include "test_folder.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace lfi {
namespace {

using testing_support::cameraSceneText;
using testing_support::inspectionBenchCamera;
using testing_support::TestFolder;
using testing_support::throughSimBench;
using testing_support::throwsError;

// 800 x 800 pixels of 0.0315 mm: the panel's half diagonal is 799 / 2 · 0.0315 · sqrt(2) mm.
constexpr int kPanel_px = 800;
constexpr double kPitch_mm = 0.0315;

struct Truth {
  double gamma = 2.2;
  double falloff = 0.2;
  std::string subpixels = "rgb";
  int seed = 1;
};

class PanelCalibrationTest : public testing::Test {
 protected:
  void SetUp() override { sim::registerSimBackends(); }

  std::string scene(const Truth& t) {
    const std::string text =
        cameraSceneText(inspectionBenchCamera(4, t.seed)) +
        "black_level_dn = 64\n"  // (a camera that clips its dark at 0 DN reads its darkest levels low)
        + fmt::format(
              "[display]\nposition_mm = [0, 0, -30]\noptics = \"lenslet_array\"\npanel_width_px = {}\n"
              "panel_height_px = {}\nsubpixels = \"{}\"\nresponse_gamma = {}\nbacklight_falloff = {}\n",
              kPanel_px, kPanel_px, t.subpixels, t.gamma, t.falloff);
    return "sim:" + dir_.write(fmt::format("panel-{}.toml", t.seed), text).string();
  }

  // The camera looks down at the display: its rows along +x, its columns down -y, centred on the axis.
  static calib::CameraMap map() {
    calib::CameraMap m;
    const double s = testing_support::objectPixel_mm(testing_support::kBenchSensorPixel_mm);
    m.perPixel_mm = cv::Matx22d(s, 0, 0, -s);
    return m;
  }

  PanelCalibration calibrate(const Truth& truth) {
    return throughSimBench(scene(truth), [&](BenchProbe& probe) { return calibratePanel(probe, map(), "sim camera"); });
  }

  TestFolder dir_{"panel_calibration"};
};

TEST_F(PanelCalibrationTest, CurvesAndBacklightLieWithinTheirUncertaintyOnRandomisedBenches) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> gamma(1.8, 2.6), falloff(0.05, 0.3);
  constexpr int kBenches = 20;
  const double corner2 = 2 * std::pow((kPanel_px - 1) / 2.0 * kPitch_mm, 2);
  int covered = 0, values = 0;
  double z2 = 0;
  const auto check = [&](double measured, double truth, double sigma, double k, const std::string& what) {
    ++values;
    const double error = measured - truth;
    if (std::abs(error) <= k * sigma) ++covered;
    z2 += error * error / (sigma * sigma);
    EXPECT_LE(std::abs(error), 2 * k * sigma) << what;  // no value far outside
  };
  for (int b = 0; b < kBenches; ++b) {
    const Truth t{.gamma = gamma(rng), .falloff = falloff(rng), .seed = b + 1};
    SCOPED_TRACE(fmt::format("bench {}: gamma {:.3f}, fall-off {:.3f}", b, t.gamma, t.falloff));
    const PanelCalibration c = calibrate(t);
    const double k = c.coverageFactor;
    ASSERT_EQ(c.response.light.size(), 3u) << "red, green and blue";
    for (std::size_t i = 0; i < 3; ++i)
      for (std::size_t j = 1; j + 1 < c.response.levels.size(); ++j)
        check(c.response.light[i][j], std::pow(c.response.levels[j] / 255, t.gamma), c.lightSigma[i][j], k,
              fmt::format("curve {} at level {}", i, c.response.levels[j]));
    // B = 1 - f (x^2 + y^2) / r_corner^2.
    const std::array<double, 6> truth{1, 0, 0, -t.falloff / corner2, 0, -t.falloff / corner2};
    for (std::size_t j = 1; j < 6; ++j)
      check(c.response.backlight[j], truth[j], c.backlightSigma[j], k, fmt::format("backlight term {}", j));
  }
  // U covers at least 90 % of the values, and is not more than twice their spread: rms z at least 0.5.
  EXPECT_GE(covered, 0.9 * values) << covered << " of " << values;
  EXPECT_GE(std::sqrt(z2 / values), 0.5);
}

// The drive the measured response makes emits the light asked for: a uniform
// light of 0.5 comes out uniform over the panel within its noise, where the
// uncalibrated drive of 128 (0.22 of the light at gamma 2.2) falls by the
// backlight's 20 % towards the corners.
TEST_F(PanelCalibrationTest, TheDriveItMakesEmitsTheLightItMeans) {
  const Truth t;
  const std::string uri = scene(t);
  const PanelCalibration c = calibrate(t);
  throughSimBench(uri, [&](BenchProbe& probe) {
    const PanelResponse response(c.response, probe.display());
    const cv::Mat dark = probe.take(cv::Mat(kPanel_px, kPanel_px, CV_8UC1, cv::Scalar(0)));
    const cv::Mat full = probe.take(cv::Mat(kPanel_px, kPanel_px, CV_8UC1, cv::Scalar(255))) - dark;
    const cv::Mat half = probe.take(response.drive(cv::Mat(kPanel_px, kPanel_px, CV_32FC1, cv::Scalar(0.5f)))) - dark;
    const cv::Mat raw = probe.take(cv::Mat(kPanel_px, kPanel_px, CV_8UC1, cv::Scalar(128))) - dark;
    // The camera's centre 20 x 20 pixels against a 20 x 20 corner of the panel's image (10 to 30 px in).
    const cv::Rect centre(18, 18, 20, 20), corner(4, 4, 12, 12);
    const auto ratio = [&](const cv::Mat& image) { return cv::mean(image(corner))[0] / cv::mean(image(centre))[0]; };
    // The truth's backlight over the same camera pixels, at the display points they see.
    const double corner2 = 2 * std::pow((kPanel_px - 1) / 2.0 * kPitch_mm, 2);
    const auto backlight = [&](const cv::Rect& r) {
      double sum = 0;
      for (int v = r.y; v < r.y + r.height; ++v)
        for (int u = r.x; u < r.x + r.width; ++u) {
          const Vec2 q = map().displayPoint({static_cast<double>(u), static_cast<double>(v)}, full.size());
          sum += 1 - t.falloff * (q.x * q.x + q.y * q.y) / corner2;
        }
      return sum / r.area();
    };
    EXPECT_NEAR(ratio(full), backlight(corner) / backlight(centre), 0.02) << "the backlight falls to the corners";
    EXPECT_NEAR(ratio(half), 1.0, 0.02) << "compensated";
    // Light 0.5 of the dimmest pixel's full light, at the centre: 0.5 · Bmin of the centre's full light.
    const double centreFull = cv::mean(full(centre))[0];
    EXPECT_NEAR(cv::mean(half(centre))[0] / centreFull, 0.5 * response.leastBacklight(), 0.01);
    EXPECT_NEAR(cv::mean(raw(centre))[0] / centreFull, std::pow(128 / 255.0, t.gamma), 0.01);
    return 0;
  });
}

TEST_F(PanelCalibrationTest, ACameraThatDoesNotSeeThePanelIsRefused) {
  const std::string uri = scene({});
  calib::CameraMap away = map();
  away.atImageCentre_mm = {100, 0};  // the camera map of another camera: its view misses the panel
  EXPECT_TRUE(throwsError(
      [&] { throughSimBench(uri, [&](BenchProbe& probe) { return calibratePanel(probe, away, "sim camera"); }); },
      Errc::Device, {"sim camera", "sees the panel with 0 pixels"}));
}

}  // namespace
}  // namespace lfi
