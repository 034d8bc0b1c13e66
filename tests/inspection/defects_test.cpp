// SPDX-License-Identifier: Apache-2.0
// The golden model and the blind defect finder (lfi/inspection/) on synthetic
// frames with known defects: a flat part of 1000 DN under Gaussian noise of
// 10 DN, trained from 20 good frames.

#include "lfi/inspection/defects.h"
#include "lfi/inspection/golden_model.h"
#include "lfi_test_support.h"

#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <numbers>

namespace lfi {
namespace {

using testing_support::throwsError;

constexpr int kWidth = 160, kHeight = 120;
constexpr double kLevel = 1000, kNoise = 10;

cv::Mat frame(cv::RNG& rng) {
  cv::Mat noise(kHeight, kWidth, CV_32FC1);
  rng.fill(noise, cv::RNG::NORMAL, kLevel, kNoise);
  cv::Mat out;
  noise.convertTo(out, CV_16U);  // (rounded: a camera's DN)
  return out;
}

// Trained with the camera's noise (10 DN) as the floor: 20 frames give each
// pixel a sample deviation that is 0.4 of the true one or less at one pixel in
// ten thousand (chi-square, 19 degrees of freedom), which would make such
// pixels raise alarms on good parts.
GoldenModel trained(cv::RNG& rng, int images = 20) {
  GoldenModelTrainer trainer;
  for (int i = 0; i < images; ++i) trainer.add(frame(rng));
  return trainer.model({.read_dn = kNoise});
}

// A frame with a disc of radius r at (x, y) scaled by `factor` (0.7: 30 % darker).
cv::Mat withDisc(cv::RNG& rng, cv::Point2d centre, double radius, double factor) {
  cv::Mat image = frame(rng), scaled;
  image.convertTo(scaled, CV_32F);
  for (int row = 0; row < kHeight; ++row)
    for (int col = 0; col < kWidth; ++col)
      if (std::hypot(col - centre.x, row - centre.y) <= radius)
        scaled.at<float>(row, col) *= static_cast<float>(factor);
  scaled.convertTo(image, CV_16U);
  return image;
}

TEST(GoldenModel, IsTheMeanAndSampleDeviationWithTheCameraNoiseAsFloor) {
  GoldenModelTrainer trainer;
  for (int value : {10, 20, 30}) trainer.add(cv::Mat(2, 3, CV_16UC1, cv::Scalar(value)));
  const GoldenModel m = trainer.model({});
  EXPECT_EQ(m.images, 3);
  EXPECT_FLOAT_EQ(m.ideal.at<float>(1, 2), 20.f);
  EXPECT_FLOAT_EQ(m.variation.at<float>(0, 0), 10.f);  // sqrt(((10 - 20)² + 0 + (30 - 20)²) / 2)
  // One image has no spread: the camera's noise, read² + gain · level, stands in.
  GoldenModelTrainer one;
  one.add(cv::Mat(2, 2, CV_16UC1, cv::Scalar(400)));
  const GoldenModel floor = one.model({.read_dn = 3, .gain_dnPerElectron = 0.04});
  EXPECT_FLOAT_EQ(floor.variation.at<float>(0, 0), static_cast<float>(std::sqrt(9 + 0.04 * 400)));
}

TEST(GoldenModel, RefusesImagesThatDoNotMatch) {
  GoldenModelTrainer trainer;
  EXPECT_TRUE(throwsError([&] { trainer.model({}); }, Errc::InvalidArgument, {"no image"}));
  trainer.add(cv::Mat(4, 5, CV_16UC1, cv::Scalar(1)));
  EXPECT_TRUE(throwsError([&] { trainer.add(cv::Mat(4, 6, CV_16UC1, cv::Scalar(1))); }, Errc::InvalidArgument,
                          {"6 x 4", "5 x 4"}));
  EXPECT_TRUE(
      throwsError([&] { trainer.add(cv::Mat(4, 5, CV_8UC1, cv::Scalar(1))); }, Errc::InvalidArgument, {"differs"}));
  EXPECT_TRUE(throwsError([&] { trainer.add(cv::Mat(4, 5, CV_8UC3)); }, Errc::InvalidArgument, {"single-channel"}));
  EXPECT_TRUE(throwsError([&] { trainer.add(cv::Mat()); }, Errc::InvalidArgument, {"not empty"}));
}

TEST(Defects, ADarkDiscIsFoundWhereItIsWithItsArea) {
  cv::RNG rng(1);
  const GoldenModel model = trained(rng);
  const cv::Point2d centre(61.3, 47.8);
  const double radius = 6;
  const std::vector<Defect> defects = findDefects(withDisc(rng, centre, radius, 0.7), model, {}, {});
  ASSERT_EQ(defects.size(), 1u);
  const Defect& d = defects[0];
  EXPECT_TRUE(d.dark);
  // The disc's pixels (centres within r) form a region whose centre of area is
  // within half a pixel of the disc's, and whose area lies between the discs
  // of radius r - 1 and r + 1.
  EXPECT_NEAR(d.centroid_px.x, centre.x, 0.5);
  EXPECT_NEAR(d.centroid_px.y, centre.y, 0.5);
  EXPECT_GT(d.area_px, std::numbers::pi * (radius - 1) * (radius - 1));
  EXPECT_LT(d.area_px, std::numbers::pi * (radius + 1) * (radius + 1));
  // Contrast -0.3 in the disc, give or take the noise (1 % of the level, a
  // few times over the peak).
  EXPECT_NEAR(d.meanContrast, -0.3, 0.01);
  EXPECT_LT(d.peakContrast, -0.3);
  EXPECT_GT(d.peakContrast, -0.3 - 0.06);
}

TEST(Defects, ABrightSpotIsBright) {
  cv::RNG rng(2);
  const GoldenModel model = trained(rng);
  const std::vector<Defect> defects = findDefects(withDisc(rng, {100, 30}, 3, 1.5), model, {}, {});
  ASSERT_EQ(defects.size(), 1u);
  EXPECT_FALSE(defects[0].dark);
  EXPECT_NEAR(defects[0].meanContrast, 0.5, 0.02);
}

TEST(Defects, GoodPartsRaiseNoAlarm) {
  // At b = 6 against a variation of at least the true 10 DN, a pixel is off
  // when its noise and the ideal's (sqrt(1 + 1/20) of 10 DN together) exceed
  // 5.9 deviations: probability 4e-9, over 100 frames of 19 200 pixels 1e-2
  // expected.
  cv::RNG rng(3);
  const GoldenModel model = trained(rng);
  for (int i = 0; i < 100; ++i) ASSERT_TRUE(findDefects(frame(rng), model, {}, {}).empty()) << "frame " << i;
}

TEST(Defects, TheIdealsOwnNoiseCountsWhenFewImagesWereTrained) {
  // A model from one image: its ideal is as noisy as the frames, so a good
  // frame's difference has twice the variance. Against σ = 10 DN alone b = 6
  // would be 4.2 deviations of that difference (2e-5 a pixel, about 40 false
  // pixels in 100 frames); against σ √2 it is 6 (2e-9: none).
  cv::RNG rng(6);
  const GoldenModel model = trained(rng, 1);
  ASSERT_EQ(model.images, 1);
  const DefectFinder finder(model, {}, {});
  EXPECT_NEAR(finder.sigma().at<float>(0, 0), kNoise * std::sqrt(2.0), 1e-3);
  int alarms = 0;
  for (int i = 0; i < 100; ++i) alarms += static_cast<int>(finder.find(frame(rng)).size());
  EXPECT_EQ(alarms, 0);
}

TEST(Defects, SmoothingMatchedToTheDefectFindsAFaintWideOne) {
  // 2 % darker (20 DN, 2 noise deviations) over a disc of radius 10: a disc
  // pixel reaches 6 deviations with probability 3e-5, none of its 314 is
  // expected to; a Gaussian of 3 px lowers the noise to 10 / (2 √π 3) =
  // 0.94 DN, against which the disc is 21 deviations deep.
  cv::RNG rng(4);
  const GoldenModel model = trained(rng);
  const cv::Mat image = withDisc(rng, {80, 60}, 10, 0.98);
  EXPECT_TRUE(findDefects(image, model, {}, {}).empty());
  const std::vector<Defect> defects = findDefects(image, model, {}, {.smoothing_px = 3});
  ASSERT_EQ(defects.size(), 1u);
  EXPECT_TRUE(defects[0].dark);
  EXPECT_NEAR(defects[0].centroid_px.x, 80, 1.0);
  EXPECT_NEAR(defects[0].centroid_px.y, 60, 1.0);
}

// A part lit on its left half (1000 DN, shot noise 33 DN) and dark on its
// right (10 DN, read noise 1 DN), as at a lens's rim, with the model's
// variation the true noise.
GoldenModel edgeModel() {
  GoldenModel m;
  m.ideal.create(kHeight, kWidth, CV_32FC1);
  m.variation.create(kHeight, kWidth, CV_32FC1);
  m.ideal.colRange(0, kWidth / 2).setTo(1000);
  m.ideal.colRange(kWidth / 2, kWidth).setTo(10);
  m.variation.colRange(0, kWidth / 2).setTo(33);
  m.variation.colRange(kWidth / 2, kWidth).setTo(1);
  m.images = 1000;
  return m;
}

cv::Mat edgeFrame(cv::RNG& rng, const GoldenModel& m) {
  cv::Mat noise(kHeight, kWidth, CV_32FC1), out;
  rng.fill(noise, cv::RNG::NORMAL, 0, 1);
  cv::Mat values = m.ideal + noise.mul(m.variation);
  values.convertTo(out, CV_16U);
  return out;
}

TEST(Defects, TheSmoothedNoiseAtALitEdgeIsTheNeighboursNotTheCentresAlone) {
  // Smoothed with σ = 2 px, a dark pixel next to the edge takes in lit pixels
  // whose noise is 33 times its own: against its own variation (1 DN times the
  // smoothing's factor 1 / (4 π σ²) = 0.02) it would be off in every frame; the
  // smoothed difference's own deviation there, sqrt(Σ k² variation²), keeps 50
  // good frames at b = 6 clean (4e-9 a pixel).
  const GoldenModel model = edgeModel();
  const DefectFinder finder(model, {}, {.smoothing_px = 2});
  // Far from the edge σ is the variation times the factor (the ideal from 1000 images adds 0.05 %); at the
  // edge, half the kernel's weight is lit.
  const double factor = (1 + 1e-3) / (4 * std::numbers::pi * 2 * 2);
  EXPECT_NEAR(finder.sigma().at<float>(60, kWidth - 10), 1 * std::sqrt(factor), 1e-3);
  EXPECT_NEAR(finder.sigma().at<float>(60, 10), 33 * std::sqrt(factor), 1e-2);
  EXPECT_GT(finder.sigma().at<float>(60, kWidth / 2), 33 * std::sqrt(factor) / 2);
  cv::RNG rng(8);
  for (int i = 0; i < 50; ++i) ASSERT_TRUE(finder.find(edgeFrame(rng, model)).empty()) << "frame " << i;
  // A real defect on the dark side is still found: 5 DN darker over a disc of radius 4 px, 20 σ deep.
  cv::Mat image = edgeFrame(rng, model);
  cv::circle(image, {kWidth - 30, 60}, 4, cv::Scalar(5), -1);
  const std::vector<Defect> found = finder.find(image);
  ASSERT_EQ(found.size(), 1u);
  EXPECT_NEAR(found[0].centroid_px.x, kWidth - 30, 1.0);
}

TEST(Defects, TheMaskTheMinimumAreaAndTheAbsoluteThresholdApply) {
  cv::RNG rng(5);
  const GoldenModel model = trained(rng);
  cv::Mat image = withDisc(rng, {30, 30}, 5, 0.5);  // outside the mask below
  image.at<std::uint16_t>(90, 120) = 0;             // one dead pixel
  cv::Mat mask = cv::Mat::zeros(kHeight, kWidth, CV_8UC1);
  cv::rectangle(mask, cv::Rect(60, 40, 100, 80), cv::Scalar(255), cv::FILLED);
  EXPECT_EQ(findDefects(image, model, {}, {}).size(), 2u);
  const std::vector<Defect> inside = findDefects(image, model, mask, {});
  ASSERT_EQ(inside.size(), 1u);
  EXPECT_EQ(inside[0].area_px, 1);
  EXPECT_TRUE(findDefects(image, model, mask, {.minArea_px = 2}).empty());
  // A difference of 500 DN is below an absolute threshold of 600 DN.
  EXPECT_TRUE(findDefects(withDisc(rng, {80, 60}, 5, 0.5), model, {}, {.absolute_dn = 600}).empty());
}

TEST(Defects, InputThatDoesNotMatchIsNamed) {
  cv::RNG rng(6);
  const GoldenModel model = trained(rng, 2);
  EXPECT_TRUE(throwsError([&] { findDefects(cv::Mat(10, 10, CV_16UC1), model, {}, {}); }, Errc::InvalidArgument,
                          {"10 x 10", "160 x 120"}));
  EXPECT_TRUE(throwsError([&] { findDefects(frame(rng), model, cv::Mat(5, 5, CV_8UC1), {}); }, Errc::InvalidArgument,
                          {"mask 5 x 5"}));
  EXPECT_TRUE(
      throwsError([&] { findDefects(frame(rng), model, {}, {.relative = -1}); }, Errc::InvalidArgument, {"b = -1"}));
  EXPECT_TRUE(throwsError([&] { findDefects(frame(rng), GoldenModel{}, {}, {}); }, Errc::InvalidArgument,
                          {"golden model is empty"}));
}

}  // namespace
}  // namespace lfi
