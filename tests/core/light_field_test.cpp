// SPDX-License-Identifier: Apache-2.0
#include "lfi/core/light_field.h"

#include "lfi/core/error.h"

#include "lfi_test_support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <vector>

namespace {

using lfi::Errc;
using lfi::LightField;
using lfi::LightFieldGeometry;
using lfi::LightFieldLookup;
using lfi::Vec2;
using lfi::Vec3;

using lfi::testing_support::throwsError;

// An odd n puts the element centre (straight up) in the middle of an angular pixel.
LightFieldGeometry smallGeometry(int angular = 7) {
  LightFieldGeometry g;
  g.spatialX = 4;
  g.spatialY = 3;
  g.angular = angular;
  g.pixelPitch_mm = 0.05;
  g.distance_mm = 12.5;
  return g;
}

// Every (ex, ey, u, v) gets its own value, so a lookup result identifies the sample.
float codeOf(int ex, int ey, int u, int v) {
  return static_cast<float>(((ex * 10 + ey) * 100 + u) * 100 + v);
}

LightField codedLightField(const LightFieldGeometry& g) {
  LightField lf(g);
  for (int ey = 0; ey < g.spatialY; ++ey)
    for (int ex = 0; ex < g.spatialX; ++ex)
      for (int v = 0; v < g.angular; ++v)
        for (int u = 0; u < g.angular; ++u) lf.at(ex, ey, u, v) = codeOf(ex, ey, u, v);
  return lf;
}

LightField randomLightField(const LightFieldGeometry& g, unsigned seed) {
  LightField lf(g);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> uni(0.f, 1.f);
  for (int r = 0; r < g.height(); ++r)
    for (int c = 0; c < g.width(); ++c) lf.lensletImage().at<float>(r, c) = uni(rng);
  return lf;
}

bool insideDisc(const Vec2& p) {
  return p.x * p.x + p.y * p.y < 1;
}

TEST(LightFieldGeometry, DerivedSizes) {
  const LightFieldGeometry g = smallGeometry();
  EXPECT_DOUBLE_EQ(g.elementPitch_mm(), 7 * 0.05);
  EXPECT_EQ(g.width(), 28);
  EXPECT_EQ(g.height(), 21);
  EXPECT_DOUBLE_EQ(g.extentX_mm(), 4 * 7 * 0.05);
  EXPECT_DOUBLE_EQ(g.extentY_mm(), 3 * 7 * 0.05);
  const LightField lf(g);
  EXPECT_EQ(lf.lensletImage().cols, 28);
  EXPECT_EQ(lf.lensletImage().rows, 21);
  EXPECT_EQ(lf.lensletImage().type(), CV_32FC1);
}

TEST(LightField, LensletLayoutIsElementTimesNPlusAngularIndex) {
  const LightFieldGeometry g = smallGeometry();
  const LightField lf = codedLightField(g);
  // pixel (col, row) = (ex n + u, ey n + v)
  EXPECT_EQ(lf.lensletImage().at<float>(2 * 7 + 5, 3 * 7 + 1), codeOf(3, 2, 1, 5));
  EXPECT_EQ(lf.lensletImage().at<float>(0 * 7 + 6, 1 * 7 + 0), codeOf(1, 0, 0, 6));
}

TEST(LightField, ElementAndAngularCentres) {
  const LightFieldGeometry g = smallGeometry();
  const LightField lf(g);
  const double e = g.elementPitch_mm();
  // The plane origin is the centre of the grid: element 0 starts at -Sx/2 e.
  EXPECT_NEAR(lf.elementCentre(0, 0).x, -2 * e + 0.5 * e, 1e-12);
  EXPECT_NEAR(lf.elementCentre(0, 0).y, -1.5 * e + 0.5 * e, 1e-12);
  EXPECT_NEAR(lf.elementCentre(3, 2).x, 1.5 * e, 1e-12);
  EXPECT_NEAR(lf.elementCentre(3, 2).y, 1.0 * e, 1e-12);
  // Angular pixel centres split [-1, 1] into n equal cells.
  EXPECT_NEAR(lf.angularCentre(0, 6).x, -1 + 1.0 / 7, 1e-12);
  EXPECT_NEAR(lf.angularCentre(0, 6).y, 1 - 1.0 / 7, 1e-12);
  EXPECT_NEAR(lf.angularCentre(3, 3).x, 0, 1e-12);
  EXPECT_NEAR(lf.angularCentre(3, 3).y, 0, 1e-12);
}

TEST(LightField, DirectionFromDiscPointsAwayFromHemispherePoint) {
  for (const Vec2& p : {Vec2(0, 0), Vec2(0.5, 0), Vec2(0, -0.3), Vec2(0.6, 0.7), Vec2(-0.2, 0.9)}) {
    const Vec3 d = LightField::directionFromDisc(p);
    // Hemisphere point below the plane; the ray of sight points from it through the origin.
    const Vec3 below{p.x, p.y, -std::sqrt(1 - p.x * p.x - p.y * p.y)};
    EXPECT_NEAR(d.length(), 1, 1e-12);
    EXPECT_GT(d.z, 0);
    EXPECT_NEAR((d + below).length(), 0, 1e-12) << "p = (" << p.x << ", " << p.y << ")";
  }
}

TEST(LightField, DiscFromDirectionInvertsDirectionFromDisc) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> uni(-1, 1);
  int tested = 0;
  while (tested < 1000) {
    const Vec2 p{uni(rng), uni(rng)};
    if (!insideDisc(p)) continue;
    ++tested;
    Vec2 back{99, 99};
    ASSERT_TRUE(LightField::discFromDirection(LightField::directionFromDisc(p), back));
    EXPECT_NEAR(back.x, p.x, 1e-12);
    EXPECT_NEAR(back.y, p.y, 1e-12);
  }
  // The other way round, for directions that are not unit length (the mapping normalises).
  for (const Vec3& d : {Vec3(0.3, -0.2, 2.0), Vec3(-5, 4, 1), Vec3(0, 0, 0.01)}) {
    Vec2 p;
    ASSERT_TRUE(LightField::discFromDirection(d, p));
    const Vec3 unit = d.normalized();
    EXPECT_NEAR(p.x, -unit.x, 1e-12);
    EXPECT_NEAR(p.y, -unit.y, 1e-12);
    const Vec3 again = LightField::directionFromDisc(p);
    EXPECT_NEAR((again - unit).length(), 0, 1e-9);
  }
}

