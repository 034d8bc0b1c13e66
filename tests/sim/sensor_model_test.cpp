// SPDX-License-Identifier: Apache-2.0
// The camera sensor model against its own statistics: exposure, shot + read +
// quantisation noise (its law computed exactly, and the fast draw's distance
// from it), saturation, linearity, reproducibility.
#include "lfi/sim/devices/camera_sensor_model.h"
#include "lfi/sim/devices/sensor_noise.h"

#include "lfi_test_support.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>
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

// Pearson's chi-square of observed counts against a law (probabilities, the
// same length), over bins of at least 20 expected counts: neighbours merged,
// the last bins into the one before. The threshold is chi-square's upper 1e-6
// quantile for bins - 1 degrees of freedom (Wilson-Hilferty: z = 4.753), so
// that a right sampler fails once in a million seeds.
struct ChiSquare {
  double statistic = 0, threshold = 0;
  int bins = 0;
};

ChiSquare chiSquare(const std::vector<double>& counts, const std::vector<double>& law) {
  double n = 0;
  for (double c : counts) n += c;
  std::vector<double> expectedBins{0}, observedBins{0};
  for (size_t k = 0; k < counts.size(); ++k) {
    if (expectedBins.back() >= 20) expectedBins.push_back(0), observedBins.push_back(0);
    expectedBins.back() += n * law[k];
    observedBins.back() += counts[k];
  }
  if (expectedBins.size() > 1 && expectedBins.back() < 20) {
    expectedBins[expectedBins.size() - 2] += expectedBins.back();
    observedBins[observedBins.size() - 2] += observedBins.back();
    expectedBins.pop_back(), observedBins.pop_back();
  }
  ChiSquare result;
  for (size_t b = 0; b < expectedBins.size(); ++b)
    result.statistic += (observedBins[b] - expectedBins[b]) * (observedBins[b] - expectedBins[b]) / expectedBins[b];
  result.bins = static_cast<int>(expectedBins.size());
  const double dof = result.bins - 1, w = 2 / (9 * dof);
  result.threshold = dof * std::pow(1 - w + 4.753 * std::sqrt(w), 3);
  return result;
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
    // Against the Poisson pmf (computed in logs).
    std::vector<double> pmf(counts.size());
    for (size_t k = 0; k < counts.size(); ++k) {
      const double kd = static_cast<double>(k);
      pmf[k] = std::exp(kd * std::log(mu) - mu - std::lgamma(kd + 1));
    }
    const ChiSquare test = chiSquare(counts, pmf);
    EXPECT_LT(test.statistic, test.threshold) << "mean " << mu << " e-: " << test.bins << " bins";
    const double n = static_cast<double>(dn.total());
    double mean, sd;
    meanStd(dn, mean, sd);
    EXPECT_NEAR(mean, mu, 5 * std::sqrt(mu / n)) << "mean " << mu << " e-";
  }
}

// ---- the noise's law -----------------------------------------------------

// The exact law of a pixel's digital number (camera_sensor_model.h):
// P(DN <= k) = P(min(N, fullWell) + r Z < (k + 1/2) / scale), N ~ Poisson(mean),
// = sum over n of p(n) Phi(((k + 1/2) / scale - min(n, fullWell)) / r), r > 0.
// Only the n within 12 r of the bound are summed one by one; those below it
// enter through the Poisson CDF (Phi = 1 to 1e-32), those above not at all.
struct Law {
  std::vector<double> p;                      // P(DN = k), k = 0 .. maxDn
  double mean = 0, variance = 0, fourth = 0;  // central moments
};

Law moments(std::vector<double> p) {
  Law law;
  for (size_t k = 0; k < p.size(); ++k) law.mean += static_cast<double>(k) * p[k];
  for (size_t k = 0; k < p.size(); ++k) {
    const double d = static_cast<double>(k) - law.mean;
    law.variance += d * d * p[k];
    law.fourth += d * d * d * d * p[k];
  }
  law.p = std::move(p);
  return law;
}

