// SPDX-License-Identifier: Apache-2.0
// The lens array fit and the camera scale fit on points of known answer:
// exact lattices and cameras, the same quantised to a panel pixel or with
// noise, outliers, and the refusals.

#include "lfi/calib/lattice_fit.h"
#include "lfi/calib/camera_scale.h"
#include "lfi/core/error.h"

#include "lfi_test_support.h"
#include "normalised_errors.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

namespace {

using namespace lfi;
using namespace lfi::calib;
using lfi::testing_support::chiSquareLower1e3;
using lfi::testing_support::maxOfEstimatesInflation;
using lfi::testing_support::NormalisedErrors;
using lfi::testing_support::throwsError;

struct LatticeTruth {
  LensPacking packing = LensPacking::Square;
  double pitch = 1.0, rotation = 0.01;
  Vec2 offset{0.3, -0.2};
  Vec2 point(int i, int j) const {
    const Vec2 l = packing == LensPacking::Square ? Vec2(i, j) : Vec2(i + 0.5 * j, 0.5 * std::sqrt(3.0) * j);
    return offset + pitch * Vec2(std::cos(rotation) * l.x - std::sin(rotation) * l.y,
                                 std::sin(rotation) * l.x + std::cos(rotation) * l.y);
  }
};

// The lattice's points within ±half of the origin, each moved by `error`.
template <typename Error>
std::vector<WeightedPoint> latticePoints(const LatticeTruth& t, double half, Error error) {
  std::vector<WeightedPoint> out;
  for (int j = -40; j <= 40; ++j)
    for (int i = -40; i <= 40; ++i) {
      const Vec2 p = t.point(i, j);
      if (std::abs(p.x) <= half && std::abs(p.y) <= half) out.push_back({error(p), 1});
    }
  return out;
}

TEST(LatticeFit, AnExactLatticeIsRecoveredExactly) {
  for (const LensPacking packing : {LensPacking::Square, LensPacking::Hexagonal}) {
    LatticeTruth t;
    t.packing = packing;
    const LatticeFit fit = fitLensLattice(latticePoints(t, 12, [](Vec2 p) { return p; }), packing, 1.0, 0, 0.0315);
    EXPECT_NEAR(fit.pitch_mm, t.pitch, 1e-12);
    EXPECT_NEAR(fit.rotation_rad, t.rotation, 1e-12);
    EXPECT_NEAR(fit.offset_mm.x, t.offset.x, 1e-12);
    EXPECT_NEAR(fit.offset_mm.y, t.offset.y, 1e-12);
    EXPECT_EQ(fit.outliers, 0);
    EXPECT_NEAR(fit.residualRms_mm, 0, 1e-12);
    // No residual, but the panel's quantum still bounds what the centres can tell.
    EXPECT_GT(fit.pitchSigma_mm, 0);
  }
}

TEST(LatticeFit, TheRotationIsReportedWithinThePackingsSymmetry) {
  // A square lattice turned by 90° + 0.01 rad is the same lattice as one turned by 0.01 rad; a hexagonal one
  // turned by 60° + 0.01 rad too.
  LatticeTruth square;
  square.rotation = M_PI / 2 + 0.01;
  EXPECT_NEAR(
      fitLensLattice(latticePoints(square, 12, [](Vec2 p) { return p; }), LensPacking::Square, 1.0, M_PI / 2, 0.0315)
          .rotation_rad,
      0.01, 1e-12);
  LatticeTruth hexagonal;
  hexagonal.packing = LensPacking::Hexagonal;
  hexagonal.rotation = M_PI / 3 + 0.01;
  EXPECT_NEAR(
      fitLensLattice(latticePoints(hexagonal, 12, [](Vec2 p) { return p; }), LensPacking::Hexagonal, 1.0, 0, 0.0315)
          .rotation_rad,
      0.01, 1e-12);
}

TEST(LatticeFit, TheOffsetNamesTheLensNearestThePanelsCentre) {
  LatticeTruth t;
  t.offset = {3.3, -4.2};  // a lattice point 3 and 4 lenses away: (0.3, -0.2) is nearest the centre
  const LatticeFit fit = fitLensLattice(latticePoints(t, 12, [](Vec2 p) { return p; }), t.packing, 1.0, 0, 0.0315);
  const Vec2 nearest = t.point(-3, 4);
  EXPECT_NEAR(fit.offset_mm.x, nearest.x, 1e-12);
  EXPECT_NEAR(fit.offset_mm.y, nearest.y, 1e-12);
}

TEST(LatticeFit, CentresQuantisedToAPanelPixelAreCoveredByTheirUncertainty) {
  // Each centre rounded to the pixel grid of a 0.0315 mm panel: the error a lens array measured on a panel has.
  // Over lattices of random pitch, rotation and offset the expanded uncertainty (k = 2) covers the error at
  // least 9 times in 10, and the error stays below a quarter pixel at the panel's edge (12.6 mm).
  const double q = 0.0315;
  std::mt19937 random(7);
  std::uniform_real_distribution<double> unit(-1, 1);
  int covered = 0;
  const int trials = 40;
  for (int trial = 0; trial < trials; ++trial) {
    LatticeTruth t;
    t.pitch = 1 + 0.01 * unit(random);
    t.rotation = unit(random) * M_PI / 180;
    t.offset = {0.5 * unit(random), 0.5 * unit(random)};
    const LatticeFit fit = fitLensLattice(
        latticePoints(t, 12.6,
                      [&](Vec2 p) { return Vec2(q * (std::floor(p.x / q) + 0.5), q * (std::floor(p.y / q) + 0.5)); }),
        t.packing, 1.0, 0, q);
    const double error = fit.pitch_mm - t.pitch;
    EXPECT_LE(std::abs(error) * 12.6, 0.25 * q);
    EXPECT_LE(std::abs(fit.rotation_rad - t.rotation) * 12.6, 0.25 * q);
    covered += std::abs(error) <= 2 * fit.pitchSigma_mm;
  }
  EXPECT_GE(covered, 0.9 * trials);
  // No bound from the other side (U not much larger than the errors). The pitch's σ is the floor of a panel
  // pixel's quantisation shared by a lattice column (row), term (3) of lattice_fit.h, not a spread: with the
  // centres' error the quantisation alone (q / √12 each), the least squares' term is that floor over √(the about
  // 25 lenses of a column), a fifth of it, and the clustered one measures how much of a column's error is shared,
  // at most all of it: σ is the floor in every trial, and the errors spread 0.18 of it (rms z over these 40). The
  // offset's σ is the same floor. The rotation's is the least squares' (a column's shared error turns nothing), but
  // the quantisation of a regular lattice is no independent noise: its errors spread 0.55 of σ here, yet 1.5 % of
  // 4000 such lattices lie beyond 3σ, and with the pitch near 32 q (1.008 mm) and the rotation below about
  // q / 25 mm (0.0013 rad) the centres quantise to an exact lattice and σ is 0 (4 of the 4000): σ bounds the
  // rotation's spread from neither side.
}

TEST(LatticeFit, OutliersAreLeftOutAndTooManyRefused) {
  LatticeTruth t;
  std::vector<WeightedPoint> points = latticePoints(t, 12, [](Vec2 p) { return p; });
  const size_t lenses = points.size();
  // A tenth as many points again, each half-way between two lenses: misdecoded pixels.
  for (size_t k = 0; k < lenses / 10; ++k) points.push_back({points[k].position_mm + Vec2(0.5, 0.5), 1});
  const LatticeFit fit = fitLensLattice(points, t.packing, 1.0, 0, 0.0315);
  EXPECT_EQ(fit.outliers, static_cast<int>(lenses / 10));
  EXPECT_NEAR(fit.pitch_mm, t.pitch, 1e-12);
  // As many again: half of them are off the lattice.
  for (size_t k = lenses / 10; k < lenses; ++k) points.push_back({points[k].position_mm + Vec2(0.5, 0.5), 1});
  EXPECT_TRUE(throwsError([&] { fitLensLattice(points, t.packing, 1.0, 0, 0.0315); }, Errc::Device,
                          {"too large for the model"}));
}

TEST(LatticeFit, TooFewOrUnrelatedCentresAreRefused) {
  LatticeTruth t;
  const auto exact = [](Vec2 p) { return p; };
  EXPECT_TRUE(throwsError([&] { fitLensLattice(latticePoints(t, 1, exact), t.packing, 1.0, 0, 0.0315); }, Errc::Device,
                          {"fewer than the 9"}));
  // Lenses 3 mm apart, the display stating 1 mm: no neighbours at the nominal pitch.
  t.pitch = 3;
  EXPECT_TRUE(throwsError([&] { fitLensLattice(latticePoints(t, 12, exact), t.packing, 1.0, 0, 0.0315); }, Errc::Device,
                          {"neighbours"}));
  // One row of lenses.
  std::vector<WeightedPoint> row;
  for (int i = 0; i < 20; ++i) row.push_back({Vec2(i, 0), 1});
  EXPECT_TRUE(
      throwsError([&] { fitLensLattice(row, LensPacking::Square, 1.0, 0, 0.0315); }, Errc::Device, {"1 row(s)"}));
  EXPECT_TRUE(throwsError([&] { fitLensLattice(row, LensPacking::Square, 0, 0, 0.0315); }, Errc::InvalidArgument,
                          {"nominal pitch"}));
}

TEST(ClusterPoints, JoinsNeighboursIntoWeightedCentroids) {
  const std::vector<WeightedPoint> points = {{{0, 0}, 1}, {{0.1, 0}, 3}, {{0.15, 0.05}, 1}, {{5, 5}, 2}};
  const std::vector<WeightedPoint> clusters = clusterPoints(points, 0.2);
  ASSERT_EQ(clusters.size(), 2u);
  EXPECT_DOUBLE_EQ(clusters[0].weight, 5);
  EXPECT_NEAR(clusters[0].position_mm.x, (0 + 0.3 + 0.15) / 5, 1e-15);
  EXPECT_NEAR(clusters[0].position_mm.y, 0.05 / 5, 1e-15);
  EXPECT_DOUBLE_EQ(clusters[1].weight, 2);
  EXPECT_TRUE(throwsError([&] { clusterPoints(points, 0); }, Errc::InvalidArgument, {"radius"}));
  EXPECT_TRUE(throwsError([&] { clusterPoints({{{0, 0}, -1}}, 1); }, Errc::InvalidArgument, {"weight"}));
}

// A camera of 0.5 mm pixels on the display, mirrored in y and turned by 0.02 rad, its centre at (1, -2) mm.
struct CameraTruth {
  double pixel = 0.5, rotation = 0.02, kappa = 0;
  Vec2 centre{1, -2};
  cv::Size image{56, 56};
  Vec2 display(const Vec2& camera) const {
    const Vec2 c(0.5 * (image.width - 1), 0.5 * (image.height - 1));
    const double r2 = c.length2();
    Vec2 d = camera - c;
    d *= 1 + kappa * d.length2() / r2;
    return centre + pixel * Vec2(std::cos(rotation) * d.x + std::sin(rotation) * d.y,
                                 std::sin(rotation) * d.x - std::cos(rotation) * d.y);
  }
};

std::vector<CameraPoint> cameraPoints(const CameraTruth& t, double noise_px, std::uint32_t seed) {
  std::mt19937 random(seed);
  std::normal_distribution<double> normal(0, 1);  // (a deviation of 0 is outside the distribution's domain)
  std::vector<CameraPoint> out;
  for (int v = 2; v < t.image.height - 2; v += 2)
    for (int u = 2; u < t.image.width - 2; u += 2) {
      const Vec2 camera(u + 0.3, v - 0.2);
      const Vec2 error(noise_px * normal(random), noise_px * normal(random));
      out.push_back({camera + error, t.display(camera), {u / 2, v / 2}});
    }
  return out;
}

TEST(CameraScaleFit, AnAffineCameraIsRecoveredExactly) {
  const CameraTruth t;
  const CameraScaleFit fit = fitCameraScale(cameraPoints(t, 0, 1), t.image);
  EXPECT_NEAR(fit.objectPixel_mm, t.pixel, 1e-12);
  EXPECT_NEAR(fit.pixelX_mm, t.pixel, 1e-12);
  EXPECT_NEAR(fit.pixelY_mm, t.pixel, 1e-12);
  EXPECT_NEAR(fit.rotation_rad, t.rotation, 1e-12);
  EXPECT_TRUE(fit.mirrored);
  EXPECT_NEAR(fit.map.atImageCentre_mm.x, t.centre.x, 1e-12);
  EXPECT_NEAR(fit.map.atImageCentre_mm.y, t.centre.y, 1e-12);
  EXPECT_NEAR(fit.distortion_px, 0, 1e-9);
  const Vec2 corner = fit.map.displayPoint({0, 0}, t.image), expected = t.display({0, 0});
  EXPECT_NEAR(corner.x, expected.x, 1e-12);
  EXPECT_NEAR(corner.y, expected.y, 1e-12);
}

TEST(CameraScaleFit, RadialDistortionIsMeasuredAtTheCorner) {
  CameraTruth t;
  t.kappa = 0.004;  // the corner 0.004 R = 0.16 px nearer the centre than an affine camera has it
  const CameraScaleFit fit = fitCameraScale(cameraPoints(t, 0, 1), t.image);
  const double r = Vec2(27.5, 27.5).length();
  EXPECT_NEAR(fit.distortion_px, t.kappa * r, 1e-9);
}

TEST(CameraScaleFit, NoisySpotsAreCoveredByTheirUncertainty) {
  // 0.05 px of centroid noise: the expanded uncertainty (k = 2) of the scale covers its error 9 times in 10.
  const CameraTruth t;
  int covered = 0;
  NormalisedErrors scale, centre, distortion;  // the other side (below)
  const int trials = 100;
  for (int trial = 0; trial < trials; ++trial) {
    const CameraScaleFit fit = fitCameraScale(cameraPoints(t, 0.05, static_cast<std::uint32_t>(trial)), t.image);
    const double scaleError = fit.objectPixel_mm - t.pixel;
    covered += std::abs(scaleError) <= 2 * fit.objectPixelSigma_mm;
    scale.add(scaleError, fit.objectPixelSigma_mm);
    centre.add(fit.map.atImageCentre_mm.x - t.centre.x, fit.centreSigma_mm.x);
    centre.add(fit.map.atImageCentre_mm.y - t.centre.y, fit.centreSigma_mm.y);
    distortion.add(fit.distortion_px, fit.distortionSigma_px);  // the truth has none
  }
  EXPECT_GE(covered, 0.9 * trials);

  // ... and U is not stated much larger than the errors: where σ is right, Σ z² (z = error / σ) over the trials is
  // chi-square(100) for the scale, chi-square(200) for the display point at the image's centre (x and y
  // independent: the noise's u and v turned by A, orthogonal up to the scale) and chi-square(100) for the
  // distortion (the full fit's κ takes the noise the affine fit leaves, independent of the scale's). Each σ is the
  // largest of the least squares' (ν = 2 · 676 − 6 = 1346) and the covariance clustered by the 26 lens columns (x)
  // and 26 rows (y) times G / (G − p) = 52 / 46. That one, for these spots, is on average 1.009 times the truth for
  // the scale (the x residuals of a column weigh (u − ū)², and its 26 sums lose their projection on 1 and u:
  // 1 − 1/26 − Σ(u − ū)⁴ / (Σ(u − ū)²)² = 0.892, times 52 / 46), 1.044 for the centre (equal weights: 24 / 26
  // times 52 / 46) and 1.068 for the distortion, and spreads as a chi-square of ν = 27.1, 23.8 and 30.0
  // (Satterthwaite's (tr M)² / tr M², M = (I − H) B (I − H), from this layout's Jacobian). The largest of the two
  // is on average at most b (1 + 1/√(πν')) times the truth, b that bias and 1/ν' = 1/ν + 1/1346 (the two
  // correlate positively, which only lowers it): 1.01 · maxOfEstimatesInflation(26) = 1.122,
  // 1.044 · maxOfEstimatesInflation(23) = 1.167 and 1.068 · maxOfEstimatesInflation(29) = 1.180. (The noise is in
  // the camera positions the fit regresses on: it shrinks the scale by 1.1 · 10⁻⁵ of itself, 0.12 σ, which only adds to
  // Σ z².) Held to chi-square's lower 10⁻³ quantile over these: 55.2, 123.2 and 52.4 (a Monte Carlo of
  // Σ xᵢ / max(pᵢ, b cᵢ), x ~ χ²₁, p ~ χ²₁₃₄₆ / 1346, c ~ χ²_ν / ν, finds 0.64, 0.24 and 0.31 10⁻³ below them;
  // 3 10⁵ draws each). A U twice too large quarters Σ z² and fails with probability P(χ²₁₀₀ < 220.6) =
  // 1 − 4 10⁻¹¹, P(χ²₂₀₀ < 493) = 1 − 10⁻²⁶ and P(χ²₁₀₀ < 209.7) = 1 − 9 10⁻¹⁰ (40 trials, as this test ran
  // before, would give 0.990 on the scale and 0.980 on the distortion; 100 take 0.03 s).
  std::printf("[ info     ] rms z of the scale, the centre and the distortion: %.2f %.2f %.2f over %d trials\n",
              scale.rms(), centre.rms(), distortion.rms(), trials);
  EXPECT_GE(scale.sum2, chiSquareLower1e3(scale.n) / (1.01 * maxOfEstimatesInflation(26))) << "rms z " << scale.rms();
  EXPECT_GE(centre.sum2, chiSquareLower1e3(centre.n) / (1.044 * maxOfEstimatesInflation(23)))
      << "rms z " << centre.rms();
  EXPECT_GE(distortion.sum2, chiSquareLower1e3(distortion.n) / (1.068 * maxOfEstimatesInflation(29)))
      << "rms z " << distortion.rms();
}

TEST(CameraScaleFit, TooFewOrCollinearSpotsAreRefused) {
  const CameraTruth t;
  std::vector<CameraPoint> points = cameraPoints(t, 0, 1);
  points.resize(5);
  EXPECT_TRUE(throwsError([&] { fitCameraScale(points, t.image); }, Errc::Device, {"fewer than the 6"}));
  std::vector<CameraPoint> line;
  for (int u = 0; u < 20; ++u) line.push_back({Vec2(u, 10), t.display(Vec2(u, 10)), {u, 0}});
  EXPECT_TRUE(throwsError([&] { fitCameraScale(line, t.image); }, Errc::Device, {"one line"}));
}

TEST(SpotCentroid, FindsASymmetricSpotsCentreAndRefusesOneOutOfTheImage) {
  cv::Mat image(40, 40, CV_32FC1);
  const Vec2 centre(17.3, 21.65);
  for (int y = 0; y < image.rows; ++y)
    for (int x = 0; x < image.cols; ++x)
      image.at<float>(y, x) = static_cast<float>(std::exp(-(Vec2(x, y) - centre).length2() / (2 * 1.5 * 1.5)));
  const auto spot = spotCentroid(image, {16, 23}, 7, 0);
  ASSERT_TRUE(spot);
  EXPECT_NEAR(spot->centre_px.x, centre.x, 0.01);
  EXPECT_NEAR(spot->centre_px.y, centre.y, 0.01);
  EXPECT_FALSE(spotCentroid(image, {3, 20}, 7, 0));      // the window leaves the image
  EXPECT_FALSE(spotCentroid(image, {16, 23}, 7, 1e6));   // too little light
  EXPECT_FALSE(spotCentroid(image, {NAN, 23}, 7, 0));    // no guess
  EXPECT_FALSE(spotCentroid(image, {1e300, 23}, 7, 0));  // none within reach of an integer
}

}  // namespace