TEST(LightField, DiscFromDirectionRejectsDirectionsAwayFromPlane) {
  Vec2 p;
  EXPECT_FALSE(LightField::discFromDirection({0, 0, -1}, p));
  EXPECT_FALSE(LightField::discFromDirection({0.5, 0.5, -0.1}, p));
  EXPECT_FALSE(LightField::discFromDirection({1, 0, 0}, p));
  EXPECT_FALSE(LightField::discFromDirection({0, 0, 0}, p));
  EXPECT_TRUE(LightField::discFromDirection({1, 0, 1e-9}, p));
}

TEST(LightField, NearestLookupFindsAngularPixelOfDirection) {
  const LightFieldGeometry g = smallGeometry();
  const LightField lf = codedLightField(g);
  const double e = g.elementPitch_mm();
  int checked = 0;
  for (int ey = 0; ey < g.spatialY; ++ey)
    for (int ex = 0; ex < g.spatialX; ++ex)
      for (int v = 0; v < g.angular; ++v)
        for (int u = 0; u < g.angular; ++u) {
          const Vec2 disc = lf.angularCentre(u, v);
          if (!insideDisc(disc)) continue;
          const Vec3 d = LightField::directionFromDisc(disc);
          // Anywhere inside the element, not only at its centre.
          for (const Vec2& offset : {Vec2(0, 0), Vec2(0.4 * e, -0.3 * e), Vec2(-0.45 * e, 0.45 * e)}) {
            const Vec2 q = lf.elementCentre(ex, ey) + offset;
            ASSERT_EQ(lf.radiance(q, d, LightFieldLookup::Nearest), codeOf(ex, ey, u, v))
                << "element (" << ex << ", " << ey << "), angular (" << u << ", " << v << ")";
          }
          ++checked;
        }
  // The centre pixels of a 7x7 element inside the unit disc: 37 of 49 (the corners fall outside).
  EXPECT_EQ(checked, g.spatialX * g.spatialY * 37);
}

