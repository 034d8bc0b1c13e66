// The coded reference's panel weights from decoded correspondences and their
// closed-loop refinement, on a synthetic bench with a known linear light
// transport: the loop makes an unevenly transmitting part look uniform.

#include "lfi/calib/coded_reference.h"
#include "lfi/core/error.h"

#include "lfi_test_support.h"

#include <gtest/gtest.h>

#include <cmath>

namespace {

using lfi::Errc;
using lfi::calib::PanelCorrespondence;
using lfi::testing_support::throwsError;

constexpr int kWidth = 60, kHeight = 40;

// Every camera pixel decoded to the panel pixel of the same coordinates, confidence 1.
PanelCorrespondence identity() {
  PanelCorrespondence c;
  c.panel.create(kHeight, kWidth, CV_32SC2);
  c.confidence = cv::Mat::ones(kHeight, kWidth, CV_32FC1);
  for (int v = 0; v < kHeight; ++v)
    for (int u = 0; u < kWidth; ++u) c.panel.at<cv::Vec2i>(v, u) = {u, v};
  c.lit = c.decoded = kWidth * kHeight;
  return c;
}

// The part's transmission at a camera pixel: 0.3 at the rim to 1 at the centre, as a lens vignettes.
double transmission(int u, int v) {
  const double r = std::hypot((u - kWidth / 2.0) / (kWidth / 2.0), (v - kHeight / 2.0) / (kHeight / 2.0));
  return 1.0 - 0.7 * std::min(1.0, r);
}

// The camera's image: 3000 DN at full drive through full transmission; each camera pixel takes 85 % of its
// light from its own panel pixel and 15 % from its four neighbours', plus Gaussian noise of 5 DN.
cv::Mat image(const cv::Mat& weights, cv::RNG& rng) {
  cv::Mat out(kHeight, kWidth, CV_32FC1);
  for (int v = 0; v < kHeight; ++v)
    for (int u = 0; u < kWidth; ++u) {
      double neighbours = 0;
      for (const auto& [du, dv] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}})
        neighbours += weights.at<float>(std::clamp(v + dv, 0, kHeight - 1), std::clamp(u + du, 0, kWidth - 1));
      const double w = 0.85 * weights.at<float>(v, u) + 0.15 * neighbours / 4;
      out.at<float>(v, u) = static_cast<float>(3000 * transmission(u, v) * w + rng.gaussian(5));
    }
  return out;
}

TEST(CodedReference, ThePanelPixelsThatReachThePartAreLit) {
  PanelCorrespondence c = identity();
  c.panel.at<cv::Vec2i>(3, 4) = {-1, -1};             // undecoded
  c.confidence.at<float>(5, 6) = 0.1f;                // decoded, but not trusted
  c.panel.at<cv::Vec2i>(7, 8) = {9, 10};              // two camera pixels on one panel pixel
  cv::Mat mask = cv::Mat::zeros(kHeight, kWidth, CV_8UC1);
  mask(cv::Rect(0, 0, 20, 20)).setTo(255);
  const cv::Mat w = lfi::calib::panelWeightsFromCorrespondence(c, mask, {kWidth, kHeight}, 0.5);
  EXPECT_EQ(w.at<float>(3, 4), 0.f);
  EXPECT_EQ(w.at<float>(5, 6), 0.f);
  EXPECT_EQ(w.at<float>(10, 9), 1.f);
  EXPECT_EQ(w.at<float>(7, 8), 0.f) << "its camera pixel is decoded elsewhere";
  EXPECT_EQ(w.at<float>(30, 30), 0.f) << "outside the mask";
  // The mask's 400 panel pixels less the three whose camera pixel is undecoded, untrusted or decoded elsewhere.
  EXPECT_EQ(cv::countNonZero(w), 20 * 20 - 3);
}

TEST(CodedReference, TheClosedLoopMakesAVignettingPartUniform) {
  const PanelCorrespondence c = identity();
  const cv::Mat mask;
  cv::RNG rng(27);
  cv::Mat weights = lfi::calib::panelWeightsFromCorrespondence(c, mask, {kWidth, kHeight}, 0.5);
  const auto first = lfi::calib::uniformity(image(weights, rng), c, mask);
  ASSERT_GT(first.cv, 0.25) << "the part's vignetting shows before the loop";
  // The target the rim can reach at full drive: 3000 · 0.3, less a tenth.
  const double target = 0.9 * 3000 * 0.3;
  lfi::calib::Uniformity last;
  for (int i = 0; i < 8; ++i) {
    weights = lfi::calib::refinePanelWeights(weights, c, image(weights, rng), mask, target);
    last = lfi::calib::uniformity(image(weights, rng), c, mask);
  }
  // The crosstalk (15 %) couples the steps: the error shrinks by about that factor per step, to the noise's
  // 5 DN of 810 (0.6 %) within a few steps; 5 % is the target.
  EXPECT_LT(last.cv, 0.05);
  EXPECT_NEAR(last.mean_dn, target, 0.02 * target);
  double lowest = 1, highest = 0;
  cv::minMaxLoc(weights, &lowest, &highest);
  EXPECT_LE(highest, 1.0);
  EXPECT_GE(lowest, 0.0);
}

TEST(CodedReference, InputsThatDoNotMatchAreNamed) {
  const PanelCorrespondence c = identity();
  const cv::Mat weights = cv::Mat::ones(kHeight, kWidth, CV_32FC1);
  const cv::Mat small(10, 10, CV_32FC1, cv::Scalar(1));
  EXPECT_TRUE(throwsError([&] { lfi::calib::refinePanelWeights(weights, c, small, {}, 100); }, Errc::InvalidArgument,
                          {"image"}));
  EXPECT_TRUE(throwsError([&] { lfi::calib::refinePanelWeights(weights, c, weights, {}, 0); }, Errc::InvalidArgument,
                          {"target"}));
  EXPECT_TRUE(throwsError([&] { lfi::calib::refinePanelWeights(weights, c, weights, {}, 100, 1.5); },
                          Errc::InvalidArgument, {"gain"}));
  EXPECT_TRUE(throwsError([&] { lfi::calib::panelWeightsFromCorrespondence(c, {}, {10, 10}, 0.5); },
                          Errc::InvalidArgument, {"outside"}));
  EXPECT_TRUE(throwsError([&] { lfi::calib::uniformity(weights, c, cv::Mat::zeros(kHeight, kWidth, CV_8UC1)); },
                          Errc::InvalidArgument, {"no decoded"}));
}

}  // namespace
