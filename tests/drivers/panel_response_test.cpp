// SPDX-License-Identifier: Apache-2.0
// A panel's measured response (panel_response.h): the drive is the inverse
// of the curve to the nearest level, the backlight's fall-off is compensated
// to the dimmest pixel's light, colours take their own curves, and responses
// that cannot be a panel's are refused by name.

#include "lfi/drivers/panel_response.h"

#include "lfi_test_support.h"

#include <gtest/gtest.h>

#include <cmath>

namespace lfi {
namespace {

using testing_support::throwsError;

DisplayInfo panel(int width, int height, SubpixelLayout subpixels = SubpixelLayout::Mono) {
  DisplayInfo info;
  info.panelWidth_px = width;
  info.panelHeight_px = height;
  info.pixelPitch_mm = 0.1;
  info.subpixels = subpixels;
  return info;
}

// A power law sampled at 17 levels.
PanelResponseParams gamma(double g) {
  PanelResponseParams p;
  for (int v = 0; v < 255; v += 16) p.levels.push_back(v);
  p.levels.push_back(255);
  std::vector<double> light;
  for (const double v : p.levels) light.push_back(std::pow(v / 255, g));
  p.light = {light};
  return p;
}

TEST(PanelResponse, TheDriveIsTheNearestLevelOfTheCurvesInverse) {
  const PanelResponse linear({{0, 255}, {{0, 1}}, {1, 0, 0, 0, 0, 0}}, panel(3, 3));
  EXPECT_EQ(linear.driveLevel(0.25, 1, 1, 0), 64);  // 63.75
  EXPECT_EQ(linear.driveLevel(0, 1, 1, 0), 0);
  EXPECT_EQ(linear.driveLevel(1, 1, 1, 0), 255);
  EXPECT_EQ(linear.driveLevel(2, 1, 1, 0), 255) << "clamped";
  const PanelResponse g(gamma(2.2), panel(3, 3));
  for (int v = 0; v <= 255; ++v) {
    // Every level's own light drives that level, and any light the level nearest in light.
    ASSERT_EQ(g.driveLevel(g.light(v, 0), 1, 1, 0), v);
    const double l = (v + 0.3) / 256.0;
    const int level = g.driveLevel(l, 1, 1, 0);
    for (const int other : {level - 1, level + 1})
      if (other >= 0 && other <= 255) {
        EXPECT_LE(std::abs(g.light(level, 0) - l), std::abs(g.light(other, 0) - l));
      }
  }
  // Between the measured levels the curve is linear.
  EXPECT_NEAR(g.light(24, 0), (g.light(16, 0) + g.light(32, 0)) / 2, 1e-12);
}

TEST(PanelResponse, TheBacklightIsCompensatedToTheDimmestPixel) {
  // B = 1 - 0.01 (x^2 + y^2): on a 101 x 51 panel of 0.1 mm the corners are at (5, 2.5) mm, B = 0.6875.
  const PanelResponse r({{0, 255}, {{0, 1}}, {1, 0, 0, -0.01, 0, -0.01}}, panel(101, 51));
  EXPECT_NEAR(r.leastBacklight(), 0.6875, 1e-12);
  EXPECT_NEAR(r.backlight(50, 25), 1, 1e-12);
  EXPECT_NEAR(r.backlight(100, 0), 0.6875, 1e-12);
  EXPECT_NEAR(r.backlight(0, 25), 0.75, 1e-12) << "x = -5 mm";
  // Full light is the dimmest pixel's: 255 at a corner, 0.6875 of full drive at the centre.
  EXPECT_EQ(r.driveLevel(1, 0, 0, 0), 255);
  EXPECT_EQ(r.driveLevel(1, 50, 25, 0), std::lround(0.6875 * 255));
  const cv::Mat drive = r.drive(cv::Mat(51, 101, CV_32FC1, cv::Scalar(0.5f)));
  EXPECT_EQ(drive.type(), CV_8UC1);
  EXPECT_EQ(drive.at<std::uint8_t>(25, 50), std::lround(0.5 * 0.6875 * 255));
  EXPECT_EQ(drive.at<std::uint8_t>(0, 100), std::lround(0.5 * 255));
}

TEST(PanelResponse, ColoursTakeTheirOwnCurvesInThePanelsOrder) {
  PanelResponseParams p = gamma(1);  // red linear, green and blue powers 2 and 3
  p.light.push_back(gamma(2).light[0]);
  p.light.push_back(gamma(3).light[0]);
  const PanelResponse bgr(p, panel(2, 2, SubpixelLayout::BgrStripe));
  const cv::Mat drive = bgr.drive(cv::Mat(2, 2, CV_32FC1, cv::Scalar(0.25f)));
  ASSERT_EQ(drive.type(), CV_8UC3);
  const cv::Vec3b px = drive.at<cv::Vec3b>(0, 0);
  EXPECT_EQ(px[2], 64) << "red, linear, last in BGR";
  EXPECT_NEAR(px[1], 255 * std::sqrt(0.25), 1.5) << "green, gamma 2";
  EXPECT_NEAR(px[0], 255 * std::cbrt(0.25), 1.5) << "blue, gamma 3";
}

TEST(PanelResponse, ResponsesNoPanelHasAreRefusedByName) {
  const auto refused = [](PanelResponseParams p, const DisplayInfo& info, std::vector<std::string> fragments) {
    return throwsError([&] { PanelResponse(std::move(p), info); }, Errc::InvalidArgument, fragments);
  };
  EXPECT_NO_THROW(PanelResponse({{0, 128, 255}, {{0, 0.6, 1}}, {1, 0, 0, 0, 0, 0}}, panel(2, 2)));
  EXPECT_TRUE(refused({{0, 128, 200, 255}, {{0, 0.6, 0.5, 1}}, {1, 0, 0, 0, 0, 0}}, panel(2, 2),
                      {"light is not monotonic", "0.5 at level 200 after 0.6 at level 128"}));
  EXPECT_TRUE(refused({{0, 128, 255}, {{0, 0.5, 0.9}}, {1, 0, 0, 0, 0, 0}}, panel(2, 2), {"not 0 and 1"}));
  EXPECT_TRUE(refused({{0, 200, 128, 255}, {{0, 0.2, 0.5, 1}}, {1, 0, 0, 0, 0, 0}}, panel(2, 2),
                      {"levels[2] = 128 does not rise"}));
  EXPECT_TRUE(refused({{0, 255}, {{0, 1}, {0, 1}, {0, 1}}, {1, 0, 0, 0, 0, 0}}, panel(2, 2),
                      {"3 curves for a panel of 1 subpixel"}));
  EXPECT_TRUE(refused({{0, 255}, {{0, 1}}, {1, 0, 0, -1, 0, 0}}, panel(101, 51),
                      {"the backlight falls to", "must stay positive"}));
  EXPECT_TRUE(refused({{0, 255}, {{0, 1}}, {0.9, 0, 0, 0, 0, 0}}, panel(2, 2), {"0.9 at the panel's centre"}));
}

}  // namespace
}  // namespace lfi
