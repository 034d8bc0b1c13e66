// SPDX-License-Identifier: Apache-2.0
// Interface optics (Snell, Fresnel, total internal reflection), the paraxial
// focal length of a traced thick lens, and the two sensors' ray geometry,
// all against closed-form optics.
#include "lfi/sim/render.h"
#include "lfi/sim/scene.h"
#include "lfi/sim/sensors.h"

#include "fresnel_step.h"       // internal to lfi_sim: the vectorised Fresnel events
#include "light_field_lanes.h"  // and light field emitters

#include <fmt/format.h>
#include "lfi_test_support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <tuple>

#include <cmath>
#include <numbers>

namespace {

using namespace lfi;
using namespace lfi::sim;

using lfi::testing_support::expectNear;
using lfi::testing_support::throwsError;

// A direction at angle theta from -n (travelling into the surface) in the x-z plane.
Vec3 incoming(double theta) {
  return {std::sin(theta), 0, -std::cos(theta)};
}

TEST(Fresnel, NormalIncidence) {
  for (auto [n1, n2] : {std::pair{1.0, 1.5}, std::pair{1.5, 1.0}, std::pair{1.0, 1.7}, std::pair{1.33, 1.5}}) {
    const double r = (n1 - n2) / (n1 + n2);
    EXPECT_NEAR(fresnelReflectance(1.0, n1, n2), r * r, 1e-15) << n1 << " -> " << n2;
  }
  EXPECT_NEAR(fresnelReflectance(1.0, 1.0, 1.5), 0.04, 1e-15);
  EXPECT_NEAR(fresnelReflectance(1.0, 1.5, 1.5), 0.0, 1e-15);
}

TEST(Fresnel, BrewsterAngleLeavesOnlyTheSComponent) {
  for (auto [n1, n2] : {std::pair{1.0, 1.5}, std::pair{1.5, 1.0}}) {
    const double thetaB = std::atan(n2 / n1);
    // At Brewster's angle the refracted ray is perpendicular to the reflected
    // one: thetaT = pi/2 - thetaB, and rs = -sin(thetaB - thetaT) / sin(thetaB + thetaT).
    const double thetaT = std::numbers::pi / 2 - thetaB;
    const double rs = -std::sin(thetaB - thetaT) / std::sin(thetaB + thetaT);
    EXPECT_NEAR(fresnelReflectance(std::cos(thetaB), n1, n2), rs * rs / 2, 1e-14) << n1 << " -> " << n2;
    // Not a coincidence of the formula: slightly off Brewster, R is larger.
    EXPECT_GT(fresnelReflectance(std::cos(thetaB + 0.05), n1, n2), rs * rs / 2);
  }
}

TEST(Fresnel, GeneralAngleMatchesTheFresnelEquationsInSineForm) {
  // rs = -sin(ti - tt)/sin(ti + tt), rp = tan(ti - tt)/tan(ti + tt); R = (rs^2 + rp^2) / 2.
  const double n1 = 1.0, n2 = 1.5;
  for (double ti : {0.1, 0.4, 0.8, 1.2, 1.5}) {
    const double tt = std::asin(n1 / n2 * std::sin(ti));
    const double rs = -std::sin(ti - tt) / std::sin(ti + tt), rp = std::tan(ti - tt) / std::tan(ti + tt);
    EXPECT_NEAR(fresnelReflectance(std::cos(ti), n1, n2), 0.5 * (rs * rs + rp * rp), 1e-13) << ti;
  }
  EXPECT_NEAR(fresnelReflectance(0.0, n1, n2), 1.0, 1e-12);  // grazing incidence
}

TEST(Fresnel, TotalInternalReflectionAboveTheCriticalAngle) {
  const double n1 = 1.5, n2 = 1.0;
  const double critical = std::asin(n2 / n1);
  const Vec3 n(0, 0, 1);
  Vec3 out;
  for (double theta : {critical + 1e-6, critical + 0.1, 1.5}) {
    EXPECT_EQ(fresnelReflectance(std::cos(theta), n1, n2), 1.0) << theta;
    EXPECT_FALSE(refract(incoming(theta), n, n1 / n2, out)) << theta;
  }
  // Just below: partial reflection, and refraction exists at almost grazing exit.
  const double below = critical - 1e-4;
  EXPECT_LT(fresnelReflectance(std::cos(below), n1, n2), 1.0);
  EXPECT_GT(fresnelReflectance(std::cos(below), n1, n2), 0.5);
  ASSERT_TRUE(refract(incoming(below), n, n1 / n2, out));
  EXPECT_GT(std::abs(out.x), 0.99);
}

TEST(Snell, RefractedRayObeysSnellAndStaysInThePlaneOfIncidence) {
  const Vec3 n = Vec3(0.2, -0.3, 1).normalized();
  for (auto [n1, n2] : {std::pair{1.0, 1.5}, std::pair{1.5, 1.0}, std::pair{1.0, 2.4}}) {
    for (double az : {0.0, 1.0, 2.5}) {
      for (double theta : {0.0, 0.2, 0.5, 0.7}) {
        // Build d at angle theta to -n, azimuth az around n.
        const Vec3 t1 = Vec3(1, 0, 0).cross(n).normalized(), t2 = n.cross(t1);
        const Vec3 d = (-n * std::cos(theta) + (t1 * std::cos(az) + t2 * std::sin(az)) * std::sin(theta)).normalized();
        Vec3 out;
        const bool ok = refract(d, n, n1 / n2, out);
        if (n1 * std::sin(theta) >= n2) {
          EXPECT_FALSE(ok);
          continue;
        }
        ASSERT_TRUE(ok);
        EXPECT_NEAR(out.length(), 1, 1e-14);
        const double sinI = d.cross(n).length(), sinT = out.cross(n).length();
        EXPECT_NEAR(n1 * sinI, n2 * sinT, 1e-13);
        EXPECT_LT(out.dot(n), 0);                    // transmitted: continues through the surface
        EXPECT_NEAR(out.dot(d.cross(n)), 0, 1e-13);  // coplanar with d and n
        if (theta > 0) {
          EXPECT_GT(out.dot(d - n * d.dot(n)), 0);  // same side of the normal as d
        }
        const Vec3 r = reflect(d, n);
        EXPECT_NEAR(r.dot(n), -d.dot(n), 1e-14);  // law of reflection
        expectNear(r - n * r.dot(n), d - n * d.dot(n), 1e-14);
      }
    }
  }
}

// A path refracts and reflects many times: its direction stays unit length to
// rounding (no drift), whatever the interfaces.
TEST(Snell, DirectionsStayUnitOverManyInterfaces) {
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<double> u(-1, 1);
  Vec3 d = Vec3(0.3, -0.2, -1).normalized();
  double worst = 0;
  for (int i = 0; i < 100000; ++i) {
    Vec3 n = Vec3(u(rng), u(rng), u(rng)).normalized();
    if (d.dot(n) > 0) n = -n;  // facing the incoming side
    Vec3 out;
    const double eta = u(rng) > 0 ? 1 / 1.5 : 1.5;
    d = u(rng) > 0.5 || !refract(d, n, eta, out) ? reflect(d, n) : out;
    worst = std::max(worst, std::abs(d.length() - 1));
  }
  EXPECT_LT(worst, 1e-15);
}

// The packet renderer's Fresnel events, all lanes at once (vectorised),
// equal the one-ray event to the bit, and the event is the interface optics
// above: its reflectance is fresnelReflectance, its directions those of
// reflect() and refract() with the normal turned to the incoming side (Snell:
// n1 sin i = n2 sin t), total internal reflection past the critical angle;
// the lanes' hit points are the rays' points at t.
TEST(FresnelLanes, EqualTheOneRayEventAndTheInterfaceOptics) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-1, 1);
  constexpr int kLanes = detail::FresnelLanes::kSize;
  const double indices[][2] = {{1.0, 1.5}, {1.5, 1.0}, {1.5, 1.33}};
  RayLanes rays;
  Scene::HitPacket hits;
  detail::FresnelLanes lanes;
  int refracted = 0, reflectedTotally = 0;
  for (int round = 0; round < 200; ++round) {
    for (int k = 0; k < kLanes; ++k) {
      rays.set(k, {{10 * u(rng), 10 * u(rng), 10 * u(rng)}, Vec3(u(rng), u(rng), u(rng)).normalized()});
      const Vec3 n = Vec3(u(rng), u(rng), u(rng)).normalized();
      hits.t[k] = 50 * (u(rng) + 1), hits.nx[k] = n.x, hits.ny[k] = n.y, hits.nz[k] = n.z;
      lanes.n1[k] = indices[k % 3][0], lanes.n2[k] = indices[k % 3][1];
    }
    detail::fresnelLanes(rays, hits, lanes);
    detail::FresnelLanes one{};  // the same events, one lane at a time (the renderer's small steps)
    std::copy_n(lanes.n1, kLanes, one.n1);
    std::copy_n(lanes.n2, kLanes, one.n2);
    for (int k = kLanes - 1; k >= 0; --k) detail::fresnelLane(rays, hits, one, k);
    for (int k = 0; k < kLanes; ++k) {
      for (const auto field : {&detail::FresnelLanes::px, &detail::FresnelLanes::py, &detail::FresnelLanes::pz,
                               &detail::FresnelLanes::cosT, &detail::FresnelLanes::reflectance,
                               &detail::FresnelLanes::rx, &detail::FresnelLanes::ry, &detail::FresnelLanes::rz,
                               &detail::FresnelLanes::tx, &detail::FresnelLanes::ty, &detail::FresnelLanes::tz})
        EXPECT_EQ((one.*field)[k], (lanes.*field)[k]) << "lane " << k;
      const Ray ray = rays.ray(k);
      const Vec3 d = ray.direction, n = hits.normal(k);
      const double n1 = lanes.n1[k], n2 = lanes.n2[k];
      const detail::FresnelEvent e = detail::fresnelEvent(d, n, n1, n2);
      EXPECT_EQ(lanes.cosT[k], e.cosT);
      EXPECT_EQ(lanes.reflectance[k], e.reflectance);
      EXPECT_EQ(Vec3(lanes.rx[k], lanes.ry[k], lanes.rz[k]), Vec3(e.rx, e.ry, e.rz));
      EXPECT_EQ(Vec3(lanes.px[k], lanes.py[k], lanes.pz[k]), ray.at(hits.t[k]));
      if (e.cosT >= 0) {
        EXPECT_EQ(Vec3(lanes.tx[k], lanes.ty[k], lanes.tz[k]), Vec3(e.tx, e.ty, e.tz));
      }

      const Vec3 facing = d.dot(n) < 0 ? n : -n;
      const double cosI = -d.dot(facing);
      EXPECT_EQ(e.reflectance, fresnelReflectance(cosI, n1, n2));
      EXPECT_EQ(Vec3(e.rx, e.ry, e.rz), reflect(d, facing));
      Vec3 out;
      const bool transmits = refract(d, facing, n1 / n2, out);
      ASSERT_EQ(transmits, e.cosT >= 0) << "cos i " << cosI << ", " << n1 << " -> " << n2;
      if (!transmits) {
        ++reflectedTotally;
        EXPECT_EQ(e.reflectance, 1.0);
        EXPECT_GT(n1 * std::sqrt(1 - cosI * cosI), n2 * (1 - 1e-12));  // past the critical angle
        continue;
      }
      ++refracted;
      EXPECT_EQ(Vec3(e.tx, e.ty, e.tz), out);
      EXPECT_NEAR(n1 * std::sqrt(1 - cosI * cosI), n2 * std::sqrt(1 - e.cosT * e.cosT), 1e-12);
      EXPECT_NEAR(-out.dot(facing), e.cosT, 1e-12);
    }
  }
  EXPECT_GT(refracted, 1000);
  EXPECT_GT(reflectedTotally, 100);
}