TEST(LightField, RayTiltedTowardsPlusXLandsAtNegativePx) {
  const LightFieldGeometry g = smallGeometry(7);
  const LightField lf = codedLightField(g);
  const Vec2 q = lf.elementCentre(1, 1);
  // Straight up: the middle pixel (3, 3).
  EXPECT_EQ(lf.radiance(q, {0, 0, 1}, LightFieldLookup::Nearest), codeOf(1, 1, 3, 3));
  // Tilted towards +x by asin(0.6): px = -0.6 lies in pixel floor((1 - 0.6) / 2 * 7) = 1, left of the centre.
  const double s = 0.6, c = std::sqrt(1 - s * s);
  EXPECT_EQ(lf.radiance(q, {s, 0, c}, LightFieldLookup::Nearest), codeOf(1, 1, 1, 3));
  // Tilted towards -x: px = +0.6, pixel floor(1.6 / 2 * 7) = 5, right of the centre.
  EXPECT_EQ(lf.radiance(q, {-s, 0, c}, LightFieldLookup::Nearest), codeOf(1, 1, 5, 3));
  // Same along y: towards +y lands at py < 0, i.e. v (the row offset) < n/2.
  EXPECT_EQ(lf.radiance(q, {0, s, c}, LightFieldLookup::Nearest), codeOf(1, 1, 3, 1));
  EXPECT_EQ(lf.radiance(q, {0, -s, c}, LightFieldLookup::Nearest), codeOf(1, 1, 3, 5));
  // An even n: the sign convention in terms of u < n/2 still holds.
  const LightField even = codedLightField(smallGeometry(8));
  for (double tilt : {0.05, 0.3, 0.9}) {
    const double t = std::sqrt(1 - tilt * tilt);
    const float towardsPlusX =
        static_cast<float>(even.radiance(even.elementCentre(0, 0), {tilt, 0.01, t}, LightFieldLookup::Nearest));
    const int u = static_cast<int>(std::lround(towardsPlusX)) / 100 % 100;
    EXPECT_LT(u, 4) << "tilt " << tilt;
  }
}

TEST(LightField, InterpolatedLookupIsExactAtElementAndAngularCentres) {
  const LightFieldGeometry g = smallGeometry(5);
  const LightField lf = randomLightField(g, 42);
  for (int ey = 0; ey < g.spatialY; ++ey)
    for (int ex = 0; ex < g.spatialX; ++ex)
      for (int v = 0; v < g.angular; ++v)
        for (int u = 0; u < g.angular; ++u) {
          const Vec2 disc = lf.angularCentre(u, v);
          if (!insideDisc(disc)) continue;
          const Vec3 d = LightField::directionFromDisc(disc);
          const Vec2 q = lf.elementCentre(ex, ey);
          EXPECT_NEAR(lf.radiance(q, d, LightFieldLookup::Interpolated), lf.at(ex, ey, u, v), 1e-9);
          EXPECT_NEAR(lf.radiance(q, d, LightFieldLookup::Nearest), lf.at(ex, ey, u, v), 0);
        }
}

