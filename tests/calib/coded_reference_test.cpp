// SPDX-License-Identifier: Apache-2.0
// The coded reference's panel weights from decoded correspondences and their
// closed-loop refinement, on a synthetic bench with a known linear light
// transport: the loop makes an unevenly transmitting part look uniform.

#include "lfi/calib/coded_reference.h"
#include "lfi/core/error.h"

#include "lfi_test_support.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <utility>

namespace {

using lfi::Errc;
using lfi::calib::PanelCorrespondence;
using lfi::calib::PanelLinks;
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

// Links from the identity's correspondence over `mask` (empty: all).
PanelLinks linksOf(const PanelCorrespondence& c, const cv::Mat& mask = {}, double minConfidence = 0.5) {
  PanelLinks links({kWidth, kHeight}, {kWidth, kHeight});
  links.add(c, mask, minConfidence);
  return links;
}

TEST(CodedReference, ThePanelPixelsThatReachThePartAreLit) {
  PanelCorrespondence c = identity();
  c.panel.at<cv::Vec2i>(3, 4) = {-1, -1};  // undecoded
  c.confidence.at<float>(5, 6) = 0.1f;     // decoded, but not trusted
  c.panel.at<cv::Vec2i>(7, 8) = {9, 10};   // two camera pixels on one panel pixel
  cv::Mat mask = cv::Mat::zeros(kHeight, kWidth, CV_8UC1);
  mask(cv::Rect(0, 0, 20, 20)).setTo(255);
  const PanelLinks links = linksOf(c, mask);
  EXPECT_EQ(links.linkedCameraPixels(), 20 * 20 - 2) << "the mask less the undecoded and the untrusted pixel";
  EXPECT_FALSE(links.linked(3, 4));
  EXPECT_FALSE(links.linked(5, 6));
  EXPECT_TRUE(links.linked(7, 8));
  const cv::Mat w = lfi::calib::panelWeights(links);
  EXPECT_EQ(w.at<float>(3, 4), 0.f);
  EXPECT_EQ(w.at<float>(5, 6), 0.f);
  EXPECT_EQ(w.at<float>(10, 9), 1.f);
  EXPECT_EQ(w.at<float>(7, 8), 0.f) << "its camera pixel is decoded elsewhere";
  EXPECT_EQ(w.at<float>(30, 30), 0.f) << "outside the mask";
  // The mask's 400 panel pixels less the three whose camera pixel is undecoded, untrusted or decoded elsewhere.
  EXPECT_EQ(cv::countNonZero(w), 20 * 20 - 3);
}

TEST(CodedReference, TwoSourcesPerAxisLinkFourPanelPixelsByTheirShares) {
  // Camera pixel (2, 1) sees columns 10 (70 %) and 11, rows 20 (60 %) and 21; its neighbour (3, 1) column 30 alone
  // and rows 20 (60 %) and 21: panel pixel (10, 20) gets 0.42 of the first's light, (30, 20) 0.6 of the second's.
  PanelCorrespondence c;
  c.panel = cv::Mat(kHeight, kWidth, CV_32SC2, cv::Scalar(-1, -1));
  c.second = cv::Mat(kHeight, kWidth, CV_32SC2, cv::Scalar(-1, -1));
  c.share = cv::Mat(kHeight, kWidth, CV_32FC2, cv::Scalar(1, 1));
  c.confidence = cv::Mat::zeros(kHeight, kWidth, CV_32FC1);
  c.panel.at<cv::Vec2i>(1, 2) = {10, 20}, c.second.at<cv::Vec2i>(1, 2) = {11, 21};
  c.share.at<cv::Vec2f>(1, 2) = {0.7f, 0.6f};
  c.panel.at<cv::Vec2i>(1, 3) = {30, 20}, c.second.at<cv::Vec2i>(1, 3) = {-1, 21};
  c.share.at<cv::Vec2f>(1, 3) = {1.f, 0.6f};
  c.confidence.at<float>(1, 2) = c.confidence.at<float>(1, 3) = 1;
  const PanelLinks links = linksOf(c);
  ASSERT_EQ(links.links().size(), 6u);
  EXPECT_EQ(links.linkedCameraPixels(), 2);
  std::map<std::pair<int, int>, float> share;  // (camera column, panel index) → share
  for (const auto& l : links.links()) share[{l.camera % kWidth, l.panel}] = l.share;
  EXPECT_FLOAT_EQ((share[{2, 20 * kWidth + 10}]), 0.42f);
  EXPECT_FLOAT_EQ((share[{2, 20 * kWidth + 11}]), 0.18f);
  EXPECT_FLOAT_EQ((share[{2, 21 * kWidth + 10}]), 0.28f);
  EXPECT_FLOAT_EQ((share[{2, 21 * kWidth + 11}]), 0.12f);
  EXPECT_FLOAT_EQ((share[{3, 20 * kWidth + 30}]), 0.6f);
  EXPECT_FLOAT_EQ((share[{3, 21 * kWidth + 30}]), 0.4f);
  EXPECT_EQ(cv::countNonZero(lfi::calib::panelWeights(links)), 6);
  // One step towards 1000 DN: panel pixel (10, 20) sees only camera pixel (2, 1), at 500 DN: doubled; (30, 20)
  // only (3, 1), at 2000 DN: halved.
  cv::Mat weights(kHeight, kWidth, CV_32FC1, cv::Scalar(0.4));
  cv::Mat image(kHeight, kWidth, CV_32FC1, cv::Scalar(0));
  image.at<float>(1, 2) = 500, image.at<float>(1, 3) = 2000;
  const cv::Mat next = lfi::calib::refinePanelWeights(weights, links, image, {}, 1000);
  EXPECT_FLOAT_EQ(next.at<float>(20, 10), 0.8f);
  EXPECT_FLOAT_EQ(next.at<float>(20, 30), 0.2f);
  EXPECT_FLOAT_EQ(next.at<float>(0, 0), 0.4f) << "a panel pixel no camera pixel sees stays";
}

TEST(CodedReference, LinksFromSeveralDecodesAddUp) {
  // A second decode (with the first one's panel pixels dark) finds the light the first left.
  PanelCorrespondence first = identity(), second = identity();
  for (int v = 0; v < kHeight; ++v)
    for (int u = 0; u < kWidth; ++u) {
      if (u % 2) first.panel.at<cv::Vec2i>(v, u) = {-1, -1};
      second.panel.at<cv::Vec2i>(v, u) = u % 2 ? cv::Vec2i(u, v) : cv::Vec2i((u + 1) % kWidth, v);
    }
  PanelLinks links({kWidth, kHeight}, {kWidth, kHeight});
  EXPECT_EQ(links.add(first, {}, 0.5), kWidth * kHeight / 2);
  EXPECT_EQ(links.linkedCameraPixels(), kWidth * kHeight / 2);
  EXPECT_EQ(links.add(second, {}, 0.5), kWidth * kHeight);
  EXPECT_EQ(links.linkedCameraPixels(), kWidth * kHeight);
  EXPECT_EQ(links.links().size(), static_cast<size_t>(kWidth * kHeight * 3 / 2));
  EXPECT_EQ(cv::countNonZero(lfi::calib::panelWeights(links)), kWidth * kHeight);
}

TEST(CodedReference, TheClosedLoopMakesAVignettingPartUniform) {
  const PanelCorrespondence c = identity();
  const cv::Mat mask;
  cv::RNG rng(27);
  const PanelLinks links = linksOf(c);
  cv::Mat weights = lfi::calib::panelWeights(links);
  const auto first = lfi::calib::uniformity(image(weights, rng), links, mask);
  ASSERT_GT(first.cv, 0.25) << "the part's vignetting shows before the loop";
  // The target the rim can reach at full drive: 3000 · 0.3, less a tenth.
  const double target = 0.9 * 3000 * 0.3;
  lfi::calib::Uniformity last;
  for (int i = 0; i < 8; ++i) {
    weights = lfi::calib::refinePanelWeights(weights, links, image(weights, rng), mask, target);
    last = lfi::calib::uniformity(image(weights, rng), links, mask);
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
  const PanelLinks links = linksOf(c);
  const cv::Mat weights = cv::Mat::ones(kHeight, kWidth, CV_32FC1);
  const cv::Mat small(10, 10, CV_32FC1, cv::Scalar(1));
  EXPECT_TRUE(throwsError([&] { lfi::calib::refinePanelWeights(weights, links, small, {}, 100); },
                          Errc::InvalidArgument, {"image"}));
  EXPECT_TRUE(throwsError([&] { lfi::calib::refinePanelWeights(small, links, weights, {}, 100); },
                          Errc::InvalidArgument, {"weights"}));
  EXPECT_TRUE(throwsError([&] { lfi::calib::refinePanelWeights(weights, links, weights, {}, 0); },
                          Errc::InvalidArgument, {"target"}));
  EXPECT_TRUE(throwsError([&] { lfi::calib::refinePanelWeights(weights, links, weights, {}, 100, 1.5); },
                          Errc::InvalidArgument, {"gain"}));
  EXPECT_TRUE(throwsError([&] { lfi::calib::refinePanelWeights(weights, links, weights, small, 100); },
                          Errc::InvalidArgument, {"mask"}));
  PanelLinks smallPanel({kWidth, kHeight}, {10, 10});
  EXPECT_TRUE(throwsError([&] { smallPanel.add(c, {}, 0.5); }, Errc::InvalidArgument, {"outside"}));
  EXPECT_TRUE(throwsError([&] { smallPanel.add(c, {}, 1.5); }, Errc::InvalidArgument, {"confidence"}));
  PanelLinks smallCamera({10, 10}, {kWidth, kHeight});
  EXPECT_TRUE(throwsError([&] { smallCamera.add(c, {}, 0.5); }, Errc::InvalidArgument, {"correspondence"}));
  EXPECT_TRUE(throwsError([&] { PanelLinks({0, 10}, {10, 10}); }, Errc::InvalidArgument, {"empty"}));
  EXPECT_TRUE(throwsError([&] { lfi::calib::uniformity(weights, links, cv::Mat::zeros(kHeight, kWidth, CV_8UC1)); },
                          Errc::InvalidArgument, {"no camera pixel"}));
}

}  // namespace