// Thick lens in air: 1/f = (n-1) [1/R1 - 1/R2 + (n-1) d / (n R1 R2)]; the back
// focal length is f (1 - (n-1) d / (n R1)), measured from the back vertex.
TEST(ParaxialLens, TracedFocalLengthMatchesTheThickLensEquation) {
  const double r1 = 100, r2 = -100, tc = 7, n = 1.5, h = 0.5;
  const double f = 1 / ((n - 1) * (1 / r1 - 1 / r2 + (n - 1) * tc / (n * r1 * r2)));
  const double bfl = f * (1 - (n - 1) * tc / (n * r1));
  for (double zLens : {0.0, 37.5}) {
    SCOPED_TRACE(testing::Message() << "lens at z=" << zLens);
    std::vector<Object> objects;
    objects.push_back({.name = "lens",
                       .shape = std::shared_ptr<const Solid>(Solid::sphericalLens(r1, r2, tc, 50)),
                       .worldFromObject = Rigid3::translation({0, 0, zLens}),
                       .material = Dielectric{n, 0}});
    const Scene scene(std::move(objects));
    const auto path = refractionPath(scene, {{h, 0, zLens - 50}, {0, 0, 1}});
    ASSERT_EQ(path.size(), 4u);  // origin, front surface, back surface, escape point
    EXPECT_NEAR(path[1].z - zLens, -tc / 2 + (r1 - std::sqrt(r1 * r1 - h * h)), 1e-9);
    const Vec3 a = path[2], b = path[3];
    ASSERT_LT(b.x, 0);  // converging: the exit ray crosses the axis
    // Axis crossing of the exit line, and where it is at height h (the rear principal plane).
    const double zFocus = a.z + (0 - a.x) / (b.x - a.x) * (b.z - a.z);
    const double zPrincipal = a.z + (h - a.x) / (b.x - a.x) * (b.z - a.z);
    const double efl = zFocus - zPrincipal, measuredBfl = zFocus - (zLens + tc / 2);
    RecordProperty(fmt::format("efl_rel_error_z{}", zLens),
                   fmt::format("{:.2e} (bfl {:.2e})", (efl - f) / f, (measuredBfl - bfl) / bfl));
    EXPECT_NEAR(efl, f, 0.005 * f);
    EXPECT_NEAR(measuredBfl, bfl, 0.005 * bfl);
    // Paraxial (h/f = 0.005): the residual is spherical aberration, far below 0.5 %.
    EXPECT_NEAR(efl, f, 1e-4 * f);
  }
}