TEST(LightField, InterpolatedLookupIsBilinearBetweenCentres) {
  const LightFieldGeometry g = smallGeometry(5);
  const LightField lf = randomLightField(g, 3);
  // Between two elements along x at an angular centre: the two elements' values mix linearly.
  const Vec2 a = lf.elementCentre(1, 1), b = lf.elementCentre(2, 1);
  const Vec3 d = LightField::directionFromDisc(lf.angularCentre(2, 1));
  for (double t : {0.0, 0.25, 0.5, 0.8, 1.0}) {
    const double expected = (1 - t) * lf.at(1, 1, 2, 1) + t * lf.at(2, 1, 2, 1);
    EXPECT_NEAR(lf.radiance(a + (b - a) * t, d, LightFieldLookup::Interpolated), expected, 1e-9) << "t = " << t;
  }
  // Between two angular pixels along y at an element centre: only that element contributes.
  const Vec2 p0 = lf.angularCentre(2, 1), p1 = lf.angularCentre(2, 2);
  for (double t : {0.0, 0.3, 0.5, 1.0}) {
    const double expected = (1 - t) * lf.at(2, 0, 2, 1) + t * lf.at(2, 0, 2, 2);
    const Vec3 dt = LightField::directionFromDisc(p0 + (p1 - p0) * t);
    EXPECT_NEAR(lf.radiance(lf.elementCentre(2, 0), dt, LightFieldLookup::Interpolated), expected, 1e-9);
  }
}

// Samples a straight path in (position, disc) space that crosses several element
// boundaries and angular pixel boundaries; returns the largest jump between
// neighbouring samples.
double maxJumpAlongPath(const LightField& lf, LightFieldLookup mode, const Vec2& q0, const Vec2& q1, const Vec2& p0,
                        const Vec2& p1, int steps) {
  double maxJump = 0;
  double previous = 0;
  for (int i = 0; i <= steps; ++i) {
    const double t = static_cast<double>(i) / steps;
    const Vec2 disc = p0 + (p1 - p0) * t;
    const double value = lf.radiance(q0 + (q1 - q0) * t, LightField::directionFromDisc(disc), mode);
    if (i > 0) maxJump = std::max(maxJump, std::abs(value - previous));
    previous = value;
  }
  return maxJump;
}

TEST(LightField, InterpolatedLookupIsContinuousNearestIsNot) {
  const LightFieldGeometry g = smallGeometry(6);
  const LightField lf = randomLightField(g, 11);
  // Largest difference between neighbouring samples along any of the four axes.
  double maxAdjacent = 0;
  for (int ey = 0; ey < g.spatialY; ++ey)
    for (int ex = 0; ex < g.spatialX; ++ex)
      for (int v = 0; v < g.angular; ++v)
        for (int u = 0; u < g.angular; ++u) {
          const double x = lf.at(ex, ey, u, v);
          if (u + 1 < g.angular) maxAdjacent = std::max(maxAdjacent, std::abs(lf.at(ex, ey, u + 1, v) - x));
          if (v + 1 < g.angular) maxAdjacent = std::max(maxAdjacent, std::abs(lf.at(ex, ey, u, v + 1) - x));
          if (ex + 1 < g.spatialX) maxAdjacent = std::max(maxAdjacent, std::abs(lf.at(ex + 1, ey, u, v) - x));
          if (ey + 1 < g.spatialY) maxAdjacent = std::max(maxAdjacent, std::abs(lf.at(ex, ey + 1, u, v) - x));
        }
  // Across the whole grid in position, across most of the disc in angle (staying inside it).
  const double e = g.elementPitch_mm();
  const Vec2 q0{-1.95 * e, -1.4 * e}, q1{1.9 * e, 1.35 * e};
  const Vec2 p0{-0.7, -0.45}, p1{0.65, 0.55};
  const int steps = 20000;
  // The interpolated field is multilinear in (element coordinate, angular pixel coordinate),
  // so a step changes it by at most maxAdjacent times the L1 length of the step in cell units.
  const double stepCells = (std::abs(q1.x - q0.x) / e + std::abs(q1.y - q0.y) / e +
                            std::abs(p1.x - p0.x) * g.angular / 2 + std::abs(p1.y - p0.y) * g.angular / 2) /
                           steps;
  const double bound = maxAdjacent * stepCells * (1 + 1e-6) + 1e-12;
  const double interpolatedJump = maxJumpAlongPath(lf, LightFieldLookup::Interpolated, q0, q1, p0, p1, steps);
  EXPECT_LE(interpolatedJump, bound);
  EXPECT_GT(interpolatedJump, 0);  // it does vary along the path
  // Nearest lookup jumps at every boundary by a whole sample difference.
  const double nearestJump = maxJumpAlongPath(lf, LightFieldLookup::Nearest, q0, q1, p0, p1, steps);
  EXPECT_GT(nearestJump, 100 * bound);
  EXPECT_GT(nearestJump, 0.3);
}

