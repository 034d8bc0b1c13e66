// The path tracer against analytic radiometry: a flat slab's transmission with
// incoherent multiple reflections and Beer-Lambert absorption, the bright disc
// of a lens under parallel illumination, determinism, cancellation, progress.
#include "lfi/sim/render.h"
#include "lfi/core/error.h"
#include "lfi/sim/scene.h"
#include "lfi/sim/sensors.h"

#include "camera_samples.h"  // sim/src/tracer: the renderer's vectorised sample pass
#include "lfi_test_support.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <array>
#include <atomic>
#include <cmath>
#include <cstring>
#include <mutex>
#include <numbers>
#include <random>
#include <vector>

namespace {

using namespace lfi;
using namespace lfi::sim;
using lfi::testing_support::throwsError;

// Thick-lens focal length (lensmaker): 1/f = (n-1) [1/R1 - 1/R2 + (n-1) d / (n R1 R2)].
double lensmakerFocalLength(double r1, double r2, double d, double n) {
  return 1 / ((n - 1) * (1 / r1 - 1 / r2 + (n - 1) * d / (n * r1 * r2)));
}

// A camera looking down -z, focused on the plane z = focusZ, with an object
// pixel of fieldMm / size and acceptance half-angle acceptance (f = 100, b = 200, m = 1).
TelecentricCamera cameraAbove(double focusZ, int size, double fieldMm, double acceptance) {
  TelecentricCamera cam;
  cam.focalLength_mm = 100;
  cam.imageDistance_mm = 200;
  cam.stopDiameter_mm = 2 * cam.focalLength_mm * std::tan(acceptance);
  cam.pixelPitch_mm = fieldMm / size;  // magnification b / wz = 1
  cam.width = size;
  cam.height = size;
  cam.worldFromCamera = TelecentricCamera::lookingDownFrom(focusZ + cam.focusDistance_mm());
  return cam;
}

Object emitterBelow(double z, Emission emission, bool facingUp = true) {
  Rigid3 x = facingUp ? Rigid3() : Rigid3::rotation({1, 0, 0}, std::numbers::pi);
  x.t = {0, 0, z};
  return {.name = "backlight", .shape = Rectangle{400, 400}, .worldFromObject = x, .emission = emission};
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
  objects.push_back({.name = "B", .shape = Solid::sphere(10, Rigid3::translation({0, 0, -12})),
                     .material = Dielectric{1.5, 0}});
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

// ---- Determinism, cancellation, progress ----------------------------------

struct SmallLensScene {
  Scene scene;
  TelecentricCamera cam;
  SmallLensScene()
      : scene([] {
          std::vector<Object> objects;
          objects.push_back(emitterBelow(-60, ParallelEmission{1.0, 0.02}));
          objects.push_back({.name = "lens",
                             .shape = std::shared_ptr<const Solid>(Solid::sphericalLens(100, -100, 7, 12)),
                             .material = Dielectric{1.5, 0.01}});
          return objects;
        }()),
        cam(cameraAbove(0, 32, 10, 0.01)) {}
};

TEST(Render, BitIdenticalForAnyThreadCountAndTileSize) {
  SmallLensScene s;
  RenderOptions a;
  a.samplesPerPixel = 4;
  a.splitDepth = 0;  // pure sampling: every random choice shows in the image
  a.seed = 7;
  a.threads = 1;
  a.tileSize = 16;
  RenderOptions b = a;
  b.threads = 2;
  b.tileSize = 5;
  const cv::Mat ia = render(s.scene, s.cam, a), ib = render(s.scene, s.cam, b);
  ASSERT_EQ(ia.size(), ib.size());
  ASSERT_EQ(ia.type(), ib.type());
  ASSERT_TRUE(ia.isContinuous() && ib.isContinuous());
  EXPECT_EQ(std::memcmp(ia.data, ib.data, ia.total() * ia.elemSize()), 0);
  EXPECT_GT(cv::norm(ia, cv::NORM_L1), 10);  // not trivially black

  RenderOptions c = b;
  c.seed = 8;
  const cv::Mat ic = render(s.scene, s.cam, c);
  EXPECT_NE(std::memcmp(ia.data, ic.data, ia.total() * ia.elemSize()), 0);
  EXPECT_GT(cv::norm(ia, ic, cv::NORM_L1), 1);

  // With Fresnel splitting each sample is a tree of branches, and samples of
  // different pixels share packets differently for each tile size: still the
  // same bits.
  RenderOptions split = a;
  split.splitDepth = 3;
  split.samplesPerPixel = 5;  // not a square: some samples outside the strata
  const cv::Mat reference = render(s.scene, s.cam, split);
  for (const auto& [threads, tile] : {std::pair{2, 1}, std::pair{2, 3}, std::pair{1, 64}}) {
    RenderOptions o = split;
    o.threads = threads;
    o.tileSize = tile;
    const cv::Mat other = render(s.scene, s.cam, o);
    EXPECT_EQ(std::memcmp(reference.data, other.data, reference.total() * reference.elemSize()), 0)
        << threads << " threads, tile " << tile;
  }
  EXPECT_GT(cv::norm(reference, cv::NORM_L1), 10);  // not trivially black
  // Splitting is in effect: the same samples without it give another image.
  RenderOptions sampled = split;
  sampled.splitDepth = 0;
  EXPECT_GT(cv::norm(reference, render(s.scene, s.cam, sampled), cv::NORM_L1), 1);
}

// permutationElement permutes [0, n) for any n (powers of two and, by cycle
// walking, the rest); distinct keys give distinct permutations; over many keys
// each element lands in each position equally often (here 4000 keys, n = 8:
// each count is 500 +- 21 (binomial sigma), bounded at 5 sigma).
TEST(Sampler, PermutationElementsPermuteAndAreUniform) {
  for (std::uint32_t n : {1u, 2u, 3u, 7u, 16u, 64u, 100u, 1000u})
    for (std::uint32_t key : {0u, 1u, 0xdeadbeefu, 0x9e3779b9u, 0xffffffffu, 0xfffffc00u}) {
      std::vector<int> seen(n, 0);
      for (std::uint32_t i = 0; i < n; ++i) {
        const std::uint32_t v = permutationElement(i, n, key);
        ASSERT_LT(v, n);
        ++seen[v];
      }
      for (std::uint32_t v = 0; v < n; ++v) ASSERT_EQ(seen[v], 1) << "n = " << n << ", key = " << key;
    }
  int same = 0;
  for (std::uint32_t i = 0; i < 64; ++i) same += permutationElement(i, 64, 11) == permutationElement(i, 64, 12);
  EXPECT_LT(same, 16);
  std::array<std::array<int, 8>, 8> counts{};
  Sampler keys(3, 9);
  for (int k = 0; k < 4000; ++k) {
    const std::uint32_t key = keys.nextU32();
    for (std::uint32_t i = 0; i < 8; ++i) ++counts[i][permutationElement(i, 8, key)];
  }
  const double sigma = std::sqrt(4000 * (1.0 / 8) * (7.0 / 8));
  for (const auto& row : counts)
    for (int c : row) EXPECT_NEAR(c, 500, 5 * sigma);
}

// Uniform doubles in [0, 1) with mean 1/2, one per draw or two (whose
// product then has mean 1/4: the halves are uncorrelated); the ends of the
// 32-bit map.
TEST(Sampler, UniformDoublesAreInRange) {
  Sampler sampler(3, 9);
  constexpr int kDraws = 100000;
  double sum = 0, sumA = 0, sumB = 0, sumAB = 0;
  for (int k = 0; k < kDraws; ++k) {
    const double u = sampler.next();
    double a, b;
    sampler.nextPair(a, b);
    for (const double v : {u, a, b}) {
      ASSERT_GE(v, 0.0);
      ASSERT_LT(v, 1.0);
    }
    sum += u, sumA += a, sumB += b, sumAB += a * b;
  }
  const double sigma = std::sqrt(1.0 / 12 / kDraws);
  EXPECT_NEAR(sum / kDraws, 0.5, 5 * sigma);
  EXPECT_NEAR(sumA / kDraws, 0.5, 5 * sigma);
  EXPECT_NEAR(sumB / kDraws, 0.5, 5 * sigma);
  EXPECT_NEAR(sumAB / kDraws, 0.25, 5 * std::sqrt(7.0 / 144 / kDraws));  // var(ab) = 1/9 - 1/16
  EXPECT_EQ(Sampler::unitInterval32(0), 0.0);
  EXPECT_EQ(Sampler::unitInterval32(0xffffffffu), 1.0 - 0x1p-32);
  EXPECT_EQ(Sampler::unitInterval32(0x80000000u), 0.5);
}

// The concentric map (Shirley and Chiu 1997): square (u1, u2) -> 2u - 1 =
// (a, b); for |a| > |b| the point is a (cos phi, sin phi) with phi = pi/4 b/a,
// otherwise b (sin psi, cos psi) with psi = pi/4 a/b. The renderer's own sin
// and cos (series on |x| <= pi/4) must agree with libm to rounding; the map
// keeps radius max(|a|, |b|) and is uniform: a quadrant's share is 1/4 and the
// mean of r^2 over a uniform disc is 1/2.
TEST(ConcentricDisc, IsShirleysMapToRoundingAndUniform) {
  Sampler sampler(5, 1);
  double r2 = 0;
  int firstQuadrant = 0;
  const int n = 200000;
  for (int k = 0; k < n; ++k) {
    const double u1 = sampler.next(), u2 = sampler.next();
    const Vec2 p = concentricDisc(u1, u2);
    const double a = 2 * u1 - 1, b = 2 * u2 - 1;
    const double phi = std::abs(a) > std::abs(b) ? std::numbers::pi / 4 * b / a : std::numbers::pi / 4 * a / b;
    const Vec2 expected = std::abs(a) > std::abs(b) ? Vec2(a * std::cos(phi), a * std::sin(phi))
                                                    : Vec2(b * std::sin(phi), b * std::cos(phi));
    ASSERT_NEAR(p.x, expected.x, 4e-16) << u1 << " " << u2;
    ASSERT_NEAR(p.y, expected.y, 4e-16) << u1 << " " << u2;
    ASSERT_NEAR(std::hypot(p.x, p.y), std::max(std::abs(a), std::abs(b)), 1e-15);
    r2 += p.x * p.x + p.y * p.y;
    firstQuadrant += p.x > 0 && p.y > 0;
  }
  EXPECT_NEAR(r2 / n, 0.5, 5 * std::sqrt(1.0 / 12 / n));  // r^2 is uniform on [0, 1)
  EXPECT_NEAR(firstQuadrant, n / 4, 5 * std::sqrt(n * 0.25 * 0.75));
  // Square edges and corners land on the circle at the angles the map gives them.
  EXPECT_NEAR(concentricDisc(1, 0.5).x, 1, 1e-16);
  EXPECT_NEAR(concentricDisc(1, 1).x, std::sqrt(0.5), 2e-16);
  EXPECT_NEAR(concentricDisc(1, 1).y, std::sqrt(0.5), 2e-16);
  EXPECT_NEAR(concentricDisc(0.5, 0).y, -1, 1e-16);
  EXPECT_EQ(concentricDisc(0.5, 0.5).x, 0);
}

// The renderer makes a packet's camera samples in one vectorised pass (an
// AVX-512, AVX2 or baseline clone). Each must be, to the bit, what the public
// one-sample formulas give: the sample's stream Sampler(seed, stream) and its
// first four draws, the jittered pixel stratum, the stop stratum through
// concentricDisc, and TelecentricCamera::ray; a stratum of -1 means plain draws.
TEST(CameraSamples, VectorisedPassEqualsOneSampleAtATime) {
  TelecentricCamera cam;
  cam.width = 300, cam.height = 200, cam.pixelPitch_mm = 0.05;
  cam.worldFromCamera = Rigid3::rotation(Vec3(1, 2, 3).normalized(), 0.7);
  cam.worldFromCamera.t = {3, -4, 150};
  const TelecentricCamera::RayMap map(cam);
  const int side = 3;
  const std::uint64_t seed = 42;
  detail::CameraSampleBatch batch;
  for (int k = 0; k < detail::CameraSampleBatch::kSize; ++k) {
    batch.stream[k] = 1000003ull * static_cast<std::uint64_t>(k) + 17;
    batch.pixelX[k] = 37 * k % cam.width, batch.pixelY[k] = 11 * k % cam.height;
    batch.sample[k] = static_cast<std::uint32_t>((7 * k + 3) % 13);  // side^2 = 9: some stratified, some not
    batch.stopKey[k] = 0x9e3779b9u * static_cast<std::uint32_t>(k + 1);
  }
  detail::makeCameraSamples(map, seed, side, detail::CameraSampleBatch::kSize, batch);
  for (int k = 0; k < detail::CameraSampleBatch::kSize; ++k) {
    Sampler sampler(seed, batch.stream[k]);
    double u0, u1, u2, u3;
    sampler.nextPair(u0, u1);
    sampler.nextPair(u2, u3);
    const bool plain = batch.sample[k] >= side * side;
    auto stratified = [&](std::uint32_t s, double u, double v) {
      if (plain) return Vec2(u, v);
      const auto row = static_cast<int>(s) / side, col = static_cast<int>(s) - row * side;
      return Vec2((col + u) * (1.0 / side), (row + v) * (1.0 / side));  // the renderer's jittered stratum
    };
    const std::uint32_t stopStratum = plain ? 0 : permutationElement(batch.sample[k], side * side, batch.stopKey[k]);
    const Vec2 stop = stratified(stopStratum, u2, u3);
    const Ray ray = cam.ray(static_cast<int>(batch.pixelX[k]), static_cast<int>(batch.pixelY[k]),
                            stratified(batch.sample[k], u0, u1), concentricDisc(stop.x, stop.y));
    EXPECT_EQ(batch.ox[k], ray.origin.x) << k;
    EXPECT_EQ(batch.oy[k], ray.origin.y) << k;
    EXPECT_EQ(batch.oz[k], ray.origin.z) << k;
    EXPECT_EQ(batch.dx[k], ray.direction.x) << k;
    EXPECT_EQ(batch.dy[k], ray.direction.y) << k;
    EXPECT_EQ(batch.dz[k], ray.direction.z) << k;
    EXPECT_EQ(batch.state[k], sampler.state) << k;
  }
}

// The light field sensor's samples, made in one vectorised pass, equal to the
// bit the sample stream's first two draws (Sampler::next), the jittered pixel
// stratum and LightFieldSensor::ray, or have no ray where that has none.
TEST(CameraSamples, LightFieldPassEqualsOneSampleAtATime) {
  LightFieldSensor sensor;
  sensor.geometry = {.spatialX = 7, .spatialY = 5, .angular = 9, .pixelPitch_mm = 0.03, .distance_mm = 0};
  sensor.worldFromSensor = Rigid3::translation({1, -2, -30}) * Rigid3::rotation({1, -0.5, 0.2}, 0.4);
  const std::uint64_t seed = 17;
  int withRay = 0, without = 0;
  for (const int side : {1, 3, 4}) {
    std::mt19937 rng(static_cast<unsigned>(side));
    for (int round = 0; round < 40; ++round) {
      detail::CameraSampleBatch batch;
      // Whole batches (as the renderer makes them) and partial ones (a tile's last).
      const int n = round % 2 ? detail::CameraSampleBatch::kSize : 1 + round * 3 % detail::CameraSampleBatch::kSize;
      for (int k = 0; k < n; ++k) {
        batch.stream[k] = rng() * 0x9e3779b97f4a7c15ull + static_cast<std::uint64_t>(k);
        batch.pixelX[k] = rng() % static_cast<unsigned>(sensor.geometry.width());
        batch.pixelY[k] = rng() % static_cast<unsigned>(sensor.geometry.height());
        batch.sample[k] = rng() % static_cast<unsigned>(side * side + 3);  // also past the strata
      }
      const std::uint64_t hasRay = detail::makeLightFieldSamples(sensor, seed, side, n, batch);
      for (int k = 0; k < n; ++k) {
        Sampler sampler(seed, batch.stream[k]);
        const double first = sampler.next();
        Vec2 offset(first, sampler.next());
        if (const auto s = static_cast<int>(batch.sample[k]); s < side * side) {
          const int row = s / side;
          offset = Vec2((s - row * side + offset.x) * (1.0 / side), (row + offset.y) * (1.0 / side));
        }
        const auto ray = sensor.ray(static_cast<int>(batch.pixelX[k]), static_cast<int>(batch.pixelY[k]), offset);
        ASSERT_EQ(hasRay >> k & 1, ray.has_value() ? 1u : 0u) << k;
        EXPECT_EQ(batch.state[k], sampler.state) << k;
        if (!ray) {
          ++without;
          continue;
        }
        ++withRay;
        EXPECT_EQ(Vec3(batch.ox[k], batch.oy[k], batch.oz[k]), ray->origin) << k;
        EXPECT_EQ(Vec3(batch.dx[k], batch.dy[k], batch.dz[k]), ray->direction) << k;
      }
    }
  }
  EXPECT_GT(withRay, 500);
  EXPECT_GT(without, 50);
}

// The stratified Fresnel choices, made in the vectorised pass (the first
// kBatchedChoices) or one at a time (stratifiedChoice, all of them), equal the
// formula of camera_samples.h to the bit, for sample counts with and without
// cycle walking; and each choice's values over a pixel's samples form a Latin
// hypercube (one value in each of the spp strata).
TEST(CameraSamples, StratifiedChoicesAreALatinHypercube) {
  for (const std::uint32_t spp : {1u, 9u, 16u, 13u, 100u, 300u}) {
    std::vector<std::vector<int>> perStratum(detail::kStratifiedChoices, std::vector<int>(spp, 0));
    for (std::uint32_t first = 0; first < spp; first += detail::ChoiceBatch::kSize) {
      detail::ChoiceBatch batch;
      const int n = static_cast<int>(std::min<std::uint32_t>(detail::ChoiceBatch::kSize, spp - first));
      auto key = [](int d) { return 0x2545f491u * static_cast<std::uint32_t>(d + 3); };
      for (int k = 0; k < n; ++k) {
        batch.sample[k] = first + static_cast<std::uint32_t>(k);
        for (int d = 0; d < detail::kBatchedChoices; ++d) batch.key[d][k] = key(d);
      }
      detail::makeStratifiedChoices(spp, n, batch);
      for (int k = 0; k < n; ++k)
        for (int d = 0; d < detail::kStratifiedChoices; ++d) {
          const std::uint32_t s = batch.sample[k];
          const double jitter = Sampler::unitInterval(splitMix64((std::uint64_t{key(d)} << 32) | s));
          const double u = (permutationElement(s, spp, key(d)) + jitter) * (1.0 / spp);
          EXPECT_EQ(detail::stratifiedChoice(spp, s, key(d)), u) << spp << " " << s;
          if (d < detail::kBatchedChoices) {
            EXPECT_EQ(batch.u[d][k], u) << spp << " " << s;
          }
          ASSERT_GE(u, 0);
          ASSERT_LT(u, 1);
          ++perStratum[static_cast<size_t>(d)][static_cast<size_t>(u * spp)];
        }
    }
    for (const auto& counts : perStratum)
      for (const int c : counts) EXPECT_EQ(c, 1) << "spp " << spp;
  }
  // A batch as the renderer fills it: samples of several pixels, each with its own keys.
  std::mt19937 rng(5);
  for (const std::uint32_t spp : {16u, 13u, 300u}) {
    detail::ChoiceBatch batch;
    for (int k = 0; k < detail::ChoiceBatch::kSize; ++k) {
      batch.sample[k] = rng() % spp;
      for (int d = 0; d < detail::kBatchedChoices; ++d) batch.key[d][k] = rng();
    }
    detail::makeStratifiedChoices(spp, detail::ChoiceBatch::kSize, batch);
    for (int k = 0; k < detail::ChoiceBatch::kSize; ++k)
      for (int d = 0; d < detail::kBatchedChoices; ++d)
        EXPECT_EQ(batch.u[d][k], detail::stratifiedChoice(spp, batch.sample[k], batch.key[d][k])) << spp << " " << k;
  }
}

TEST(Render, CancelFlagSetBeforehandThrowsCancelled) {
  SmallLensScene s;
  std::atomic<bool> cancel{true};
  RenderOptions opt;
  opt.samplesPerPixel = 1;
  opt.threads = 2;
  opt.cancel = &cancel;
  try {
    render(s.scene, s.cam, opt);
    FAIL() << "render did not throw";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), Errc::Cancelled);
  }
  // Not set: renders normally.
  cancel = false;
  EXPECT_NO_THROW(render(s.scene, s.cam, opt));
}