TEST(ParaxialLens, DivergingLensHasANegativeFocalLength) {
  const double r1 = -80, r2 = 120, tc = 4, n = 1.6, h = 0.5;
  const double f = 1 / ((n - 1) * (1 / r1 - 1 / r2 + (n - 1) * tc / (n * r1 * r2)));
  ASSERT_LT(f, 0);
  std::vector<Object> objects;
  objects.push_back({.name = "lens",
                     .shape = std::shared_ptr<const Solid>(Solid::sphericalLens(r1, r2, tc, 40)),
                     .material = Dielectric{n, 0}});
  const Scene scene(std::move(objects));
  const auto path = refractionPath(scene, {{h, 0, -50}, {0, 0, 1}});
  ASSERT_EQ(path.size(), 4u);
  const Vec3 a = path[2], b = path[3];
  ASSERT_GT(b.x, h);                                                  // diverging
  const double zFocus = a.z + (0 - a.x) / (b.x - a.x) * (b.z - a.z);  // virtual focus, in front
  const double zPrincipal = a.z + (h - a.x) / (b.x - a.x) * (b.z - a.z);
  EXPECT_NEAR(zFocus - zPrincipal, f, 1e-3 * std::abs(f));
}

// ---- Telecentric camera -------------------------------------------------

TelecentricCamera testCamera(const Rigid3& worldFromCamera) {
  TelecentricCamera cam;
  cam.focalLength_mm = 80;
  cam.imageDistance_mm = 200;  // wz = 133.33 mm, magnification 1.5
  cam.stopDiameter_mm = 3;
  cam.pixelPitch_mm = 0.05;
  cam.width = 40;
  cam.height = 30;
  cam.worldFromCamera = worldFromCamera;
  return cam;
}

