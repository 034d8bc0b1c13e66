// SPDX-License-Identifier: Apache-2.0
// A part's verdict from its defects: positions and areas in the part's frame,
// pass/fail by each rule; and a stored golden model that training goes on from.

#include "lfi/inspection/verdict.h"
#include "lfi/core/error.h"
#include "lfi/inspection/golden_model.h"

#include "lfi_test_support.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace {

using lfi::Defect;
using lfi::Errc;
using lfi::testing_support::throwsError;

Defect defectAt(double col, double row, double area_px) {
  Defect d;
  d.centroid_px = {col, row};
  d.area_px = area_px;
  d.dark = true;
  return d;
}

TEST(Verdict, DefectsArePlacedInThePartsFrameWithYUpTheImage) {
  const lfi::PartFrame frame = lfi::PartFrame::isotropic(0.5, {27.5, 27.5});
  const lfi::PartVerdict v = lfi::judgePart({defectAt(33.5, 23.5, 4)}, frame, {.maxDefects = 1});
  ASSERT_EQ(v.defects.size(), 1u);
  // 6 columns right of the origin and 4 rows above it, at 0.5 mm a pixel.
  EXPECT_DOUBLE_EQ(v.defects[0].centroid_mm.x, 3.0);
  EXPECT_DOUBLE_EQ(v.defects[0].centroid_mm.y, 2.0);
  EXPECT_DOUBLE_EQ(v.defects[0].area_mm2, 4 * 0.25);
  EXPECT_TRUE(v.pass);
}

// A camera turned by 90° and seeing the part mirrored: its columns run down the part's y, its rows along x.
TEST(Verdict, ACalibratedCameraMapPlacesDefectsOnThePartsAxes) {
  const lfi::PartFrame frame{cv::Matx22d(0, 0.5, -0.25, 0), {10, 20}};
  const lfi::PartVerdict v = lfi::judgePart({defectAt(14, 26, 8)}, frame, {.maxDefects = 1});
  ASSERT_EQ(v.defects.size(), 1u);
  EXPECT_DOUBLE_EQ(v.defects[0].centroid_mm.x, 0.5 * 6);    // six rows down
  EXPECT_DOUBLE_EQ(v.defects[0].centroid_mm.y, -0.25 * 4);  // four columns right
  EXPECT_DOUBLE_EQ(v.defects[0].area_mm2, 8 * 0.125) << "|det A| = 0.125 mm^2 a pixel";
  // Its uncertainty: A's elements', the origin's and the centroid's, each through A, in quadrature.
  lfi::PartFrame uncertain = frame;
  uncertain.perPixelU_mm = cv::Matx22d(0.01, 0.02, 0.03, 0.04);
  uncertain.originU_px = {0.5, 0.25};
  uncertain.centroidU_px = 0.1;
  const lfi::Vec2 u = uncertain.toPartU({14, 26});  // d = (4, 6) px
  EXPECT_NEAR(
      u.x, std::sqrt(std::pow(4 * 0.01, 2) + std::pow(6 * 0.02, 2) + std::pow(0.5 * 0.25, 2) + std::pow(0.5 * 0.1, 2)),
      1e-12);
  EXPECT_NEAR(
      u.y, std::sqrt(std::pow(4 * 0.03, 2) + std::pow(6 * 0.04, 2) + std::pow(0.25 * 0.5, 2) + std::pow(0.25 * 0.1, 2)),
      1e-12);
}

TEST(Verdict, EachRuleFailsThePartOnItsOwnAndSaysWhy) {
  const lfi::PartFrame frame = lfi::PartFrame::isotropic(0.1, {0, 0});
  const std::vector<Defect> two{defectAt(10, 10, 300), defectAt(50, 50, 50)};  // 3 and 0.5 mm²
  EXPECT_TRUE(lfi::judgePart({}, frame, {}).pass) << "no defect passes the strictest rules";
  const auto count = lfi::judgePart(two, frame, {.maxDefects = 1});
  EXPECT_FALSE(count.pass);
  ASSERT_EQ(count.reasons.size(), 1u);
  EXPECT_NE(count.reasons[0].find("2 defects"), std::string::npos) << count.reasons[0];
  const auto area = lfi::judgePart(two, frame, {.maxDefects = 2, .maxDefectArea_mm2 = 2.9});
  EXPECT_FALSE(area.pass);
  ASSERT_EQ(area.reasons.size(), 1u) << "only the larger defect breaks the area rule";
  EXPECT_TRUE(lfi::judgePart(two, frame, {.maxDefects = 2, .maxDefectArea_mm2 = 3.0}).pass);
  const auto total = lfi::judgePart(two, frame, {.maxDefects = 2, .maxTotalArea_mm2 = 3.4});
  EXPECT_FALSE(total.pass);
  EXPECT_TRUE(lfi::judgePart(two, frame, {.maxDefects = 2, .maxTotalArea_mm2 = 3.5}).pass);
}

