// SPDX-License-Identifier: Apache-2.0
// The camera sensor model against its own statistics: exposure, shot + read +
// quantisation noise, saturation, linearity, reproducibility.
#include "lfi/sim/devices/camera_sensor_model.h"

#include "lfi_test_support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <vector>

namespace {

using namespace lfi;
using namespace lfi::sim;
using lfi::testing_support::throwsError;

cv::Mat flat(int size, float radiance) {
  return cv::Mat(size, size, CV_32FC1, cv::Scalar(radiance));
}

void meanStd(const cv::Mat& dn, double& mean, double& stddev) {
  cv::Scalar m, s;
  cv::meanStdDev(dn, m, s);
  mean = m[0];
  stddev = s[0];
}

TEST(CameraSensorModel, ExposeForPutsTheBrightestAtSeventyPercent) {
  for (double gain : {1.0, 2.0}) {
    CameraSensorModel model;
    model.gain = gain;
    model.exposeFor(2.5);
    double mean, sd;
    meanStd(model.capture(flat(128, 2.5f), 3), mean, sd);
    // 16384 pixels, sd ~ 30 DN: the mean is known to ~0.25 DN.
    EXPECT_NEAR(mean, 0.7 * model.maxDigitalNumber(), 2) << "gain " << gain;
    // A radiance of half the brightest gives half the signal.
    meanStd(model.capture(flat(128, 1.25f), 4), mean, sd);
    EXPECT_NEAR(mean, 0.35 * model.maxDigitalNumber(), 2) << "gain " << gain;
  }
  CameraSensorModel model;
  model.exposeFor(4, 0.5);
  double mean, sd;
  meanStd(model.capture(flat(64, 4.0f), 5), mean, sd);
  EXPECT_NEAR(mean, 0.5 * model.maxDigitalNumber(), 3);
}

TEST(CameraSensorModel, CaptureIsReproducibleWithTheSameSeed) {
  CameraSensorModel model;
  model.exposeFor(1.0);
  cv::Mat radiance(40, 50, CV_32FC1);
  cv::randu(radiance, 0.0, 1.0);
  const cv::Mat a = model.capture(radiance, 11), b = model.capture(radiance, 11), c = model.capture(radiance, 12);
  ASSERT_EQ(a.type(), CV_16UC1);
  ASSERT_EQ(a.size(), radiance.size());
  EXPECT_EQ(std::memcmp(a.data, b.data, a.total() * a.elemSize()), 0);
  EXPECT_NE(std::memcmp(a.data, c.data, a.total() * a.elemSize()), 0);
  // Different seeds differ in most pixels, not in one.
  cv::Mat diff;
  cv::compare(a, c, diff, cv::CMP_NE);
  EXPECT_GT(cv::countNonZero(diff), static_cast<int>(a.total() / 2));
}

TEST(CameraSensorModel, FlatFieldNoiseMatchesNoiseDn) {
  CameraSensorModel model;
  model.electronsPerUnit = 1;
  // Electrons per pixel: read-noise dominated, balanced, shot-noise dominated.
  for (double electrons : {30.0, 1000.0, 8000.0}) {
    double mean, sd;
    meanStd(model.capture(flat(256, static_cast<float>(electrons)), 21), mean, sd);
    const double expectedMean = electrons * model.gain / model.fullWell_e * model.maxDigitalNumber();
    EXPECT_NEAR(mean, expectedMean, 0.01 * expectedMean + 0.1) << electrons << " e-";
    // 65536 pixels: the sample sd is known to ~0.3 %.
    EXPECT_NEAR(sd / model.noiseDn(mean), 1.0, 0.03) << electrons << " e-: sd " << sd << " DN";
    RecordProperty("noise_ratio_" + std::to_string(static_cast<int>(electrons)) + "e",
                   std::to_string(sd / model.noiseDn(mean)));
  }
  // Without read noise the variance is the Poisson one: sqrt(N) e- (+ quantisation).
  model.readNoise_e = 0;
  double mean, sd;
  meanStd(model.capture(flat(256, 4000.0f), 22), mean, sd);
  const double scale = model.maxDigitalNumber() / model.fullWell_e;
  EXPECT_NEAR(sd, std::sqrt(4000 * scale * scale + 1.0 / 12), 0.03 * sd);
}

// Without read noise and with one DN per electron, the digital numbers are the
// shot noise's draws: their histogram must be Poisson's, both where the sampler
// inverts the distribution (means below 10) and where it rejects (above).
TEST(CameraSensorModel, ShotNoiseIsPoissonDistributed) {
  CameraSensorModel model;
  model.readNoise_e = 0;
  model.fullWell_e = model.maxDigitalNumber();  // 1 DN per electron
  model.electronsPerUnit = 1;
  for (double mu : {0.5, 3.0, 9.5, 10.5, 40.0, 900.0}) {
    const cv::Mat dn = model.capture(flat(256, static_cast<float>(mu)), 51);
    std::vector<double> counts(static_cast<size_t>(model.maxDigitalNumber()) + 1, 0.0);
    for (auto it = dn.begin<std::uint16_t>(); it != dn.end<std::uint16_t>(); ++it) counts[*it] += 1;
    // Pearson's chi-square against the Poisson pmf (computed in logs), over bins
    // of at least 20 expected counts: neighbours merged, the upper tail into the last.
    const double n = static_cast<double>(dn.total());
    std::vector<double> expectedBins{0}, observedBins{0};
    for (size_t k = 0; k < counts.size(); ++k) {
      if (expectedBins.back() >= 20) expectedBins.push_back(0), observedBins.push_back(0);
      const double kd = static_cast<double>(k);
      expectedBins.back() += n * std::exp(kd * std::log(mu) - mu - std::lgamma(kd + 1));
      observedBins.back() += counts[k];
    }
    if (expectedBins.size() > 1 && expectedBins.back() < 20) {
      expectedBins[expectedBins.size() - 2] += expectedBins.back();
      observedBins[observedBins.size() - 2] += observedBins.back();
      expectedBins.pop_back(), observedBins.pop_back();
    }
    double chi2 = 0;
    for (size_t b = 0; b < expectedBins.size(); ++b)
      chi2 += (observedBins[b] - expectedBins[b]) * (observedBins[b] - expectedBins[b]) / expectedBins[b];
    const int bins = static_cast<int>(expectedBins.size());
    // Degrees of freedom: bins - 1. The threshold is chi-square's upper 1e-6 quantile
    // (Wilson-Hilferty: z = 4.753), so that a right sampler fails once in a million seeds.
    const double dof = bins - 1, w = 2 / (9 * dof);
    const double threshold = dof * std::pow(1 - w + 4.753 * std::sqrt(w), 3);
    EXPECT_LT(chi2, threshold) << "mean " << mu << " e-: " << bins << " bins";
    double mean, sd;
    meanStd(dn, mean, sd);
    EXPECT_NEAR(mean, mu, 5 * std::sqrt(mu / n)) << "mean " << mu << " e-";
  }
}

TEST(CameraSensorModel, SaturationClampsAtTheMaximumDigitalNumber) {
  CameraSensorModel model;
  model.electronsPerUnit = model.fullWell_e;  // radiance 1 fills the well
  for (int bits : {8, 12, 16}) {
    model.bitDepth = bits;
    const cv::Mat dn = model.capture(flat(64, 5.0f), 1);
    double lo, hi;
    cv::minMaxLoc(dn, &lo, &hi);
    EXPECT_EQ(hi, model.maxDigitalNumber()) << bits;
    // The well is full: only read noise is left below full scale.
    EXPECT_GT(lo, model.maxDigitalNumber() * (1 - 10 * model.readNoise_e / model.fullWell_e)) << bits;
  }
  // With gain 2 half a well reaches full scale, so a full well is clipped everywhere.
  model.bitDepth = 12;
  model.gain = 2;
  const cv::Mat dn = model.capture(flat(64, 1.0f), 2);
  EXPECT_EQ(cv::countNonZero(dn != model.maxDigitalNumber()), 0);
}

TEST(CameraSensorModel, DoublingElectronsPerUnitDoublesTheMean) {
  CameraSensorModel model;
  model.electronsPerUnit = 2000;
  const cv::Mat radiance = flat(128, 1.0f);
  double m1, m2, sd;
  meanStd(model.capture(radiance, 31), m1, sd);
  model.electronsPerUnit = 4000;
  meanStd(model.capture(radiance, 32), m2, sd);
  // Means of 16384 pixels: ~0.1 DN of noise on ~780 and ~1560 DN.
  EXPECT_NEAR(m2 / m1, 2.0, 0.002);
  // Past saturation it stops doubling.
  model.electronsPerUnit = 8000;
  meanStd(model.capture(flat(128, 2.0f), 33), m1, sd);
  model.electronsPerUnit = 16000;
  meanStd(model.capture(flat(128, 2.0f), 34), m2, sd);
  EXPECT_LT(m2 / m1, 1.4);
}

TEST(CameraSensorModel, ZeroRadianceGivesOnlyReadNoise) {
  CameraSensorModel model;
  double mean, sd;
  const cv::Mat dn = model.capture(flat(256, 0.0f), 41);
  meanStd(dn, mean, sd);
  // Read noise of 2.4 e- is sigma = 2.4 x 4095 / 10500 = 0.936 DN, rounded and
  // clipped at 0: the mean is sum over k >= 1 of P(X >= k - 1/2) = 0.355 DN,
  // and 70 % of the pixels read 0 (P(X < 1/2)). (No read noise: mean 0; twice
  // as much: 0.74 DN.) 65 536 pixels: both known to about 0.003.
  const double sigma = 2.4 * 4095 / 10500;
  auto above = [&](double x) { return 0.5 * std::erfc(x / (sigma * std::sqrt(2.0))); };
  double expectedMean = 0;
  for (int k = 1; k < 20; ++k) expectedMean += above(k - 0.5);
  EXPECT_NEAR(mean, expectedMean, 0.012);
  EXPECT_NEAR(1.0 - cv::countNonZero(dn) / static_cast<double>(dn.total()), 1 - above(0.5), 0.01);
  EXPECT_TRUE(throwsError([&] { model.exposeFor(0); }, Errc::InvalidArgument, {"black image"}));
  // Settings the sampler cannot honour are refused, not drawn from.
  for (double well : {0.0, -1.0, 2e12, std::nan("")}) {
    CameraSensorModel bad;
    bad.fullWell_e = well;
    EXPECT_TRUE(throwsError([&] { bad.capture(flat(4, 1.0f), 1); }, Errc::InvalidArgument, {"fullWell_e"})) << well;
  }
  const std::pair<const char*, double CameraSensorModel::*> infinite[] = {
      {"electronsPerUnit", &CameraSensorModel::electronsPerUnit},
      {"readNoise_e", &CameraSensorModel::readNoise_e},
      {"gain", &CameraSensorModel::gain}};
  for (const auto& [field, member] : infinite) {
    CameraSensorModel endless;
    endless.*member = std::numeric_limits<double>::infinity();
    EXPECT_TRUE(throwsError([&] { endless.capture(flat(4, 0.0f), 1); }, Errc::InvalidArgument, {field})) << field;
  }
}

}  // namespace