Rigid3 someCameraPose() {
  return Rigid3::translation({5, -3, 250}) * Rigid3::rotation(Vec3(0.4, 1, 0.3), 2.6);
}

TEST(TelecentricCamera, MagnificationDoesNotDependOnObjectDistance) {
  const TelecentricCamera cam = testCamera(someCameraPose());
  const Vec3 axis = cam.worldFromCamera.vector({0, 0, 1});
  const double m = cam.imageDistance_mm / cam.focusDistance_mm();
  for (const Vec3& local : {Vec3(0.3, -0.2, 0), Vec3(-0.5, 0.4, 0), Vec3(0, 0, 0)}) {
    const Vec2 p0 = cam.project(cam.worldFromCamera.point(local + Vec3(0, 0, 100)));
    for (double dz : {-50.0, 3.0, 40.0, 400.0}) {
      const Vec2 p = cam.project(cam.worldFromCamera.point(local + Vec3(0, 0, 100)) + axis * dz);
      EXPECT_NEAR(p.x, p0.x, 1e-9);
      EXPECT_NEAR(p.y, p0.y, 1e-9);
    }
    // Scale: m = b / wz pixels per pitch per mm, centred at (W/2, H/2).
    EXPECT_NEAR(p0.x, 0.5 * cam.width + local.x * m / cam.pixelPitch_mm, 1e-9);
    EXPECT_NEAR(p0.y, 0.5 * cam.height + local.y * m / cam.pixelPitch_mm, 1e-9);
  }
  EXPECT_NEAR(cam.magnification(), m, 1e-15);
}

