// SPDX-License-Identifier: Apache-2.0
// Display distance calibration: light field propagation against an analytic
// light field, and the full calibration against the ray-traced bench.

#include "lfi/calib/display_distance.h"
#include "lfi/sim/render.h"

#include "lfi_test_support.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

namespace {

using namespace lfi;
using namespace lfi::sim;
using lfi::testing_support::throwsError;

LightFieldGeometry smallGeometry() {
  LightFieldGeometry g;
  g.spatialX = g.spatialY = 24;
  g.angular = 15;
  g.pixelPitch_mm = 0.04;  // elements of 0.6 mm, 14.4 mm across
  g.distance_mm = 30;
  return g;
}

// The light field of a luminous disc of radius r centred on the axis at
// height h above the plane: a ray of sight (q, d) sees it iff it crosses the
// plane z = h within r of the axis.
LightField discLightField(const LightFieldGeometry& g, double h, double r) {
  LightField lf(g);
  for (int ey = 0; ey < g.spatialY; ++ey)
    for (int ex = 0; ex < g.spatialX; ++ex)
      for (int v = 0; v < g.angular; ++v)
        for (int u = 0; u < g.angular; ++u) {
          const Vec2 disc = lf.angularCentre(u, v);
          if (disc.x * disc.x + disc.y * disc.y >= 1) continue;
          const Vec3 d = LightField::directionFromDisc(disc);
          const Vec2 q = lf.elementCentre(ex, ey);
          const Vec2 at(q.x + h * d.x / d.z, q.y + h * d.y / d.z);
          lf.at(ex, ey, u, v) = at.length() < r ? 1.f : 0.f;
        }
  return lf;
}

TEST(PropagateLightField, ZeroIsTheIdentityAndDistanceFollows) {
  const LightField a = discLightField(smallGeometry(), 12, 6);
  const LightField b = calib::propagateLightField(a, 0);
  EXPECT_EQ(cv::norm(a.lensletImage(), b.lensletImage(), cv::NORM_INF), 0.0);
  EXPECT_DOUBLE_EQ(calib::propagateLightField(a, 2.5).geometry().distance_mm, 27.5);
}

TEST(PropagateLightField, MatchesTheAnalyticFieldOnTheMovedPlane) {
  // Moving the plane 3 mm towards the disc leaves it 9 mm away: the propagated
  // field must equal the analytic one at h = 9 wherever the propagated ray
  // started inside the original plane (steep rays near the border came from
  // outside it: no data), except where a sample sits on the disc's edge
  // (nearest lookup takes the element centre's ray, up to 0.3 mm away).
  const LightFieldGeometry g = smallGeometry();
  const double dz = 3, h = 12, r = 6;
  const LightField original = discLightField(g, h, r);
  const LightField moved = calib::propagateLightField(original, dz, LightFieldLookup::Nearest);
  const LightField expected = discLightField(g, h - dz, r);
  int compared = 0, lit = 0, differ = 0, differUnmoved = 0;
  for (int ey = 0; ey < g.spatialY; ++ey)
    for (int ex = 0; ex < g.spatialX; ++ex)
      for (int v = 0; v < g.angular; ++v)
        for (int u = 0; u < g.angular; ++u) {
          const Vec2 disc = moved.angularCentre(u, v);
          if (disc.x * disc.x + disc.y * disc.y >= 1) continue;
          const Vec3 d = LightField::directionFromDisc(disc);
          const Vec2 q = moved.elementCentre(ex, ey);
          const Vec2 source(q.x - dz * d.x / d.z, q.y - dz * d.y / d.z);
          if (std::abs(source.x) > g.extentX_mm() / 2 || std::abs(source.y) > g.extentY_mm() / 2) continue;
          ++compared;
          lit += expected.at(ex, ey, u, v) > 0.5;
          differ += std::abs(moved.at(ex, ey, u, v) - expected.at(ex, ey, u, v)) > 0.5;
          differUnmoved += std::abs(original.at(ex, ey, u, v) - expected.at(ex, ey, u, v)) > 0.5;
        }
  ASSERT_GT(lit, 2000);
  EXPECT_LT(differ, 0.1 * lit) << compared << " compared";
  EXPECT_GT(differUnmoved, 3 * differ);
}

// The simulated bench: intact lens, light field captured at Δ = 30 mm, display
// actually at Δ + trueError, telecentric camera (0.243x, NA 0.0152).
struct Bench {
  std::shared_ptr<const Solid> lens = Solid::sphericalLens(51.5, -51.5, 5, 25.4);
  LightFieldGeometry g = smallGeometry();
  TelecentricCamera camera;
  Bench() {
    camera.imageDistance_mm = 0.243 * 102.5;
    camera.focalLength_mm = 1 / (1 / 102.5 + 1 / camera.imageDistance_mm);
    camera.stopDiameter_mm = 2 * camera.focalLength_mm * std::tan(0.0152);
    camera.pixelPitch_mm = 0.5 * 0.243;
    camera.width = camera.height = 48;
    camera.worldFromCamera = TelecentricCamera::lookingDownFrom(102.5);
  }
  LightField capture() const {
    std::vector<Object> objects;
    objects.push_back({"lens", lens, {}, Dielectric{1.5168, 0}, std::nullopt});
    Rigid3 down = Rigid3::rotation({1, 0, 0}, std::numbers::pi);
    down.t = {0, 0, 50};
    objects.push_back({"beam", Rectangle{100, 100}, down, Absorber{}, ParallelEmission{1, 0.0087}});
    RenderOptions ro;
    ro.samplesPerPixel = 64;
    return LightField(g, render(Scene(std::move(objects)), LightFieldSensor{g, Rigid3::translation({0, 0, -30})}, ro));
  }
  cv::Mat inspect(const LightField& shown, double trueError) const {
    std::vector<Object> objects;
    objects.push_back({"lens", lens, {}, Dielectric{1.5168, 0}, std::nullopt});
    objects.push_back({"display", Rectangle{g.extentX_mm(), g.extentY_mm()},
                       Rigid3::translation({0, 0, -30 - trueError}), Absorber{},
                       LightFieldEmission{std::make_shared<LightField>(shown), LightFieldLookup::Interpolated}});
    RenderOptions ro;
    ro.samplesPerPixel = 16;
    return render(Scene(std::move(objects)), camera, ro);
  }
};

TEST(DisplayDistance, MeasuresHowFarTheDisplayMoved) {
  // With an ideal light field emitter (every element emitting its recorded
  // radiance over its whole area) the peak's centre is offset from the
  // display's true error by a constant that the light field's sampling sets
  // (docs/calibration.md; a physical display's peak is not: lfi_cli_test).
  // So the calibration measures the display's position relative to a known
  // one: a scan with the display where the light field was captured gives the
  // offset, and scans at unknown positions must then return their error.
  // Only the lens (radius 12.7 mm, 0.5 mm pixels) counts: a disc of 20 pixels.
  const Bench bench;
  cv::Mat roi = cv::Mat::zeros(48, 48, CV_8UC1);
  cv::circle(roi, {24, 24}, 20, cv::Scalar(255), cv::FILLED);
  const LightField captured = bench.capture();
  const std::vector<double> candidates = {-6, -5, -4, -3, -2, -1, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9};
  auto estimate = [&](double trueError) {
    const auto scan = calib::calibrateDisplayDistance(
        captured, [&](const LightField& lf) { return bench.inspect(lf, trueError); }, candidates, roi);
    std::printf("display error %+.2f mm: the peak's centre at %+.3f mm\n", trueError, scan.estimate_mm);
    return scan.estimate_mm;
  };
  const double offset = estimate(0);
  RecordProperty("sampling_offset_mm", std::to_string(offset));
  EXPECT_LT(std::abs(offset), 3.0);  // a fraction of the 6 mm scan, not a runaway
  // The estimates follow the error with a slope a little under 1: the
  // candidates' own resampling blurs the field more the further they
  // propagate it, which tilts the peak towards ε = 0 (measured: 0.87 with
  // this ideal emitter; docs/calibration.md). A slope far from that (a sign or
  // scale error in the propagation) fails.
  const std::vector<double> errors = {-2.0, 1.5, 3.0};
  double sxx = 0, sxy = 0;
  for (const double trueError : errors) {
    const double relative = estimate(trueError) - offset;
    EXPECT_NEAR(relative, trueError, 0.25 * std::abs(trueError)) << trueError;
    sxx += trueError * trueError, sxy += trueError * relative;
  }
  const double slope = sxy / sxx;  // through the origin: the offset is measured
  RecordProperty("slope", std::to_string(slope));
  std::printf("slope of the estimates against the true errors: %.3f\n", slope);
  EXPECT_GT(slope, 0.78);
  EXPECT_LT(slope, 1.02);
}

// The distance of the plane a shown light field was propagated to, from the
// plane it was captured on: the ε the calibration tried.
double shownEpsilon(const LightField& shown) {
  return shown.geometry().distance_mm - smallGeometry().distance_mm;
}

TEST(DisplayDistance, TheCentreOfThePeakIsFoundBetweenCandidates) {
  const LightField lf(smallGeometry());
  // A tent with its apex at 0.3 mm: the flanks are straight, so the crossings
  // of the level (a quarter down from 97 at ε = 0 to 77 at ε = -2: 92) are
  // exact, at -0.5 and 1.1 mm, and so is their midpoint.
  auto tent = [](const LightField& shown) {
    return cv::Mat(4, 4, CV_32FC1, cv::Scalar(100 - 10 * std::abs(shownEpsilon(shown) - 0.3)));
  };
  const auto scan = calib::calibrateDisplayDistance(lf, tent, {-2, -1, 0, 1, 2});
  EXPECT_NEAR(scan.level, 92, 1e-4);
  EXPECT_NEAR(scan.estimate_mm, 0.3, 1e-5);
  EXPECT_NEAR(scan.width_mm, 1.6, 1e-5);
  ASSERT_EQ(scan.brightness.size(), 5u);
  EXPECT_NEAR(scan.brightness[2], 97, 1e-4);
  // A flat top (a display's depth of field) from -1.6 to 2.4 mm, flanks down to 0 at -3.6 and 4.4 mm: its centre,
  // 0.4 mm, within the interpolation's error (the right crossing's segment holds the top's corner), not the first
  // of the equally bright candidates (-1 mm).
  auto flatTop = [](const LightField& shown) {
    return cv::Mat(4, 4, CV_32FC1, cv::Scalar(50 * std::clamp(4 - std::abs(shownEpsilon(shown) - 0.4), 0.0, 2.0)));
  };
  EXPECT_NEAR(calib::calibrateDisplayDistance(lf, flatTop, {-5, -4, -3, -2, -1, 0, 1, 2, 3, 4, 5}).estimate_mm, 0.4,
              0.05);
  // A peak whose flank is outside the scan is not located: an error that shows the scan, not an answer.
  EXPECT_TRUE(throwsError(
      [&] {
        calib::calibrateDisplayDistance(lf, tent, {-3, -2, -1, 0});
      },
      Errc::InvalidArgument, {"high side", "-1 mm: 87", "scan further"}));
  EXPECT_TRUE(throwsError(
      [&] {
        calib::calibrateDisplayDistance(lf, tent, {1, 2, 3});
      },
      Errc::InvalidArgument, {"low side"}));
}

// What does not change from one image to the next (stray light, a sensor's
// fixed pattern) is not noise: a dark image with a strong pattern does not
// hide a small rise. The noise of a mean comes from the difference of two
// dark images; a dark image's own spread is 2.3 DN here,
// and ten times that refused this 1.5 DN rise.
TEST(DisplayDistance, AFixedPatternInTheDarkIsNotNoise) {
  LightField lf(smallGeometry());
  lf.lensletImage().setTo(1);  // shown fields are not dark; the dark one is all zeros
  cv::Mat pattern(32, 32, CV_32FC1);
  for (int x = 0; x < 32; ++x) pattern.col(x).setTo(8.0 * x);  // 0..248 DN across the image
  cv::RNG rng(11);
  auto image = [&](const LightField& shown) {
    const bool lit = cv::countNonZero(shown.lensletImage()) > 0;
    cv::Mat noise(32, 32, CV_32FC1);
    rng.fill(noise, cv::RNG::NORMAL, 0, 2.0);  // a mean's noise: 2 / 32 = 0.0625
    return cv::Mat(pattern + noise + (lit ? 2 - 0.5 * std::abs(shownEpsilon(shown) - 0.5) : 0.0));
  };
  const auto scan = calib::calibrateDisplayDistance(lf, image, {-3, -2, -1, 0, 1, 2, 3});
  EXPECT_NEAR(scan.noise, 0.0625, 0.01);
  EXPECT_NEAR(scan.dark, 124, 0.1);
  EXPECT_NEAR(scan.estimate_mm, 0.5, 0.2);
}

// Two peaks in one scan (a region over two features, a periodic display's
// neighbouring view): when the second rises above the level, which one is the
// display's is not known and the scan is refused; a lower second one is not a
// peak of the display and the brightest peak's centre is the answer.
TEST(DisplayDistance, TwoPeaksAsBrightAreRefused) {
  const LightField lf(smallGeometry());
  const std::vector<double> candidates = {-6, -5, -4, -3, -2, -1, 0, 1, 2, 3, 4, 5, 6};
  auto twoTents = [](double second) {
    return [second](const LightField& shown) {
      const double e = shownEpsilon(shown);
      return cv::Mat(4, 4, CV_32FC1,
                     cv::Scalar(std::max({100 - 20 * std::abs(e + 3), second - 20 * std::abs(e - 3), 0.0})));
    };
  };
  // Level 83.75 (a quarter down from 100 to the scan's lowest, 35 at +6 mm); the first peak's flanks cross it at
  // -3.8125 and -2.1875 mm.
  EXPECT_TRUE(throwsError([&] { calib::calibrateDisplayDistance(lf, twoTents(95), candidates); }, Errc::InvalidArgument,
                          {"two peaks", "95 again at +3 mm", "above 83.75", "-3.81", "-2.19"}));
  // Level 75 (a quarter down from 100 to 0): crossings at -4.25 and -1.75 mm.
  const auto scan = calib::calibrateDisplayDistance(lf, twoTents(60), candidates);
  EXPECT_NEAR(scan.estimate_mm, -3, 1e-9);
  EXPECT_NEAR(scan.width_mm, 2.5, 1e-9);
}

// A flank that wavers about the level by the noise is not a second peak: the
// brightness {0, 50, 100, 100, 74.9, 75.1, 0} (level 75) with a mean's noise
// of 0.5 falls through the level between 0 and +1 mm and is 0.1 above it at
// +2 mm, well within the noise. The same scan without noise is refused.
TEST(DisplayDistance, AFlankWaveringByTheNoiseIsNotASecondPeak) {
  const std::vector<double> candidates = {-3, -2, -1, 0, 1, 2, 3}, brightness = {0, 50, 100, 100, 74.9, 75.1, 0};
  cv::RNG rng(5);
  auto scanWith = [&](double sigma) {
    return [&, sigma](const LightField& shown) {
      const bool lit = cv::countNonZero(shown.lensletImage()) > 0;
      cv::Mat noise(64, 64, CV_32FC1);
      rng.fill(noise, cv::RNG::NORMAL, 0, sigma);
      noise -= cv::mean(noise);  // the noise of a mean is sigma / 64, but each mean is exact
      const auto k = static_cast<size_t>(std::lround(shownEpsilon(shown) + 3));
      return cv::Mat(noise + (lit ? brightness[k] : 0.0));
    };
  };
  LightField shownLit(smallGeometry());
  shownLit.lensletImage().setTo(1);
  const auto scan = calib::calibrateDisplayDistance(shownLit, scanWith(32), candidates);
  EXPECT_NEAR(scan.noise, 0.5, 0.05);
  EXPECT_NEAR(scan.level, 75, 1e-4);
  EXPECT_NEAR(scan.estimate_mm, 0.5 * ((-2 + 0.5) + (0 + 25 / 25.1)), 1e-3);  // crossings at -1.5 and +0.996 mm
  EXPECT_TRUE(throwsError([&] { calib::calibrateDisplayDistance(shownLit, scanWith(0), candidates); },
                          Errc::InvalidArgument, {"two peaks", "75.1 again at +2 mm"}));
}

TEST(DisplayDistance, RejectsBadCandidatesAndImages) {
  const LightField lf(smallGeometry());
  auto black = [](const LightField&) { return cv::Mat(8, 8, CV_32FC1, cv::Scalar(0)); };
  EXPECT_TRUE(throwsError(
      [&] {
        calib::calibrateDisplayDistance(lf, black, {0, 1});
      },
      Errc::InvalidArgument, {"at least 3"}));
  EXPECT_TRUE(throwsError(
      [&] {
        calib::calibrateDisplayDistance(lf, black, {0, 2, 1});
      },
      Errc::InvalidArgument, {"increasing"}));
  EXPECT_TRUE(throwsError(
      [&] {
        calib::calibrateDisplayDistance(lf, [](const LightField&) { return cv::Mat(); }, {0, 1, 2});
      },
      Errc::Device, {"no image"}));
  EXPECT_TRUE(throwsError(
      [&] {
        calib::calibrateDisplayDistance(lf, black, {0, 1, 2}, cv::Mat::ones(4, 4, CV_8UC1));
      },
      Errc::InvalidArgument, {"ROI"}));
  EXPECT_TRUE(throwsError(
      [&] {
        calib::calibrateDisplayDistance(lf, black, {0, 1, 2}, cv::Mat::zeros(8, 8, CV_8UC1));
      },
      Errc::InvalidArgument, {"ROI", "non-zero"}));
  EXPECT_TRUE(throwsError(
      [&] {
        calib::calibrateDisplayDistance(lf, black, {0, 1, 2}, cv::Mat::ones(8, 8, CV_32FC1));
      },
      Errc::InvalidArgument, {"CV_8UC1"}));
  EXPECT_TRUE(throwsError(
      [&] {
        calib::calibrateDisplayDistance(lf, black, {0, NAN, 2});
      },
      Errc::InvalidArgument, {"finite"}));
  // A camera whose region changes during the scan, with or without a ROI.
  auto smallerWhenLit = [](const LightField& shown) {
    const int side = shownEpsilon(shown) == 0 ? 8 : 4;
    return cv::Mat(side, side, CV_32FC1, cv::Scalar(0));
  };
  EXPECT_TRUE(throwsError(
      [&] {
        calib::calibrateDisplayDistance(lf, smallerWhenLit, {-1, 1, 2});
      },
      Errc::Device, {"candidate -1 mm is 4x4", "the first one (with the display dark) 8x8"}));
  EXPECT_TRUE(throwsError(
      [&] {
        calib::calibrateDisplayDistance(lf, smallerWhenLit, {-1, 1, 2}, cv::Mat::ones(8, 8, CV_8UC1));
      },
      Errc::Device, {"candidate -1 mm is 4x4", "region or binning change"}));
  // The light field was captured 30 mm from the part: the display cannot be 30 mm nearer.
  EXPECT_TRUE(throwsError(
      [&] {
        calib::calibrateDisplayDistance(lf, black, {-30, 0, 1});
      },
      Errc::InvalidArgument, {"-30 mm", "past the part"}));
  EXPECT_TRUE(throwsError([&] { calib::propagateLightField(lf, 31); }, Errc::InvalidArgument, {"pass it"}));
  // A dark (or saturated) image at every candidate has no maximum: not an answer.
  EXPECT_TRUE(throwsError(
      [&] {
        calib::calibrateDisplayDistance(lf, black, {0, 1, 2});
      },
      Errc::Device, {"hardly changes", "+1 mm: 0"}));
  auto nan = [](const LightField&) { return cv::Mat(8, 8, CV_32FC1, cv::Scalar(NAN)); };
  EXPECT_TRUE(throwsError(
      [&] {
        calib::calibrateDisplayDistance(lf, nan, {0, 1, 2});
      },
      Errc::Device, {"non-finite", "with the display dark"}));
  // A reference that does not say how far from the part it was captured.
  LightFieldGeometry unset = smallGeometry();
  unset.distance_mm = 0;
  EXPECT_TRUE(throwsError(
      [&] {
        calib::calibrateDisplayDistance(LightField(unset), black, {0, 1, 2});
      },
      Errc::InvalidArgument, {"distance_mm", "not set"}));
  // A camera that fails mid-scan: its error, its code, the candidate and what the scan had so far.
  auto stallsAtOne = [](const LightField& shown) {
    if (shownEpsilon(shown) == 1) lfi::fail(Errc::Timeout, "camera 'x': no frame");
    return cv::Mat(8, 8, CV_32FC1, cv::Scalar(10 - std::abs(shownEpsilon(shown))));
  };
  EXPECT_TRUE(throwsError(
      [&] {
        calib::calibrateDisplayDistance(lf, stallsAtOne, {-1, 0, 1, 2});
      },
      Errc::Timeout, {"candidate +1 mm", "camera 'x': no frame", "-1 mm: 9", "+0 mm: 10"}));
}

// The noise where the signal is: a camera's shot noise grows with the light,
// which two dark images cannot show. A rise of 120 times the dark images' noise
// of a mean, but only 4 times the noise at the part's brightness, is refused;
// the same rise with the noise as small in the light as in the dark is not.
TEST(DisplayDistance, TheNoiseIsMeasuredWhereTheSignalIs) {
  LightField lf(smallGeometry());
  lf.lensletImage().setTo(1);  // shown fields are not dark; the dark one is all zeros
  cv::RNG rng(3);
  auto camera = [&](double litSigma) {
    return [&, litSigma](const LightField& shown) {
      const bool lit = cv::countNonZero(shown.lensletImage()) > 0;
      cv::Mat image(32, 32, CV_32FC1);  // 1024 pixels: a mean's noise is sigma / 32
      rng.fill(image, cv::RNG::NORMAL, 0, lit ? litSigma : 0.32);
      return cv::Mat(image + (lit ? 100 + 0.4 * (3 - std::abs(shownEpsilon(shown))) : 5.0));  // a rise of 1.2
    };
  };
  const std::vector<double> candidates = {-3, -2, -1, 0, 1, 2, 3};
  EXPECT_TRUE(throwsError([&] { calib::calibrateDisplayDistance(lf, camera(9.6), candidates); }, Errc::Device,
                          {"hardly changes"}));
  const auto scan = calib::calibrateDisplayDistance(lf, camera(0.32), candidates);
  EXPECT_NEAR(scan.noise, 0.01, 0.002);
  EXPECT_NEAR(scan.estimate_mm, 0, 0.1);
}

// Light that drifts during the scan tilts the peak: the brightest candidate,
// measured again at the end, must agree with itself.
TEST(DisplayDistance, DriftDuringTheScanIsRefused) {
  LightField lf(smallGeometry());
  lf.lensletImage().setTo(1);
  int shows = 0;
  auto drifting = [&](const LightField& shown) {
    const bool lit = cv::countNonZero(shown.lensletImage()) > 0;
    const double value = lit ? 100 - 10 * std::abs(shownEpsilon(shown)) + 0.5 * shows : 0.0;
    ++shows;
    cv::Mat image(16, 16, CV_32FC1);
    cv::RNG(shows).fill(image, cv::RNG::NORMAL, value, 0.16);  // a mean's noise 0.01
    return image;
  };
  EXPECT_TRUE(throwsError(
      [&] {
        calib::calibrateDisplayDistance(lf, drifting, {-3, -2, -1, 0, 1, 2, 3});
      },
      Errc::Device, {"candidate +0 mm", "after the scan", "drifting"}));
}

// A display that shows nothing (or a camera that sees nothing of it) gives a
// "peak" of noise: the scan refuses it, judging the noise of a mean from the
// dark image's spread. The same noise on a real peak does not stop it.
TEST(DisplayDistance, APeakOfNoiseIsNotAnAnswer) {
  LightField lf(smallGeometry());
  lf.lensletImage().setTo(1);  // shown fields are not dark; the dark one is all zeros
  cv::RNG rng(7);
  auto noisy = [&](double level) {
    cv::Mat image(32, 32, CV_32FC1);  // 1024 pixels of noise 2: a mean's noise is 2 / 32 = 0.0625
    rng.fill(image, cv::RNG::NORMAL, level, 2.0);
    return image;
  };
  auto dark = [&](const LightField&) { return noisy(10); };
  EXPECT_TRUE(throwsError(
      [&] {
        calib::calibrateDisplayDistance(lf, dark, {-3, -2, -1, 0, 1, 2, 3});
      },
      Errc::Device, {"hardly changes", "the noise of a mean about 0.06"}));
  auto peak = [&](const LightField& shown) {
    const bool lit = cv::countNonZero(shown.lensletImage()) > 0;
    return noisy(10 + (lit ? 20 - 5 * std::abs(shownEpsilon(shown) - 0.5) : 0));
  };
  EXPECT_NEAR(calib::calibrateDisplayDistance(lf, peak, {-3, -2, -1, 0, 1, 2, 3}).estimate_mm, 0.5, 0.05);
  // Identical dark images (no frame-to-frame noise at all): the caller's floor is the noise. A noise-free rise of
  // 20 over 16 pixels is significant unless a pixel's noise is 8 or more.
  auto tent = [](const LightField& shown) {
    return cv::Mat(4, 4, CV_32FC1, cv::Scalar(100 - 10 * std::abs(shownEpsilon(shown) - 0.3)));
  };
  const std::vector<double> candidates = {-2, -1, 0, 1, 2};
  const auto scan = calib::calibrateDisplayDistance(lf, tent, candidates, {}, 7.9);
  EXPECT_NEAR(scan.noise, 7.9 / 4, 1e-12);
  EXPECT_TRUE(throwsError([&] { calib::calibrateDisplayDistance(lf, tent, candidates, {}, 8.1); }, Errc::Device,
                          {"hardly changes", "noise of a mean about 2"}));
  EXPECT_TRUE(throwsError([&] { calib::calibrateDisplayDistance(lf, tent, candidates, {}, -1); }, Errc::InvalidArgument,
                          {"noise floor -1"}));
}

}  // namespace