Law exactLaw(const CameraSensorModel& m, double mean) {
  const double scale = m.gain / m.fullWell_e * m.maxDigitalNumber(), r = m.readNoise_e;
  const int maxDn = m.maxDigitalNumber();
  // Poisson(mean) where its pmf exceeds 1e-30, from the mode in logs; n >= fullWell as fullWell.
  const double mode = std::floor(mean);
  const double spread = 12 * std::sqrt(mean) + 30;
  const long lo = static_cast<long>(std::max(0.0, mode - spread)), hi = static_cast<long>(mode + spread);
  std::vector<double> pmf(static_cast<size_t>(hi - lo + 1)), cdf(pmf.size());
  double total = 0;
  for (long n = lo; n <= hi; ++n) {
    const double nd = static_cast<double>(n);
    pmf[static_cast<size_t>(n - lo)] = mean > 0 ? std::exp(nd * std::log(mean) - mean - std::lgamma(nd + 1)) : n == 0;
    total += pmf[static_cast<size_t>(n - lo)];
    cdf[static_cast<size_t>(n - lo)] = total;
  }
  auto electronsOf = [&](long n) { return std::min(static_cast<double>(n), m.fullWell_e); };
  auto below = [&](double t) {  // P(min(N, W) + r Z < t)
    double p = 0;
    const long first = std::max(lo, static_cast<long>(std::floor(t - 12 * r)));
    if (first > hi) return 1.0;
    if (first > lo) p += cdf[static_cast<size_t>(first - 1 - lo)];
    for (long n = first; n <= hi && electronsOf(n) < t + 12 * r; ++n)
      p += pmf[static_cast<size_t>(n - lo)] * 0.5 * std::erfc(-(t - electronsOf(n)) / (r * std::sqrt(2.0)));
    return p;
  };
  std::vector<double> p(static_cast<size_t>(maxDn) + 1, 0.0);
  double previous = 0;
  for (int k = 0; k < maxDn; ++k) {
    const double now = below((k + 0.5) / scale);
    p[static_cast<size_t>(k)] = now - previous;
    previous = now;
  }
  p[static_cast<size_t>(maxDn)] = 1 - previous;
  return moments(std::move(p));
}

// The law of the transformed normal draw (sensor_noise.h): P(DN <= k) =
// Phi(z_k) where electrons(z_k) = (k + 1/2) / scale, found by bisection (the
// test below checks that electrons(z) increases over the sampler's |z| <= 5.77).
Law transformedLaw(const CameraSensorModel& m, double mean) {
  const double scale = m.gain / m.fullWell_e * m.maxDigitalNumber();
  const int maxDn = m.maxDigitalNumber();
  const ShotReadTransform t = ShotReadTransform::at(mean, m.readNoise_e);
  auto zAt = [&](double electrons) {
    double lo = -9, hi = 9;
    for (int i = 0; i < 60; ++i)
      (t.electrons(static_cast<float>(0.5 * (lo + hi))) < electrons ? lo : hi) = 0.5 * (lo + hi);
    return 0.5 * (lo + hi);
  };
  std::vector<double> p(static_cast<size_t>(maxDn) + 1, 0.0);
  double previous = 0;
  const double sd = std::sqrt(mean + m.readNoise_e * m.readNoise_e);
  for (int k = 0; k < maxDn; ++k) {
    const double bound = (k + 0.5) / scale;
    double now = bound < mean - 12 * sd   ? 0
                 : bound > mean + 12 * sd ? 1
                                          : 0.5 * std::erfc(-zAt(bound) / std::sqrt(2.0));
    p[static_cast<size_t>(k)] = now - previous;
    previous = now;
  }
  p[static_cast<size_t>(maxDn)] = 1 - previous;
  return moments(std::move(p));
}

double totalVariation(const Law& a, const Law& b) {
  double sum = 0;
  for (size_t k = 0; k < a.p.size(); ++k) sum += std::abs(a.p[k] - b.p[k]);
  return sum / 2;
}