TEST(LightField, DirectionsAwayFromPlaneGiveZero) {
  const LightFieldGeometry g = smallGeometry();
  LightField lf(g);
  lf.lensletImage().setTo(1.0f);
  const Vec2 q = lf.elementCentre(1, 1);
  for (auto mode : {LightFieldLookup::Nearest, LightFieldLookup::Interpolated}) {
    EXPECT_EQ(lf.radiance(q, {0, 0, 1}, mode), 1.0);  // control: the plane does emit
    EXPECT_EQ(lf.radiance(q, {0.1, 0.1, 0.99}, mode), 1.0);
    EXPECT_EQ(lf.radiance(q, {0, 0, -1}, mode), 0.0);
    EXPECT_EQ(lf.radiance(q, {0.3, -0.2, -0.5}, mode), 0.0);
    EXPECT_EQ(lf.radiance(q, {1, 0, 0}, mode), 0.0);
    EXPECT_EQ(lf.radiance(q, {0, -1, 0}, mode), 0.0);
  }
}

// Directions and disc positions that are not finite give 0 or the border's
// value, never a cast of NaN or infinity to an index (undefined; it read out
// of bounds). The sanitiser build checks the reads.
TEST(LightField, NonFiniteDirectionsGiveZeroAndNonFiniteDiscsStayInTheElement) {
  const LightFieldGeometry g = smallGeometry();
  const LightField lf = codedLightField(g);
  const double inf = std::numeric_limits<double>::infinity(), nan = std::numeric_limits<double>::quiet_NaN();
  Vec2 disc;
  for (const Vec3& d : {Vec3(inf, 0, 1), Vec3(0, -inf, 1), Vec3(0, 0, inf), Vec3(nan, 0, 1), Vec3(0, 0, nan)}) {
    EXPECT_FALSE(LightField::discFromDirection(d, disc)) << d;
    for (const auto mode : {LightFieldLookup::Nearest, LightFieldLookup::Interpolated})
      EXPECT_EQ(lf.radiance({0, 0}, d, mode), 0.0) << d;
  }
  for (const Vec2& bad : {Vec2(nan, 0), Vec2(0, nan), Vec2(1e300, -1e300), Vec2(-inf, inf)})
    for (const auto mode : {LightFieldLookup::Nearest, LightFieldLookup::Interpolated}) {
      // Element (1, 1)'s codes (and so any blend of them) lie in [codeOf(1, 1, 0, 0), codeOf(1, 1, n-1, n-1)].
      const double v = lf.radianceAt(1.5, 1.5, bad, mode);
      EXPECT_GE(v, codeOf(1, 1, 0, 0)) << bad;
      EXPECT_LE(v, codeOf(1, 1, g.angular - 1, g.angular - 1)) << bad;
    }
}

