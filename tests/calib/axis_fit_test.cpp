// SPDX-License-Identifier: Apache-2.0
// The lens axis fit on points of known answer: exact axes, the points a
// lenticular sheet's Gray code gives (on the axis, quantised to a panel
// pixel) and a line barrier's (spread over the slit), outliers, and the
// refusals.

#include "lfi/calib/axis_fit.h"
#include "lfi/core/error.h"

#include "lfi_test_support.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace {

using namespace lfi;
using namespace lfi::calib;
using lfi::testing_support::throwsError;

constexpr double kPixel_mm = 0.0315;
constexpr int kHalfPanel_px = 400;  // an 800 x 800 panel

struct AxesTruth {
  double pitch_px = 32.3, slant_rad = 0.12, offset_px = 5.2;
  double x(int m, double y) const { return y * std::tan(slant_rad) + offset_px + m * pitch_px; }
};

// Points along every axis within the panel, one every `step_px` up it, placed by `place(x on the axis, y)`, in mm.
template <typename Place>
std::vector<WeightedPoint> axisPoints(const AxesTruth& t, double step_px, Place place) {
  std::vector<WeightedPoint> out;
  for (int m = -20; m <= 20; ++m)
    for (double y = -kHalfPanel_px + 0.5; y < kHalfPanel_px; y += step_px) {
      const double x = t.x(m, y);
      if (std::abs(x) >= kHalfPanel_px) continue;
      const Vec2 p = place(x, y);
      out.push_back({{p.x * kPixel_mm, p.y * kPixel_mm}, 1});
    }
  return out;
}

// A panel pixel's centre (the Gray code names pixels): x and y to the nearest centre, ±0.5 px.
Vec2 quantised(double x, double y) {
  return {std::floor(x) + 0.5, std::floor(y) + 0.5};
}

TEST(AxisFit, ExactAxesAreRecoveredExactly) {
  for (const double slant : {0.0, 0.12, -0.3}) {
    AxesTruth t;
    t.slant_rad = slant;
    const AxisFit fit =
        fitLensAxes(axisPoints(t, 7, [](double x, double y) { return Vec2(x, y); }), kPixel_mm, 32, slant + 0.02);
    EXPECT_NEAR(fit.pitch_px, t.pitch_px, 1e-9);
    EXPECT_NEAR(fit.slant_rad, t.slant_rad, 1e-11);
    EXPECT_NEAR(fit.offset_px, t.offset_px, 1e-9);
    EXPECT_EQ(fit.outliers, 0);
    EXPECT_NEAR(fit.residualRms_px, 0, 1e-9);
    // No residual, but a pixel's quantum still bounds what the points can tell: axes along the columns keep an
    // error of up to half a pixel over their length, 1/√12 px shared by each axis's points, over the axes.
    EXPECT_GT(fit.offsetSigma_px, 0);
    if (slant == 0) {
      EXPECT_GE(fit.offsetSigma_px, 0.5 / std::sqrt(12.0 * fit.axes));
    }
  }
}

TEST(AxisFit, TheOffsetNamesTheAxisNearestThePanelsCentre) {
  AxesTruth t;
  t.offset_px = 5.2 + 3 * t.pitch_px;  // the same axes, numbered from another one
  const AxisFit fit = fitLensAxes(axisPoints(t, 7, [](double x, double y) { return Vec2(x, y); }), kPixel_mm, 32, 0.1);
  EXPECT_NEAR(fit.offset_px, 5.2, 1e-9);
  EXPECT_EQ(fit.nearestAxis(5.2 + 0.4 * t.pitch_px, 0), 0);
  EXPECT_EQ(fit.nearestAxis(5.2 + 0.6 * t.pitch_px, 0), 1);
  EXPECT_NEAR(fit.x(2, 10), 10 * std::tan(t.slant_rad) + 5.2 + 2 * t.pitch_px, 1e-9);
}