TEST(TelecentricCamera, ChiefRaysAreParallelToTheAxisAndProjectBack) {
  const TelecentricCamera cam = testCamera(someCameraPose());
  const Vec3 axis = cam.worldFromCamera.vector({0, 0, 1});
  for (int i : {0, 7, 20, 39})
    for (int j : {0, 15, 29}) {
      const Ray r = cam.ray(i, j, {0.5, 0.5}, {0, 0});
      expectNear(r.direction, axis, 1e-12);
      // The chief ray of pixel centre (i + 1/2, j + 1/2) projects there at any depth.
      for (double alpha : {10.0, 133.0, 300.0}) {
        const Vec2 p = cam.project(r.at(alpha));
        EXPECT_NEAR(p.x, i + 0.5, 1e-9);
        EXPECT_NEAR(p.y, j + 0.5, 1e-9);
      }
    }
}

// Binning b x b: binned pixel (i, j) sees what the unbinned block b i .., b j ..
// sees, its chief ray the mean of theirs, also when the size is no multiple of
// b (the remainder is dropped on the right and bottom, as a sensor drops it).
TEST(TelecentricCamera, ABinnedPixelSeesItsBlock) {
  TelecentricCamera cam = testCamera(someCameraPose());
  for (const auto& [width, height, b] : {std::tuple{40, 30, 2}, std::tuple{41, 31, 2}, std::tuple{41, 32, 3}}) {
    cam.width = width, cam.height = height;
    const TelecentricCamera binned = cam.binned(b);
    EXPECT_EQ(binned.width, width / b);
    EXPECT_EQ(binned.height, height / b);
    EXPECT_NEAR(binned.objectPixel_mm(), b * cam.objectPixel_mm(), 1e-12);
    for (const auto& [i, j] : {std::pair{0, 0}, std::pair{binned.width - 1, binned.height - 1}, std::pair{3, 5}}) {
      Vec3 mean(0, 0, 0);
      for (int v = 0; v < b; ++v)
        for (int u = 0; u < b; ++u) mean += cam.ray(b * i + u, b * j + v, {0.5, 0.5}, {0, 0}).origin / (b * b);
      const Ray chief = binned.ray(i, j, {0.5, 0.5}, {0, 0});
      expectNear(chief.origin, mean, 1e-9);
      expectNear(chief.direction, cam.ray(0, 0, {0.5, 0.5}, {0, 0}).direction, 1e-12);
    }
  }
  EXPECT_TRUE(throwsError([&] { (void)cam.binned(0); }, Errc::InvalidArgument, {"binning 0"}));
}

