// SPDX-License-Identifier: Apache-2.0
// Image helpers: percentile by nearest rank, PNG written atomically.

#include "lfi/core/image.h"

#include "lfi_test_support.h"

#include <gtest/gtest.h>
#include <unistd.h>
#include <opencv2/imgcodecs.hpp>

#include <filesystem>
#include <numeric>

namespace {

using lfi::Errc;
using lfi::testing_support::throwsError;

TEST(Percentile, NearestRankOfAShuffledRamp) {
  // 0..999 in a scrambled order: the p-th percentile is the value at rank floor(p n).
  cv::Mat ramp(1, 1000, CV_32FC1);
  for (int i = 0; i < 1000; ++i) ramp.at<float>(0, i) = static_cast<float>((i * 617) % 1000);
  EXPECT_EQ(lfi::percentile(ramp, 0.5), 500);
  EXPECT_EQ(lfi::percentile(ramp, 0.999), 999);
  EXPECT_EQ(lfi::percentile(ramp, 0), 0);
  EXPECT_EQ(lfi::percentile(ramp, 1), 999);
  EXPECT_TRUE(throwsError([] { lfi::percentile(cv::Mat(), 0.5); }, Errc::InvalidArgument, {"empty"}));
}

TEST(WritePngAtomically, RoundTripsAndRefusesToOverwrite) {
  const std::filesystem::path path =
      std::filesystem::path(testing::TempDir()) / ("lfi_png_" + std::to_string(::getpid()) + ".png");
  std::filesystem::remove(path);
  cv::Mat image(7, 5, CV_8UC1);
  cv::randu(image, 0, 256);
  lfi::writePngAtomically(path, image, lfi::Overwrite::Refuse);
  EXPECT_EQ(cv::norm(cv::imread(path.string(), cv::IMREAD_UNCHANGED), image, cv::NORM_INF), 0);
  EXPECT_TRUE(throwsError([&] { lfi::writePngAtomically(path, image, lfi::Overwrite::Refuse); }, Errc::Exists,
                          {path.string()}));

  // Colour images are BGR, as OpenCV's; a region of interest is not continuous.
  cv::Mat colour(9, 11, CV_8UC3);
  cv::randu(colour, 0, 256);
  const cv::Mat roi = colour(cv::Rect(2, 1, 6, 7));
  ASSERT_FALSE(roi.isContinuous());
  lfi::writePngAtomically(path, roi, lfi::Overwrite::Allow);
  EXPECT_EQ(cv::norm(cv::imread(path.string(), cv::IMREAD_UNCHANGED), roi, cv::NORM_INF), 0);

  EXPECT_TRUE(throwsError([&] { lfi::writePngAtomically(path, cv::Mat(3, 3, CV_32FC1), lfi::Overwrite::Allow); },
                          Errc::InvalidArgument, {path.string(), "32FC1"}));
  EXPECT_TRUE(throwsError([&] { lfi::writePngAtomically(path, cv::Mat(), lfi::Overwrite::Allow); },
                          Errc::InvalidArgument, {path.string(), "empty"}));
  std::filesystem::remove(path);
}

}  // namespace