TEST(LightField, PositionsOutsidePlaneGiveZero) {
  const LightFieldGeometry g = smallGeometry();
  LightField lf(g);
  lf.lensletImage().setTo(1.0f);
  const double hx = 0.5 * g.extentX_mm(), hy = 0.5 * g.extentY_mm(), eps = 1e-6;
  const Vec3 up{0, 0, 1};
  for (auto mode : {LightFieldLookup::Nearest, LightFieldLookup::Interpolated}) {
    // Just inside each edge: emits.
    for (const Vec2& q : {Vec2(hx - eps, 0), Vec2(-hx + eps, 0), Vec2(0, hy - eps), Vec2(0, -hy + eps)})
      EXPECT_EQ(lf.radiance(q, up, mode), 1.0) << q.x << ", " << q.y;
    // Just outside each edge and far away: nothing.
    for (const Vec2& q : {Vec2(hx + eps, 0), Vec2(-hx - eps, 0), Vec2(0, hy + eps), Vec2(0, -hy - eps),
                          Vec2(100 * hx, 100 * hy), Vec2(std::numeric_limits<double>::quiet_NaN(), 0)})
      EXPECT_EQ(lf.radiance(q, up, mode), 0.0) << q.x << ", " << q.y;
  }
  // An empty (default-constructed) light field emits nothing.
  EXPECT_EQ(LightField().radiance({0, 0}, up, LightFieldLookup::Interpolated), 0.0);
}

TEST(LightField, ConstructorRejectsMismatchedLensletImage) {
  const LightFieldGeometry g = smallGeometry();
  EXPECT_NO_THROW((void)LightField(g, cv::Mat(g.height(), g.width(), CV_32FC1, cv::Scalar(0))));
  EXPECT_TRUE(throwsError([&] { (void)LightField(g, cv::Mat(g.height(), g.width() + 1, CV_32FC1)); },
                          Errc::InvalidArgument, {"29x21", "28x21"}));
  EXPECT_TRUE(throwsError([&] { (void)LightField(g, cv::Mat(g.height() - 7, g.width(), CV_32FC1)); },
                          Errc::InvalidArgument, {"28x14", "28x21"}));
  // Transposed: right pixel count, wrong shape.
  EXPECT_TRUE(throwsError([&] { (void)LightField(g, cv::Mat(g.width(), g.height(), CV_32FC1)); }, Errc::InvalidArgument,
                          {"21x28"}));
  EXPECT_TRUE(throwsError([&] { (void)LightField(g, cv::Mat(g.height(), g.width(), CV_64FC1)); }, Errc::InvalidArgument,
                          {"CV_32FC1"}));
  EXPECT_TRUE(throwsError([&] { (void)LightField(g, cv::Mat(g.height(), g.width(), CV_32FC3)); }, Errc::InvalidArgument,
                          {"CV_32FC1"}));
  EXPECT_TRUE(throwsError([&] { (void)LightField(g, cv::Mat()); }, Errc::InvalidArgument, {"lenslet image"}));
  // A radiance that is not finite, named by its pixel.
  for (const float bad : {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity()}) {
    cv::Mat image(g.height(), g.width(), CV_32FC1, cv::Scalar(1));
    image.at<float>(5, 9) = bad;
    EXPECT_TRUE(throwsError([&] { (void)LightField(g, image); }, Errc::InvalidArgument, {"(9, 5)", "finite"}));
  }
}