// The bound sensor_noise.h states for the transformed normal draw: its law
// of DN within a total variation of 1e-4 of the exact law (2e-5 at 2.4 e- of
// read noise and more) for means from 0.01 e- to the full-well band, at 0 and
// 24 dB of gain, 12 and 16 bits, and a sensor binned 8 x 8 (a 64x deeper
// well). Computed from both laws, not sampled: it holds for every draw.
TEST(SensorNoise, TheTransformedDrawIsWithinItsBoundOfTheExactLaw) {
  struct Case {
    double readNoise, gain;
    int bits;
    double fullWell, bound;
  };
  const std::vector<Case> cases = {
      {2.4, 1, 12, 10500, 2e-5},
      {2.4, 15.85, 12, 10500, 2e-5},
      {2.4, 1, 16, 10500, 2e-5},
      {2.4, 1, 12, 672000, 2e-5},
      {6.0, 1, 12, 10500, 2e-5},
      {kTransformedMinReadNoise_e, 1, 12, 10500, 1e-4},
      {kTransformedMinReadNoise_e, 15.85, 12, 10500, 1e-4},
      {kTransformedMinReadNoise_e, 1, 16, 10500, 1e-4},
  };
  for (const Case& c : cases) {
    CameraSensorModel m;
    m.readNoise_e = c.readNoise, m.gain = c.gain, m.bitDepth = c.bits, m.fullWell_e = c.fullWell;
    const double bandFrom = c.fullWell - 8 * std::sqrt(c.fullWell) - 10;
    double worst = 0, worstMean = 0;
    for (double mean = 0.01; mean < std::min(bandFrom, 20000.0); mean *= 1.7) {
      const ShotReadTransform t = ShotReadTransform::at(mean, c.readNoise);
      for (double z = -5.8; z < 5.8; z += 0.01)
        ASSERT_GT(t.electrons(static_cast<float>(z + 0.01)), t.electrons(static_cast<float>(z)))
            << "not increasing at z = " << z << ", mean " << mean;
      const double tv = totalVariation(exactLaw(m, mean), transformedLaw(m, mean));
      if (tv > worst) worst = tv, worstMean = mean;
    }
    EXPECT_LT(worst, c.bound) << "read noise " << c.readNoise << " e-, gain " << c.gain << ", " << c.bits
                              << " bits, well " << c.fullWell << ": worst at a mean of " << worstMean << " e-";
    RecordProperty(fmt::format("tv_r{}_g{}_b{}_w{}", c.readNoise, c.gain, c.bits, c.fullWell),
                   fmt::format("{:.2e}", worst));
  }
}

// What capture() draws, against the exact law, at every exposure level and on
// every path: the transformed normal (dark to 70 % of the well), the exact
// sampler (the full-well band; a sensor with little read noise), the full well
// (past the band), with gain and at 16 bits. 262 144 pixels a level: the
// histogram by chi-square (sensor_noise.h's bound is 1e-4, the test sees ~1e-2),
// the mean within 5 of its standard errors, the variance within 5 of its own.
TEST(SensorNoise, CapturedDigitalNumbersFollowTheExactLawAtEveryExposureLevel) {
  struct Level {
    double mean, readNoise = 2.4, gain = 1;
    int bits = 12;
  };
  const std::vector<Level> levels = {{0},
                                     {0.3},
                                     {3},
                                     {30},
                                     {300},
                                     {3000},
                                     {7350},
                                     {9950},
                                     {10300},
                                     {11400},
                                     {300, 2.4, 15.85},
                                     {3000, 2.4, 1, 16},
                                     {30, 1.0},
                                     {3000, 1.0}};
  std::uint64_t seed = 61;
  for (const Level& level : levels) {
    CameraSensorModel m;
    m.readNoise_e = level.readNoise, m.gain = level.gain, m.bitDepth = level.bits, m.electronsPerUnit = 1;
    const cv::Mat dn = m.capture(flat(512, static_cast<float>(level.mean)), ++seed);
    std::vector<double> counts(static_cast<size_t>(m.maxDigitalNumber()) + 1, 0.0);
    for (auto it = dn.begin<std::uint16_t>(); it != dn.end<std::uint16_t>(); ++it) counts[*it] += 1;
    const Law law = exactLaw(m, level.mean);
    const std::string what = fmt::format("mean {} e-, read noise {} e-, gain {}, {} bits", level.mean, level.readNoise,
                                         level.gain, level.bits);
    const ChiSquare test = chiSquare(counts, law.p);
    EXPECT_LT(test.statistic, test.threshold) << what << ": " << test.bins << " bins";
    const double n = static_cast<double>(dn.total());
    double mean, sd;
    meanStd(dn, mean, sd);
    EXPECT_NEAR(mean, law.mean, 5 * std::sqrt(law.variance / n)) << what;
    EXPECT_NEAR(sd * sd, law.variance, 5 * std::sqrt((law.fourth - law.variance * law.variance) / n) + 1e-12) << what;
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