// Points quantised to pixel centres (a lenticular sheet's) and spread over a slit (a line barrier's), over random
// axes: every value within its expanded uncertainty (k = 2) in at least 90 % of the trials, and within what the
// points can tell: no axis moved by more than half a pixel at the panel's edge (400 px out) by the pitch's or the
// slant's error, nor by the offset's (the points name pixels; an axis along the pixel columns keeps one
// quantisation error of up to half a pixel over its whole length).
TEST(AxisFit, QuantisedAndSlitWidePointsAreWithinTheirUncertainty) {
  std::mt19937 random(20261205);
  std::uniform_real_distribution<double> unit(-1, 1);
  for (const double slit_px : {0.0, 4.0}) {
    SCOPED_TRACE(slit_px == 0 ? "lenticular" : "line barrier");
    int trials = 0, pitch = 0, slant = 0, offset = 0;
    for (int trial = 0; trial < 20; ++trial) {
      AxesTruth t;
      t.pitch_px = 32 * (1 + 0.02 * unit(random));
      // One trial in four with the axes along the pixel columns, as many line barriers are: each axis's points
      // then share one quantisation error.
      t.slant_rad = trial % 4 == 0 ? 0 : 0.2 * unit(random);
      t.offset_px = 0.5 * t.pitch_px * unit(random);
      const auto points = axisPoints(t, 3, [&](double x, double y) {
        const double across = 0.5 * slit_px * unit(random);  // uniform over the slit, along the row
        return quantised(x + across, y);
      });
      // The display states its slant to a degree or so.
      const AxisFit fit = fitLensAxes(points, kPixel_mm, 32, t.slant_rad + 0.02 * unit(random));
      const double k = 2;
      EXPECT_LE(std::abs(fit.pitch_px - t.pitch_px), 0.5 / (kHalfPanel_px / t.pitch_px));
      EXPECT_LE(std::abs(std::tan(fit.slant_rad) - std::tan(t.slant_rad)), 0.5 / kHalfPanel_px);
      EXPECT_LE(std::abs(fit.offset_px - t.offset_px), 0.5);
      ++trials;
      pitch += std::abs(fit.pitch_px - t.pitch_px) <= k * fit.pitchSigma_px;
      slant += std::abs(fit.slant_rad - t.slant_rad) <= k * fit.slantSigma_rad;
      offset += std::abs(fit.offset_px - t.offset_px) <= k * fit.offsetSigma_px;
    }
    const int least = static_cast<int>(std::ceil(0.9 * trials));
    EXPECT_GE(pitch, least);
    EXPECT_GE(slant, least);
    EXPECT_GE(offset, least);
  }
}

TEST(AxisFit, PointsOffTheAxesAreLeftOut) {
  AxesTruth t;
  auto points = axisPoints(t, 3, [](double x, double y) { return quantised(x, y); });
  const size_t good = points.size();
  std::mt19937 random(7);
  std::uniform_real_distribution<double> anywhere(-kHalfPanel_px * kPixel_mm, kHalfPanel_px * kPixel_mm);
  for (size_t k = 0; k < good / 10; ++k) points.push_back({{anywhere(random), anywhere(random)}, 1});
  const AxisFit fit = fitLensAxes(points, kPixel_mm, 32, 0.1);
  EXPECT_NEAR(fit.pitch_px, t.pitch_px, 0.1 / (kHalfPanel_px / t.pitch_px));
  EXPECT_NEAR(fit.offset_px, t.offset_px, 0.1);
  EXPECT_GE(fit.outliers, static_cast<int>(0.8 * (good / 10)));  // the rest land near an axis by chance
}

TEST(AxisFit, RefusalsAreNamed) {
  AxesTruth t;
  const auto exact = [](double x, double y) { return Vec2(x, y); };
  EXPECT_TRUE(throwsError([&] { fitLensAxes(axisPoints(t, 7, exact), kPixel_mm, 0, 0); }, Errc::InvalidArgument,
                          {"nominal pitch"}));
  EXPECT_TRUE(throwsError([&] { fitLensAxes(axisPoints(t, 7, exact), kPixel_mm, 32, 1.0); }, Errc::InvalidArgument,
                          {"nominal slant"}));
  EXPECT_TRUE(throwsError([&] { fitLensAxes({}, kPixel_mm, 32, 0); }, Errc::Device, {"0 lens axes"}));
  // Two axes' points only.
  std::vector<WeightedPoint> two;
  for (const WeightedPoint& p : axisPoints(t, 7, exact))
    if (std::abs(p.position_mm.x / kPixel_mm - p.position_mm.y / kPixel_mm * std::tan(t.slant_rad) - t.offset_px -
                 0.5 * t.pitch_px) < 0.6 * t.pitch_px)
      two.push_back(p);
  EXPECT_TRUE(throwsError([&] { fitLensAxes(two, kPixel_mm, 32, 0.1); }, Errc::Device, {"fewer than 3"}));
  // Points scattered over the panel: no axes.
  std::mt19937 random(3);
  std::uniform_real_distribution<double> anywhere(-kHalfPanel_px * kPixel_mm, kHalfPanel_px * kPixel_mm);
  std::vector<WeightedPoint> scattered;
  for (int k = 0; k < 3000; ++k) scattered.push_back({{anywhere(random), anywhere(random)}, 1});
  EXPECT_TRUE(throwsError([&] { fitLensAxes(scattered, kPixel_mm, 32, 0); }, Errc::Device, {"too large"}));
}

}  // namespace
