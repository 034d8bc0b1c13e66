// SPDX-License-Identifier: Apache-2.0
// The path tracer against analytic radiometry and geometry: a flat slab's
// transmission with incoherent multiple reflections and Beer-Lambert absorption,
// nested dielectrics, the bright disc of a lens under parallel illumination, meshes far out.
#include "lfi/core/error.h"
#include "lfi/sim/render.h"
#include "lfi/sim/scene.h"
#include "lfi/sim/sensors.h"

#include "lfi_test_support.h"
#include "render_fixture.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

namespace {

using namespace lfi;
using namespace lfi::sim;
using lfi::testing_support::cameraAbove;
using lfi::testing_support::emitterBelow;
using lfi::testing_support::throwsError;

// Thick-lens focal length (lensmaker): 1/f = (n-1) [1/R1 - 1/R2 + (n-1) d / (n R1 R2)].
double lensmakerFocalLength(double r1, double r2, double d, double n) {
  return 1 / ((n - 1) * (1 / r1 - 1 / r2 + (n - 1) * d / (n * r1 * r2)));
}

// ---- Slab transmission --------------------------------------------------
//
// Camera above (looking down -z), a flat non-absorbing slab, a one-sided
// Lambertian emitter (radiance 1, normal +z) below. A camera ray at (near)
// normal incidence: reflected at the top face it goes up and escapes (no
// source there: 0). Transmitted (1-R), it reaches the bottom face: (1-R) again
// to the emitter, which it hits on its lit side (radiance 1); R back up to the
// top face, where (1-R) escapes upwards (0) and R goes down again, and so on.
// Each extra round trip multiplies by R^2, and with absorption by tau^2, where
// tau = exp(-a d) is the single-pass Beer-Lambert factor:
//   L = (1-R)^2 tau sum_k (R^2 tau^2)^k = (1-R)^2 tau / (1 - R^2 tau^2),
// which for tau = 1 is (1-R)^2 / (1-R^2) = (1-R) / (1+R). R = ((n-1)/(n+1))^2.
// With splitDepth = 8 the first eight interfaces are split deterministically;
// what is left is sampled with weight < (1-R)^2 R^8 ~ 1e-11, and the acceptance
// cone (0.01 rad) changes R and the path length by < 1e-5: tolerance 2e-5.
double slabRadiance(const Shape& slab, double n, double absorption, bool emitterFacingUp, double* minOut = nullptr) {
  std::vector<Object> objects;
  objects.push_back(emitterBelow(0, LambertianEmission{1.0}, emitterFacingUp));
  objects.push_back({.name = "slab",
                     .shape = slab,
                     .worldFromObject = Rigid3::translation({0, 0, 20}),
                     .material = Dielectric{n, absorption}});
  const Scene scene(std::move(objects));
  const TelecentricCamera cam = cameraAbove(20, 16, 2.0, 0.01);
  RenderOptions opt;
  opt.samplesPerPixel = 4;
  opt.splitDepth = 8;
  opt.threads = 2;
  const cv::Mat image = render(scene, cam, opt);
  double lo, hi;
  cv::minMaxLoc(image, &lo, &hi);
  if (minOut) *minOut = lo;
  EXPECT_LT(hi - lo, 2e-5);  // a uniform slab gives a uniform image
  return cv::mean(image)[0];
}

TEST(SlabTransmission, NonAbsorbingSlabTransmitsOneMinusROverOnePlusR) {
  for (double n : {1.5, 1.8}) {
    const double r = std::pow((n - 1) / (n + 1), 2);
    const double expected = (1 - r) / (1 + r);
    const double measured = slabRadiance(Solid::sphericalLens(0, 0, 5, 200), n, 0, true);
    RecordProperty(fmt::format("slab_n{}", n), fmt::format("{:.7f} vs {:.7f}", measured, expected));
    EXPECT_NEAR(measured, expected, 2e-5) << "n=" << n;
    // Distinguishable from the single-pass (1-R)^2 the multiple reflections add to.
    EXPECT_GT(measured - (1 - r) * (1 - r), 5e-4);
  }
}

TEST(SlabTransmission, AbsorbingSlabAddsTheBeerLambertFactor) {
  const double n = 1.5, a = 0.02, d = 5;
  const double r = std::pow((n - 1) / (n + 1), 2), tau = std::exp(-a * d);
  const double expected = (1 - r) * (1 - r) * tau / (1 - r * r * tau * tau);
  // The same slab built by hand from a cylinder and two half spaces.
  auto top = Solid::halfSpace(Rigid3::translation({0, 0, d / 2}));
  auto bottom = Solid::halfSpace(Rigid3::translation({0, 0, -d / 2}) * Rigid3::rotation({1, 0, 0}, std::numbers::pi));
  auto slab = Solid::combine(Solid::Kind::Intersection, Solid::cylinder(100),
                             Solid::combine(Solid::Kind::Intersection, top, bottom));
  const double measured = slabRadiance(slab, n, a, true);
  RecordProperty("absorbing_slab", fmt::format("{:.7f} vs {:.7f}", measured, expected));
  EXPECT_NEAR(measured, expected, 2e-5);
}

// The same absorbing slab as a triangle mesh (a 200 x 200 x 5 box): the
// packet renderer takes a mesh's interfaces one lane at a time (float
// intersections, paths stepped 1e-4 mm off the faces, which changes the
// Beer-Lambert path by < 1e-6 of the slab's thickness per pass).
TEST(SlabTransmission, MeshSlabTransmitsAsTheAnalyticSlab) {
  const double n = 1.5, a = 0.02, d = 5;
  const double r = std::pow((n - 1) / (n + 1), 2), tau = std::exp(-a * d);
  const double expected = (1 - r) * (1 - r) * tau / (1 - r * r * tau * tau);
  TriangleMesh box;
  for (const double z : {-d / 2, d / 2})
    for (const auto& [x, y] : {std::pair{-100.0, -100.0}, {100.0, -100.0}, {100.0, 100.0}, {-100.0, 100.0}})
      box.vertices.push_back({x, y, z});
  box.triangles = {{0, 2, 1}, {0, 3, 2}, {4, 5, 6}, {4, 6, 7}, {0, 1, 5}, {0, 5, 4},
                   {3, 7, 6}, {3, 6, 2}, {0, 4, 7}, {0, 7, 3}, {1, 2, 6}, {1, 6, 5}};  // outward
  const double measured = slabRadiance(box, n, a, true);
  RecordProperty("mesh_slab", fmt::format("{:.7f} vs {:.7f}", measured, expected));
  EXPECT_NEAR(measured, expected, 2e-5);
}

TEST(SlabTransmission, OneSidedEmitterSeenFromBehindIsDark) {
  // Turned over, the emitter's lit side faces away from the camera: nothing is seen.
  double lo = -1;
  EXPECT_EQ(slabRadiance(Solid::sphericalLens(0, 0, 5, 200), 1.5, 0, false, &lo), 0.0);
  EXPECT_EQ(lo, 0.0);
}

// ---- Nested dielectrics ---------------------------------------------------
//
// `count` slabs of one index n, slab k (1-based) 2k mm thick, all centred on
// z = 0: optically one slab 2 count mm thick, since the inner faces separate
// equal indices. An oblique ray refracts at the outer faces only (Snell, from
// 1 to n and back) and goes straight through the inner ones, which it does only
// if the tracer tracks every nesting level (a lost or misordered level bends it
// there).
constexpr int kNesting = 8;  // the documented limit (docs/scene-files.md)

Scene nestedSlabs(int count, double n) {
  std::vector<Object> objects;
  objects.push_back(emitterBelow(-30, LambertianEmission{1.0}));
  for (int k = 1; k <= count; ++k)
    objects.push_back({.name = fmt::format("slab {}", k),
                       .shape = Solid::sphericalLens(0, 0, 2 * k, 200),
                       .material = Dielectric{n, 0}});
  return Scene(std::move(objects));
}

TEST(NestedDielectrics, EightLevelsRefractAsTheOuterSlabAlone) {
  const int count = kNesting;
  const double n = 1.5, theta = 0.3, top = 50;
  const Vec3 d0(std::sin(theta), 0, -std::cos(theta));
  // refractionPath always refracts: the origin, 2 count crossings and the back light.
  const std::vector<Vec3> path = refractionPath(nestedSlabs(count, n), {{0, 0, top}, d0});
  ASSERT_EQ(path.size(), static_cast<size_t>(2 * count + 2));
  const double xEnter = (top - count) * std::tan(theta), tanT = std::tan(std::asin(std::sin(theta) / n));
  for (size_t i = 1; i + 1 < path.size(); ++i) {  // every crossing lies on the one refracted line
    const double z = path[i].z;
    EXPECT_NEAR(std::abs(z), static_cast<double>(i <= static_cast<size_t>(count) ? count + 1 - i : i - count), 1e-9);
    EXPECT_NEAR(path[i].x, xEnter + (count - z) * tanT, 1e-9) << "crossing " << i << " at z = " << z;
  }
  const Vec3 out = (path.back() - path[path.size() - 2]).normalized();
  EXPECT_NEAR((out - d0).length(), 0, 1e-12);  // leaves parallel to how it came
}

// Overlapping dielectrics: the one entered last is the medium. A path inside
// sphere B (n = 1.5) where it overlaps sphere A (n = 1.7) meets A's far surface
// with B on both sides: no interface, the ray goes straight on (not bent from
// 1.7 to 1.5). (The packet renderer takes its indices by the same rule, MediumStack::iorInside.)
TEST(NestedDielectrics, OverlapsTakeTheMediumEnteredLast) {
  std::vector<Object> objects;
  objects.push_back(emitterBelow(-30, LambertianEmission{1.0}));
  objects.push_back({.name = "A", .shape = Solid::sphere(10), .material = Dielectric{1.7, 0}});
  objects.push_back(
      {.name = "B", .shape = Solid::sphere(10, Rigid3::translation({0, 0, -12})), .material = Dielectric{1.5, 0}});
  const Scene scene(std::move(objects));
  // Down from above, off the axis: into A, into B (inside A), out of A (inside B), out of B, to the back light.
  const std::vector<Vec3> path = refractionPath(scene, {{3, 1, 40}, Vec3(0.05, 0.02, -1).normalized()});
  ASSERT_EQ(path.size(), 6u);
  EXPECT_NEAR(path[3].length(), 10, 1e-9);  // A's surface, inside B
  EXPECT_LT((path[3] - Vec3(0, 0, -12)).length(), 10);
  const Vec3 before = (path[3] - path[2]).normalized(), after = (path[4] - path[3]).normalized();
  EXPECT_NEAR((after - before).length(), 0, 1e-12);
}

TEST(NestedDielectrics, ANinthLevelIsAConfigErrorNamingTheObjects) {
  const Scene scene = nestedSlabs(kNesting + 1, 1.5);
  const std::vector<std::string> named{"slab 1", "slab 9", "at most 8"};
  EXPECT_TRUE(throwsError([&] { refractionPath(scene, {{0, 0, 50}, {0, 0, -1}}); }, Errc::Config, named));
  RenderOptions opt;
  opt.samplesPerPixel = 1;
  opt.threads = 2;
  EXPECT_TRUE(throwsError([&] { render(scene, cameraAbove(0, 4, 2.0, 0.01), opt); }, Errc::Config, named));
}

// ---- Parallel illumination of an intact lens ------------------------------
//
// Camera above looking down -z, focused on a converging lens (focal length f
// from the lensmaker equation), a ParallelEmission backlight (half-angle
// theta_e) below. A camera ray through the lens at height h with direction
// delta (|delta| <= theta_c, uniform over the acceptance disc: the stop is
// sampled uniformly) leaves the lens towards the backlight with direction
// delta - h/f (thin-lens deflection towards the axis). The backlight returns
// radiance iff |delta - h/f| < theta_e. So the lit fraction of a pixel at
// height h is the area of the disc |delta| <= theta_c, shifted by h/f, inside
// the circle of radius theta_e, over pi theta_c^2: 1 for h < f (theta_e -
// theta_c), 0 for h > f (theta_e + theta_c), and close to 1/2 (a little less:
// the circle is convex) at h = f theta_e. Away from the lens the camera sees
// the backlight directly, at angles <= theta_c < theta_e: radiance 1.
double litFraction(double shift, double thetaC, double thetaE) {
  const double d = shift, r = thetaC, big = thetaE;
  if (d <= big - r) return 1;
  if (d >= big + r) return 0;
  const double area = r * r * std::acos((d * d + r * r - big * big) / (2 * d * r)) +
                      big * big * std::acos((d * d + big * big - r * r) / (2 * d * big)) -
                      0.5 * std::sqrt((-d + r + big) * (d + r - big) * (d - r + big) * (d + r + big));
  return area / (std::numbers::pi * r * r);
}

TEST(ParallelIllumination, LensShowsABrightDiscOfRadiusFocalLengthTimesEmitterAngle) {
  const double r1 = 100, r2 = -100, tc = 7, n = 1.5, diameter = 12;
  const double thetaE = 0.02, thetaC = 0.01, field = 20;
  const int size = 96;
  const double f = lensmakerFocalLength(r1, r2, tc, n);
  std::vector<Object> objects;
  objects.push_back(emitterBelow(-60, ParallelEmission{1.0, thetaE}));
  objects.push_back({.name = "lens",
                     .shape = std::shared_ptr<const Solid>(Solid::sphericalLens(r1, r2, tc, diameter)),
                     .material = Dielectric{n, 0}});
  const Scene scene(std::move(objects));
  const TelecentricCamera cam = cameraAbove(0, size, field, thetaC);
  RenderOptions opt;
  opt.samplesPerPixel = 32;
  opt.splitDepth = 2;
  opt.threads = 2;
  const cv::Mat image = render(scene, cam, opt);

  const double pixel = field / size;
  auto radiusOf = [&](int i, int j) {
    return std::hypot((i + 0.5 - size / 2.0) * pixel, (j + 0.5 - size / 2.0) * pixel);
  };
  // The plateau: transmitted through two surfaces, about (1 - 0.04)^2.
  double plateau = 0;
  int plateauCount = 0;
  for (int j = 0; j < size; ++j)
    for (int i = 0; i < size; ++i)
      if (radiusOf(i, j) < 0.6) plateau += image.at<float>(j, i), ++plateauCount;
  plateau /= plateauCount;
  EXPECT_NEAR(plateau, 0.96 * 0.96, 0.01);

  // The 50 % radius: a least-squares line through the normalised edge profile
  // (pixels at 1.5 < r < 2.4 mm, where the profile is nearly straight), solved
  // for 1/2. The same fit of the model's lit fraction at the same pixel radii
  // gives the prediction, free of the small bias of fitting a line to a curve.
  double s[2][5] = {};  // per fit: n, sum r, sum v, sum r^2, sum r v
  for (int j = 0; j < size; ++j)
    for (int i = 0; i < size; ++i) {
      const double rr = radiusOf(i, j), v = image.at<float>(j, i);
      if (rr > 3.6 && rr < 5.5) {
        EXPECT_LT(v, 0.01) << "dark ring at r=" << rr;
      }
      if (rr > 7) {
        EXPECT_EQ(v, 1.0f) << "direct backlight at r=" << rr;
      }
      if (rr < 1.5 || rr > 2.4) continue;
      const double values[2] = {v / plateau, litFraction(rr / f, thetaC, thetaE)};
      for (int k = 0; k < 2; ++k) {
        s[k][0] += 1, s[k][1] += rr, s[k][2] += values[k], s[k][3] += rr * rr, s[k][4] += rr * values[k];
      }
    }
  auto halfRadius = [](const double* x) {
    const double slope = (x[0] * x[4] - x[1] * x[2]) / (x[0] * x[3] - x[1] * x[1]);
    const double intercept = (x[2] - slope * x[1]) / x[0];
    return (0.5 - intercept) / slope;
  };
  const double measured = halfRadius(s[0]), predicted = halfRadius(s[1]);
  // The exact half point of the model, by bisection: close to f theta_e, a little inside.
  double lo = f * (thetaE - thetaC), hi = f * (thetaE + thetaC);
  for (int k = 0; k < 60; ++k) {
    const double mid = 0.5 * (lo + hi);
    (litFraction(mid / f, thetaC, thetaE) > 0.5 ? lo : hi) = mid;
  }
  const double halfPoint = 0.5 * (lo + hi);
  EXPECT_NEAR(predicted, halfPoint, 0.02);
  RecordProperty("disc_radius_mm", fmt::format("{:.4f} vs {:.4f} (half point {:.4f}, f theta_e {:.4f})", measured,
                                               predicted, halfPoint, f * thetaE));
  EXPECT_GT(measured, f * (thetaE - thetaC));
  EXPECT_LT(measured, f * (thetaE + thetaC));
  EXPECT_NEAR(measured, f * thetaE, 0.1 * f * thetaE);
  EXPECT_NEAR(measured, predicted, 0.04);  // a fifth of a pixel
}

// A glass box as a mesh, tilted so that no face lies on a float grid plane,
// placed 3 m and 10 m out along (1, 1, 1), and rays crossing it as they
// cross it at the origin. A mesh is met in float, so a path leaving a face
// must start off it by more than float rounding there: a fixed 1e-4 mm is
// under one unit in the last place past 1024 mm, and with it a quarter of these
// paths at 3 m would meet the face they had left again (at 10 m the box would
// stack inside itself until the tracer refused the path).
TEST(MeshPaths, AMeshFarFromTheOriginIsCrossedAsNearIt) {
  TriangleMesh box;
  for (const double z : {-2.5, 2.5})
    for (const auto& [x, y] : {std::pair{-10.0, -10.0}, {10.0, -10.0}, {10.0, 10.0}, {-10.0, 10.0}})
      box.vertices.push_back({x, y, z});
  box.triangles = {{0, 2, 1}, {0, 3, 2}, {4, 5, 6}, {4, 6, 7}, {0, 1, 5}, {0, 5, 4},
                   {3, 7, 6}, {3, 6, 2}, {0, 4, 7}, {0, 7, 3}, {1, 2, 6}, {1, 6, 5}};  // outward
  const Rigid3 tilt = Rigid3::rotation(Vec3(1, 1, 0).normalized(), 0.3);
  auto paths = [&](double far) {
    const Vec3 shift(far, far, far);
    const Scene scene({{.name = "box",
                        .shape = box,
                        .worldFromObject = Rigid3::translation(shift) * tilt,
                        .material = Dielectric{1.5, 0}}});
    std::vector<std::vector<Vec3>> out;
    for (int i = 0; i < 1000; ++i) {
      const double a = 0.1 + 0.2 * i / 1000, b = 0.1 * ((i * 7919) % 1000) / 1000;
      const Vec3 d(std::sin(a) * std::cos(b), std::sin(a) * std::sin(b), std::cos(a));
      const Vec3 o((i % 37) * 0.2 - 3.7, (i % 23) * 0.3 - 3.4, -20);
      std::vector<Vec3> path = refractionPath(scene, {o + shift, d.normalized()}, 64, 100);
      for (Vec3& v : path) v = v - shift;
      out.push_back(std::move(path));
    }
    return out;
  };
  const auto nearOrigin = paths(0);
  for (const double far : {3000.0, 10000.0}) {
    const auto farOut = paths(far);
    // The box's own float rounding and the step off each face move a vertex
    // by a few units in the last place at `far`.
    const double tolerance = 16 * std::numeric_limits<float>::epsilon() * far;
    int differ = 0;
    double worst = 0;
    for (size_t i = 0; i < nearOrigin.size(); ++i) {
      if (farOut[i].size() != nearOrigin[i].size()) {
        ++differ;
        continue;
      }
      for (size_t k = 0; k < farOut[i].size(); ++k) worst = std::max(worst, (farOut[i][k] - nearOrigin[i][k]).length());
    }
    EXPECT_EQ(differ, 0) << "at " << far << " mm";
    EXPECT_LT(worst, tolerance) << "at " << far << " mm";
  }
  size_t crossed = 0;  // most paths enter and leave the box (origin, 2 crossings, escape)
  for (const auto& path : nearOrigin) crossed += path.size() == 4;
  EXPECT_GT(crossed, 900u);
}

}  // namespace
