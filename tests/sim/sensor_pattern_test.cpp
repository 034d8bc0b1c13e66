// SPDX-License-Identifier: Apache-2.0
// The simulated camera's fixed pattern (sensor_pattern.h): vignetting on its
// law, the response and dark offsets spread as stated, binning as the mean of
// the binned pixels, and frames from the sim: camera carrying the pattern.

#include "lfi/sim/devices/sensor_pattern.h"
#include "lfi/sim/devices/sim_camera.h"
#include "lfi_test_support.h"
#include "scene_text.h"
#include "test_folder.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

namespace lfi::sim {
namespace {

using testing_support::cameraSceneText;
using testing_support::kBackLightObject;
using testing_support::TestFolder;

// Mean and standard deviation of a CV_32FC1 image.
std::pair<double, double> meanAndSigma(const cv::Mat& image) {
  cv::Scalar mean, sigma;
  cv::meanStdDev(image, mean, sigma);
  return {mean[0], sigma[0]};
}

TEST(SensorPattern, VignettingFollowsItsLawAndTheResponseSpreadsAsStated) {
  CameraSensorParameters p;
  p.vignetting = 0.15;
  p.gainFpn = 0.02;
  const int w = 400, h = 300;
  const SensorPattern pattern = sensorPattern(p, w, h, 1);
  ASSERT_EQ(pattern.response.size(), cv::Size(w, h));
  EXPECT_TRUE(pattern.offset_dn.empty()) << "no black level, no dark spread";
  // The vignetting law alone, from its statement: 1 - v (r / r_corner)^2.
  cv::Mat law(h, w, CV_32FC1);
  const double cx = (w - 1) / 2.0, cy = (h - 1) / 2.0;
  for (int r = 0; r < h; ++r)
    for (int c = 0; c < w; ++c)
      law.at<float>(r, c) =
          static_cast<float>(1 - 0.15 * ((c - cx) * (c - cx) + (r - cy) * (r - cy)) / (cx * cx + cy * cy));
  const auto [mean, sigma] = meanAndSigma(pattern.response / law);
  // The PRNU over 120 000 pixels: its mean within 5 standard errors of 1,
  // its sample deviation within 5 of its own (sigma / sqrt(2 N)).
  const double n = static_cast<double>(w) * h;
  EXPECT_NEAR(mean, 1, 5 * 0.02 / std::sqrt(n));
  EXPECT_NEAR(sigma, 0.02, 5 * 0.02 / std::sqrt(2 * n));
  // A 20 x 20 corner against the centre: 0.85 at the corner pixel, the patch
  // a little brighter (its mean of the law); the PRNU averages to 0.02 / 20.
  const cv::Rect corner(0, 0, 20, 20), centre(w / 2 - 10, h / 2 - 10, 20, 20);
  const double ratio = cv::mean(pattern.response(corner))[0] / cv::mean(pattern.response(centre))[0];
  const double lawRatio = cv::mean(law(corner))[0] / cv::mean(law(centre))[0];
  EXPECT_NEAR(ratio, lawRatio, 5 * std::sqrt(2.0) * 0.02 / 20);
  EXPECT_NEAR(law.at<float>(0, 0), 0.85, 1e-6);
}

TEST(SensorPattern, DarkOffsetsSpreadAboutTheBlackLevel) {
  CameraSensorParameters p;
  p.blackLevel_dn = 64;
  p.darkFpn_dn = 1.5;
  const SensorPattern pattern = sensorPattern(p, 300, 200, 1);
  EXPECT_TRUE(pattern.response.empty()) << "no vignetting, no PRNU";
  const auto [mean, sigma] = meanAndSigma(pattern.offset_dn);
  const double n = 300.0 * 200;
  EXPECT_NEAR(mean, 64, 5 * 1.5 / std::sqrt(n));
  EXPECT_NEAR(sigma, 1.5, 5 * 1.5 / std::sqrt(2 * n));
  // Another seed, another pattern; the same seed, the same one.
  CameraSensorParameters other = p;
  other.patternSeed = 2;
  EXPECT_GT(cv::norm(sensorPattern(other, 300, 200, 1).offset_dn, pattern.offset_dn, cv::NORM_INF), 1.0);
  EXPECT_EQ(cv::norm(sensorPattern(p, 300, 200, 1).offset_dn, pattern.offset_dn, cv::NORM_INF), 0.0);
}

TEST(SensorPattern, ABinnedPixelHasTheMeanOfItsPixels) {
  CameraSensorParameters p;
  p.vignetting = 0.3;
  p.gainFpn = 0.05;
  p.blackLevel_dn = 10;
  p.darkFpn_dn = 3;
  const int w = 61, h = 43;  // odd: the last column and row make no whole block
  const SensorPattern full = sensorPattern(p, w, h, 1), binned = sensorPattern(p, w, h, 2);
  ASSERT_EQ(binned.response.size(), cv::Size(30, 21));
  ASSERT_EQ(binned.offset_dn.size(), cv::Size(30, 21));
  for (int r = 0; r < 21; ++r)
    for (int c = 0; c < 30; ++c) {
      const cv::Rect block(2 * c, 2 * r, 2, 2);
      EXPECT_NEAR(binned.response.at<float>(r, c), cv::mean(full.response(block))[0], 1e-6);
      EXPECT_NEAR(binned.offset_dn.at<float>(r, c), cv::mean(full.offset_dn(block))[0], 1e-5);
    }
}

// Frames of the sim: camera carry the pattern: averaged over frames, each
// pixel's DN is its offset plus its response times the signal.
TEST(SensorPattern, TheSimCamerasFramesCarryThePattern) {
  TestFolder dir("lfi-sensor-pattern");
  const std::string scene = cameraSceneText({.width_px = 48,
                                             .height_px = 32,
                                             .fullWell_e = 20000,
                                             .readNoise_e = 5,
                                             .bitDepth = 12,
                                             .electronsPerUnitPerUs = 2.0}) +
                            "black_level_dn = 100\ndark_fpn_dn = 4\ngain_fpn = 0.03\nvignetting = 0.2\n" +
                            kBackLightObject;
  SimImager imager(dir.write("bench.toml", scene));
  const SensorPattern& pattern = imager.pattern(1);
  CameraSettings s;
  s.exposure_us = 4000;  // 8000 e- of the 20 000 e- well at radiance 1: 1638 DN
  s.pixelFormat = PixelFormat::Mono16;
  s = imager.resolve(s, "test");
  constexpr int kFrames = 64;
  cv::Mat sum = cv::Mat::zeros(32, 48, CV_64FC1), frame;
  for (int i = 0; i < kFrames; ++i) {
    imager.capture(s, static_cast<std::uint64_t>(i), frame);
    cv::Mat dn;
    frame.convertTo(dn, CV_64FC1, 1.0 / 16);  // 12-bit ADC values
    sum += dn;
  }
  const double dnPerElectron = 4095.0 / 20000, signal_dn = 8000 * dnPerElectron;
  cv::Mat expected, offset, response;
  pattern.offset_dn.convertTo(offset, CV_64FC1);
  pattern.response.convertTo(response, CV_64FC1);
  expected = offset + signal_dn * response;
  // Each pixel's mean of 64 frames is off by its shot, read and rounding noise over 8.
  const double noise = std::sqrt((8000 + 25) * dnPerElectron * dnPerElectron + 1.0 / 12) / std::sqrt(kFrames);
  cv::Mat residual = sum / kFrames - expected;
  const auto [mean, sigma] = meanAndSigma(residual);
  EXPECT_NEAR(mean, 0, 5 * noise / std::sqrt(48.0 * 32));
  EXPECT_LT(sigma, 1.2 * noise) << "the pattern's spread (" << signal_dn * 0.03 << " DN) is 6x the noise";
  EXPECT_GT(sigma, 0.8 * noise);
}

}  // namespace
}  // namespace lfi::sim