TEST(TelecentricCamera, AllApertureSamplesOfAPixelMeetAtTheFocusedPoint) {
  const TelecentricCamera cam = testCamera(someCameraPose());
  const Rigid3 cameraFromWorld = cam.worldFromCamera.inverse();
  const double wz = 1 / (1 / cam.focalLength_mm - 1 / cam.imageDistance_mm);
  EXPECT_NEAR(cam.focusDistance_mm(), wz, 1e-12);
  for (auto [i, j] : {std::pair{3, 4}, std::pair{20, 15}, std::pair{38, 1}}) {
    const Vec2 off(0.25, 0.75);
    const Vec3 s(-(i + off.x - 0.5 * cam.width) * cam.pixelPitch_mm,
                 -(j + off.y - 0.5 * cam.height) * cam.pixelPitch_mm, -cam.imageDistance_mm);
    const Vec3 w(-(wz / cam.imageDistance_mm) * s.x, -(wz / cam.imageDistance_mm) * s.y, wz);
    for (const Vec2& a : {Vec2(0, 0), Vec2(1, 0), Vec2(0, -1), Vec2(0.6, 0.6), Vec2(-0.3, 0.2)}) {
      const Ray r = cam.ray(i, j, off, a);
      const Vec3 o = cameraFromWorld.point(r.origin), d = cameraFromWorld.vector(r.direction);
      EXPECT_NEAR(o.z, 0, 1e-9);  // starts on the lens plane
      const Vec3 atFocus = o + d * ((wz - o.z) / d.z);
      expectNear(atFocus, w, 1e-9);
      // Off the focal plane, the samples spread (depth of field): different points.
      if (a.x != 0 || a.y != 0) {
        const Vec3 chief = cameraFromWorld.point(cam.ray(i, j, off, {0, 0}).at(2 * wz));
        const Vec3 here = o + d * ((2 * wz - o.z) / d.z);
        EXPECT_GT((here - chief).length(), 1e-3);
      }
    }
  }
}

TEST(TelecentricCamera, AcceptanceAngleIsSetByTheStop) {
  const TelecentricCamera cam = testCamera(someCameraPose());
  const Vec3 axis = cam.worldFromCamera.vector({0, 0, 1});
  // A ray through the stop at radius a makes tan(angle) = a / f with the axis,
  // whatever the pixel: the rim of the stop gives exactly atan(D / 2f).
  const double acceptance = std::atan(0.5 * cam.stopDiameter_mm / cam.focalLength_mm);
  EXPECT_NEAR(cam.acceptanceHalfAngle_rad(), acceptance, 1e-15);
  for (auto [i, j] : {std::pair{0, 0}, std::pair{20, 15}, std::pair{39, 29}})
    for (double phi = 0; phi < 6.28; phi += 0.7) {
      for (double rho : {0.3, 0.8, 1.0}) {
        const Ray r = cam.ray(i, j, {0.1, 0.9}, {rho * std::cos(phi), rho * std::sin(phi)});
        const double angle = std::acos(std::clamp(r.direction.dot(axis), -1.0, 1.0));
        EXPECT_NEAR(std::tan(angle), rho * std::tan(acceptance), 1e-9);
        EXPECT_LE(angle, acceptance + 1e-12);
      }
    }
}

TEST(TelecentricCamera, LookingDownFromPointsAlongMinusZ) {
  TelecentricCamera cam = testCamera(TelecentricCamera::lookingDownFrom(300));
  const Ray r = cam.ray(20, 15, {0, 0}, {0, 0});  // the image centre
  expectNear(r.direction, {0, 0, -1}, 1e-15);
  expectNear(r.origin, {0, 0, 300}, 1e-12);
  // Camera y is world -y: world +x increases the column, world +y decreases the row.
  const Vec2 px = cam.project({1, 0, 0}), py = cam.project({0, 1, 0});
  EXPECT_GT(px.x, 20);
  EXPECT_LT(py.y, 15);
}

// ---- Light field sensor -------------------------------------------------