TEST(Verdict, AFrameOrRuleOutOfRangeIsRefused) {
  EXPECT_TRUE(throwsError(
      [] {
        lfi::judgePart({}, lfi::PartFrame::isotropic(0, {0, 0}), {});
      },
      Errc::InvalidArgument, {"frame"}));
  EXPECT_TRUE(throwsError(
      [] {
        lfi::judgePart({}, lfi::PartFrame::isotropic(1, {0, 0}), {.maxDefects = -1});
      },
      Errc::InvalidArgument, {"limits"}));
}

// Images of one noisy level: mean and spread that training sees.
cv::Mat noisyImage(std::mt19937& rng, int size) {
  cv::Mat m(size, size, CV_16UC1);
  std::normal_distribution<double> noise(1000, 30);
  for (int r = 0; r < size; ++r)
    for (int c = 0; c < size; ++c)
      m.at<std::uint16_t>(r, c) = static_cast<std::uint16_t>(std::lround(noise(rng)) + 10 * c);
  return m;
}

TEST(GoldenModel, TrainingGoesOnFromStoredStatisticsAsIfItHadSeenEveryImage) {
  std::mt19937 rng(3);
  lfi::GoldenModelTrainer all, first;
  for (int i = 0; i < 5; ++i) {
    const cv::Mat image = noisyImage(rng, 16);
    all.add(image);
    first.add(image);
  }
  lfi::GoldenModelTrainer resumed =
      lfi::GoldenModelTrainer::resume(first.mean(), first.spread(), first.count(), CV_16UC1);
  for (int i = 0; i < 3; ++i) {
    const cv::Mat image = noisyImage(rng, 16);
    all.add(image);
    resumed.add(image);
  }
  EXPECT_EQ(resumed.count(), 8);
  const lfi::GoldenModel a = all.model({}), b = resumed.model({});
  // The stored mean is a float: off by up to 6e-8 relative (7e-5 DN at 1150 DN). That error enters the
  // sum of squares as 2 n μ δμ ≈ 0.8 DN², the variance as 0.8 / 7 DN², a 30 DN spread as 0.12 / 60 = 0.002 DN.
  EXPECT_LE(cv::norm(a.ideal, b.ideal, cv::NORM_INF), 1e-3);
  EXPECT_LE(cv::norm(a.variation, b.variation, cv::NORM_INF), 1e-2);
  EXPECT_TRUE(
      throwsError([&] { resumed.add(cv::Mat(16, 16, CV_8UC1, cv::Scalar(1))); }, Errc::InvalidArgument, {"differs"}))
      << "the resumed trainer knows the type of the images it was trained on";
  EXPECT_TRUE(throwsError([&] { lfi::GoldenModelTrainer::resume(first.mean(), -first.spread(), 5, CV_16UC1); },
                          Errc::InvalidArgument, {"negative"}));
}

TEST(GoldenModel, ACopiedTrainerTrainsOnItsOwn) {
  lfi::GoldenModelTrainer a;
  a.add(cv::Mat(4, 4, CV_16UC1, cv::Scalar(100)));
  lfi::GoldenModelTrainer b = a;
  b.add(cv::Mat(4, 4, CV_16UC1, cv::Scalar(700)));
  EXPECT_EQ(a.count(), 1);
  EXPECT_EQ(a.mean().at<float>(0, 0), 100.0f) << "the copy's images are not the original's";
  EXPECT_EQ(b.mean().at<float>(0, 0), 400.0f);
}

}  // namespace