TEST(LightFieldGeometry, ValidateNamesTheBadField) {
  EXPECT_NO_THROW(smallGeometry().validate());
  struct Case {
    std::function<void(LightFieldGeometry&)> spoil;
    std::string field;
  };
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  const std::vector<Case> cases = {
      {[](LightFieldGeometry& g) { g.spatialX = 0; }, "spatialX"},
      {[](LightFieldGeometry& g) { g.spatialX = -3; }, "spatialX"},
      {[](LightFieldGeometry& g) { g.spatialY = 0; }, "spatialY"},
      {[](LightFieldGeometry& g) { g.spatialY = 1 << 20; }, "spatialY"},
      {[](LightFieldGeometry& g) { g.angular = 0; }, "angular"},
      {[](LightFieldGeometry& g) { g.angular = 5000; }, "angular"},
      {[](LightFieldGeometry& g) { g.pixelPitch_mm = 0; }, "pixelPitch_mm"},
      {[](LightFieldGeometry& g) { g.pixelPitch_mm = -0.01; }, "pixelPitch_mm"},
      {[nan](LightFieldGeometry& g) { g.pixelPitch_mm = nan; }, "pixelPitch_mm"},
      {[inf](LightFieldGeometry& g) { g.pixelPitch_mm = inf; }, "pixelPitch_mm"},
      {[](LightFieldGeometry& g) { g.distance_mm = -1; }, "distance_mm"},
      {[nan](LightFieldGeometry& g) { g.distance_mm = nan; }, "distance_mm"},
      {[inf](LightFieldGeometry& g) { g.distance_mm = inf; }, "distance_mm"},
  };
  for (const Case& c : cases) {
    LightFieldGeometry g = smallGeometry();
    c.spoil(g);
    EXPECT_TRUE(throwsError([&] { g.validate(); }, Errc::InvalidArgument, {c.field})) << c.field;
    // The constructors validate too.
    EXPECT_TRUE(throwsError([&] { (void)LightField(g); }, Errc::InvalidArgument, {c.field})) << c.field;
  }
  // Each field alone in range but the lenslet image too large.
  LightFieldGeometry huge = smallGeometry();
  huge.spatialX = 1 << 15;
  huge.angular = 1024;
  EXPECT_TRUE(throwsError([&] { huge.validate(); }, Errc::InvalidArgument, {"too large"}));
  // Each side in range but more than 2^30 pixels in all; exactly 2^30 is allowed.
  huge.spatialX = huge.spatialY = 1 << 15;
  huge.angular = 2;
  EXPECT_TRUE(throwsError([&] { huge.validate(); }, Errc::InvalidArgument, {"65536x65536", "2^30 pixels"}));
  huge.spatialX = huge.spatialY = 1 << 14;
  EXPECT_NO_THROW(huge.validate());
}

}  // namespace

TEST(BinaryDrive, LightsEveryPixelAtOrAboveTheThresholdOfTheBrightest) {
  const LightFieldGeometry g = smallGeometry();
  LightField captured(g);
  captured.at(0, 0, 3, 3) = 2.f;      // the brightest
  captured.at(1, 2, 0, 6) = 0.5f;     // exactly a quarter of it: lit
  captured.at(2, 1, 5, 1) = 0.4999f;  // just below: dark
  captured.at(3, 0, 2, 2) = 1.f;
  const LightField drive = lfi::binaryDrive(captured, 0.25);
  EXPECT_EQ(drive.geometry(), g);
  EXPECT_EQ(drive.lensletImage().type(), CV_32FC1);
  EXPECT_EQ(drive.at(0, 0, 3, 3), 1.f);
  EXPECT_EQ(drive.at(1, 2, 0, 6), 1.f);
  EXPECT_EQ(drive.at(2, 1, 5, 1), 0.f);
  EXPECT_EQ(drive.at(3, 0, 2, 2), 1.f);
  EXPECT_EQ(cv::countNonZero(drive.lensletImage()), 3);
  EXPECT_EQ(cv::sum(drive.lensletImage())[0], 3.0);  // every lit pixel exactly 1
  // Threshold 1: the brightest alone.
  EXPECT_EQ(cv::countNonZero(lfi::binaryDrive(captured, 1).lensletImage()), 1);
}

TEST(BinaryDrive, RefusesAThresholdOutOfRangeAndALightFieldWithoutLight) {
  LightField captured(smallGeometry());
  EXPECT_TRUE(throwsError([&] { (void)lfi::binaryDrive(captured, 0.01); }, Errc::InvalidArgument, {"no light"}));
  captured.at(0, 0, 0, 0) = 1;
  for (const double bad : {0.0, -0.1, 1.5, std::numeric_limits<double>::quiet_NaN()})
    EXPECT_TRUE(throwsError([&] { (void)lfi::binaryDrive(captured, bad); }, Errc::InvalidArgument, {"(0, 1]"})) << bad;
}
