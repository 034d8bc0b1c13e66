// SPDX-License-Identifier: Apache-2.0
// The Gray code across lens axes on synthetic camera frames: a camera that
// sees each panel pixel decodes its band exactly; one that sees the panel
// blurred along the axes (as a camera focused on the part sees a lenticular
// sheet 30 mm below it) still decodes within a band; the refusals.

#include "lfi/calib/axis_code.h"
#include "lfi/core/error.h"

#include "lfi_test_support.h"

#include <gtest/gtest.h>

#include <cmath>

namespace axis_code_test {

using namespace lfi;
using namespace lfi::calib;
using lfi::testing_support::throwsError;

constexpr int kWidth = 200, kHeight = 120;

double xiOf(double col, double row, double slant) {
  return (col + 0.5 - 0.5 * kWidth) - (0.5 * kHeight - row - 0.5) * std::tan(slant);
}

// The camera's frame of `panel`: each camera pixel the mean of the panel along the axis through its pixel's
// centre, over ±reach pixels (0: the pixel itself), the panel's pixels taken nearest.
cv::Mat seen(const cv::Mat& panel, double slant, double reach) {
  cv::Mat out(panel.size(), CV_32FC1);
  const double ax = std::sin(slant), ay = -std::cos(slant);  // along the axis, in columns and rows (rows go down)
  for (int row = 0; row < panel.rows; ++row)
    for (int col = 0; col < panel.cols; ++col) {
      double sum = 0;
      int n = 0;
      for (double u = -reach; u <= reach + 1e-9; u += 0.25) {
        const int c = static_cast<int>(std::lround(col + u * ax)), r = static_cast<int>(std::lround(row + u * ay));
        if (c < 0 || r < 0 || c >= panel.cols || r >= panel.rows) continue;
        sum += panel.at<std::uint8_t>(r, c);
        ++n;
      }
      out.at<float>(row, col) = static_cast<float>(16 + sum / std::max(n, 1));  // a black level of 16 DN
    }
  return out;
}

AxisCorrespondence decodeSeen(const AxisCodeSet& set, double reach) {
  std::vector<cv::Mat> frames;
  for (const cv::Mat& p : set.patterns) frames.push_back(seen(p, set.slant_rad, reach));
  return decodeAxisCode(frames, seen(set.white, set.slant_rad, reach), seen(set.black, set.slant_rad, reach), set);
}

TEST(AxisCode, EveryPanelPixelDecodesToItsBand) {
  for (const double slant : {0.0, 0.1, -0.3}) {
    const AxisCodeSet set = axisCodePatterns(kWidth, kHeight, slant);
    EXPECT_EQ(set.patterns.size(), static_cast<size_t>(2 * set.bits));
    EXPECT_GE(1 << set.bits, set.bands);
    const AxisCorrespondence c = decodeSeen(set, 0);
    EXPECT_EQ(c.decoded, kWidth * kHeight);
    int wrong = 0;
    for (int row = 0; row < kHeight; ++row)
      for (int col = 0; col < kWidth; ++col) {
        const double xi = xiOf(col, row, slant);
        wrong += c.xi.at<float>(row, col) != static_cast<float>(std::floor(xi - set.xi0_px) + set.xi0_px + 0.5);
      }
    EXPECT_EQ(wrong, 0) << "slant " << slant;
  }
}

TEST(AxisCode, APanelBlurredAlongTheAxesStillDecodesWithinABand) {
  // 15 pixels either way along the axis: what a camera focused 30 mm above a 0.0315 mm-pixel panel with a 0.015
  // aperture sees (0.9 mm). The bands' pixels step by up to half a pixel from the axis line they follow, so a
  // blurred pixel mixes neighbouring bands: it decodes to one of them, or not at all.
  const double slant = 0.1;
  const AxisCodeSet set = axisCodePatterns(kWidth, kHeight, slant);
  const AxisCorrespondence c = decodeSeen(set, 15);
  int within = 0;
  for (int row = 0; row < kHeight; ++row)
    for (int col = 0; col < kWidth; ++col)
      if (const float xi = c.xi.at<float>(row, col); !std::isnan(xi))
        within += std::abs(xi - xiOf(col, row, slant)) <= 1.0;
  EXPECT_GE(c.decoded, 0.5 * kWidth * kHeight);
  EXPECT_GE(within, 0.99 * c.decoded);
}

TEST(AxisCode, RefusalsAreNamed) {
  EXPECT_TRUE(throwsError([] { axisCodePatterns(0, 10, 0); }, Errc::InvalidArgument, {"panel"}));
  EXPECT_TRUE(throwsError([] { axisCodePatterns(10, 10, 1.0); }, Errc::InvalidArgument, {"slant"}));
  const AxisCodeSet set = axisCodePatterns(16, 16, 0);
  EXPECT_TRUE(throwsError([&] { decodeAxisCode({}, set.white, set.black, set); }, Errc::InvalidArgument, {"frames"}));
  std::vector<cv::Mat> frames(set.patterns.size(), cv::Mat::zeros(8, 8, CV_8UC1));
  EXPECT_TRUE(throwsError([&] { decodeAxisCode(frames, set.white, set.black, set); }, Errc::InvalidArgument,
                          {"pattern", "16 x 16"}));
}

}  // namespace axis_code_test