TEST(LightFieldSensor, RaysFollowTheHemisphereMapping) {
  LightFieldSensor sensor;
  sensor.geometry = {.spatialX = 4, .spatialY = 3, .angular = 5, .pixelPitch_mm = 0.02, .distance_mm = 0};
  sensor.worldFromSensor = Rigid3::translation({1, 2, -30}) * Rigid3::rotation({1, -0.5, 0.2}, 0.4);
  const Vec3 normal = sensor.worldFromSensor.vector({0, 0, 1});
  const int n = 5;
  const double e = n * 0.02;
  for (int ex = 0; ex < 4; ++ex)
    for (int ey = 0; ey < 3; ++ey) {
      const Vec3 centre = sensor.worldFromSensor.point({(ex + 0.5 - 2) * e, (ey + 0.5 - 1.5) * e, 0});
      // The centre pixel's centre sample looks along the plane normal.
      auto c = sensor.ray(ex * n + 2, ey * n + 2, {0.5, 0.5});
      ASSERT_TRUE(c.has_value());
      expectNear(c->direction, normal, 1e-12);
      expectNear(c->origin, centre, 1e-12);
      for (int u = 0; u < n; ++u)
        for (int v = 0; v < n; ++v)
          for (const Vec2& off : {Vec2(0.5, 0.5), Vec2(0.1, 0.8), Vec2(0, 0)}) {
            const double px = 2 * (u + off.x) / n - 1, py = 2 * (v + off.y) / n - 1;
            auto r = sensor.ray(ex * n + u, ey * n + v, off);
            if (px * px + py * py >= 1) {
              EXPECT_FALSE(r.has_value()) << u << "," << v;
              continue;
            }
            ASSERT_TRUE(r.has_value()) << u << "," << v;
            const Vec3 local = Vec3(-px, -py, std::sqrt(1 - px * px - py * py)).normalized();
            expectNear(r->direction, sensor.worldFromSensor.vector(local), 1e-12);
            expectNear(r->origin, centre, 1e-12);
          }
    }
  // Corner samples of an element are outside the disc.
  EXPECT_FALSE(sensor.ray(0, 0, {0, 0}).has_value());
  EXPECT_FALSE(sensor.ray(4, 4, {0.99, 0.99}).has_value());
}

// ---- Light field emitter ------------------------------------------------

// The packet renderer maps all lanes' rays into the emitter's plane at once
// and then looks each up (light_field_lanes.h); that must equal the one-ray
// emitter, LightField::radiance of the hit point and the reversed direction in
// the plane frame, to the bit, on and off the plane and for directions away
// from it, with either lookup.
TEST(LightFieldEmitter, PacketMappingGivesTheOneRayRadiance) {
  const LightFieldGeometry g{.spatialX = 6, .spatialY = 5, .angular = 8, .pixelPitch_mm = 0.05, .distance_mm = 0};
  LightField lf(g);
  cv::randu(lf.lensletImage(), 0.1, 1.0);
  const Rigid3 worldFromPlane = Rigid3::translation({3, -2, -40}) * Rigid3::rotation({0.3, 1, -0.2}, 0.7);
  const Rigid3 planeFromWorld = worldFromPlane.inverse();
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  RayLanes rays;
  double t[RayLanes::kSize];
  detail::LightFieldMapping mapping;
  int lit = 0, dark = 0;
  for (int round = 0; round < 300; ++round) {
    for (int k = 0; k < RayLanes::kSize; ++k) {
      // A point up to 1.3 x the plane's half extent from its centre, a direction
      // back towards the sensor over the whole sphere (a quarter away from the plane).
      const Vec3 q(1.3 * u(rng) * g.extentX_mm() / 2, 1.3 * u(rng) * g.extentY_mm() / 2, 0);
      const Vec3 back = Vec3(0.8 * u(rng), 0.8 * u(rng), u(rng) + 0.5).normalized();
      const Vec3 d = -worldFromPlane.vector(back);
      t[k] = 10 + 40 * (u(rng) + 1);
      rays.set(k, {worldFromPlane.point(q) - d * t[k], d});
    }
    detail::mapToLightField(rays, t, planeFromWorld, g, mapping);
    for (const LightFieldLookup lookup : {LightFieldLookup::Nearest, LightFieldLookup::Interpolated})
      for (int k = 0; k < RayLanes::kSize; ++k) {
        const Ray ray = rays.ray(k);
        const Vec3 q = planeFromWorld.point(ray.at(t[k]));  // as emittedRadiance
        const double expected = lf.radiance({q.x, q.y}, planeFromWorld.vector(-ray.direction), lookup);
        ASSERT_EQ(mapping.oneByOne[k], 0);
        const double mapped =
            mapping.seen[k] ? lf.radianceAt(mapping.sx[k], mapping.sy[k], {mapping.discX[k], mapping.discY[k]}, lookup)
                            : 0.0;
        EXPECT_EQ(mapped, expected) << "lane " << k << ", round " << round;
        (expected > 0 ? lit : dark) += 1;
      }
  }
  EXPECT_GT(lit, 2000);
  EXPECT_GT(dark, 2000);
}

}  // namespace