TEST(Render, ProgressEndsAtOne) {
  SmallLensScene s;
  const int tileSize = 8, tiles = (32 / tileSize) * (32 / tileSize);
  for (int threads : {1, 2}) {
    std::mutex m;
    std::vector<double> calls;
    RenderOptions opt;
    opt.samplesPerPixel = 1;
    opt.threads = threads;
    opt.tileSize = tileSize;
    opt.progress = [&](double x) {
      std::lock_guard lock(m);
      calls.push_back(x);
    };
    render(s.scene, s.cam, opt);
    ASSERT_EQ(static_cast<int>(calls.size()), tiles) << "threads=" << threads;
    for (double x : calls) {
      EXPECT_GT(x, 0);
      EXPECT_LE(x, 1);
    }
    // Every fraction k / tiles is reported once; 1.0 is among them. With one
    // thread the calls come in order, so 1.0 is the last one.
    std::vector<double> sorted = calls;
    std::sort(sorted.begin(), sorted.end());
    for (int k = 0; k < tiles; ++k) EXPECT_DOUBLE_EQ(sorted[k], (k + 1.0) / tiles);
    if (threads == 1) {
      EXPECT_EQ(calls.back(), 1.0);
    }
  }
}

TEST(Render, RejectsInvalidOptions) {
  SmallLensScene s;
  RenderOptions opt;
  opt.samplesPerPixel = 0;
  EXPECT_TRUE(throwsError([&] { render(s.scene, s.cam, opt); }, Errc::InvalidArgument, {"samplesPerPixel"}));
  opt.samplesPerPixel = 1;
  opt.splitDepth = 13;
  EXPECT_TRUE(
      throwsError([&] { render(s.scene, s.cam, opt); }, Errc::InvalidArgument, {"splitDepth = 13", "[0, 12]"}));
  opt.splitDepth = 12;  // the largest taken
  EXPECT_NO_THROW(render(s.scene, s.cam, opt));
}

// A glass box as a mesh, tilted so that no face lies on a float grid plane,
// placed 3 m and 10 m out along (1, 1, 1), and rays crossing it as they
// cross it at the origin. A mesh is met in float, so a path leaving a face
// must start off it by more than float rounding there: a fixed 1e-4 mm is
// under one unit in the last place past 1024 mm, and at 3 m a quarter of these
// paths met the face they had left again (at 10 m the box stacked inside
// itself until the tracer refused the path).
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
    const Scene scene({{.name = "box", .shape = box, .worldFromObject = Rigid3::translation(shift) * tilt,
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
