// SPDX-License-Identifier: Apache-2.0
// Scene::intersect against brute force: the nearest hit over every object,
// computed from the solids' exact intervals and the rectangles' planes.
#include "lfi/sim/scene.h"
#include "lfi/core/error.h"
#include "lfi/sim/render.h"
#include "lfi/sim/scene_file.h"

#include "lfi_test_support.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <span>

namespace {

using namespace lfi;
using namespace lfi::sim;
using lfi::testing_support::throwsError;

constexpr double kInf = std::numeric_limits<double>::infinity();

// Nearest t > tMin of one object, and its normal (world frame).
double bruteForce(const Object& obj, const Ray& world, double tMin, Vec3& normal) {
  const Rigid3 objectFromWorld = obj.worldFromObject.inverse();
  const Ray local{objectFromWorld.point(world.origin), objectFromWorld.vector(world.direction)};
  double best = kInf;
  if (const auto* solid = std::get_if<std::shared_ptr<const Solid>>(&obj.shape)) {
    IntervalList list;
    (*solid)->intervals(local, list);
    for (int i = 0; i < list.size(); ++i)
      for (const SurfacePoint* s : {&list[i].enter, &list[i].exit})
        if (s->t > tMin && s->t < best && std::isfinite(s->t)) {
          best = s->t;
          normal = obj.worldFromObject.vector(s->normal);
        }
  } else if (const auto* rect = std::get_if<Rectangle>(&obj.shape)) {
    if (local.direction.z != 0) {
      const double t = -local.origin.z / local.direction.z;
      const Vec3 p = local.at(t);
      if (t > tMin && std::abs(p.x) < rect->sizeX / 2 && std::abs(p.y) < rect->sizeY / 2) {
        best = t;
        normal = obj.worldFromObject.vector({0, 0, 1});
      }
    }
  }
  return best;
}

TEST(Scene, IntersectReturnsTheNearestHitAmongSolidsAndRectangles) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<Object> objects;
  // Interleave solids and rectangles along z, closer than the solids are thick, so
  // that rays cross several of each and rectangles lie inside solids' bounding boxes.
  for (int k = 0; k < 12; ++k) {
    const Vec3 at(4 * u(rng), 4 * u(rng), -20 + 3.5 * k);
    if (k % 3 == 1) {
      objects.push_back(
          {.name = "rect" + std::to_string(k),
           .shape = Rectangle{6 + 2 * u(rng), 6 + 2 * u(rng)},
           .worldFromObject = Rigid3::translation(at) * Rigid3::rotation({u(rng), u(rng), 1}, 0.3 * u(rng)),
           .emission = LambertianEmission{1}});
    } else if (k % 3 == 0) {
      objects.push_back({.name = "ball" + std::to_string(k),
                         .shape = std::shared_ptr<const Solid>(Solid::sphere(3 + u(rng))),
                         .worldFromObject = Rigid3::translation(at),
                         .material = Dielectric{}});
    } else {
      objects.push_back(
          {.name = "lens" + std::to_string(k),
           .shape = std::shared_ptr<const Solid>(Solid::sphericalLens(20, -30, 3, 10)),
           .worldFromObject = Rigid3::translation(at) * Rigid3::rotation({u(rng), u(rng), 1}, 0.5 * u(rng)),
           .material = Dielectric{}});
    }
  }
  const Scene scene(objects);
  int hits = 0, mismatches = 0;
  for (int i = 0; i < 20000; ++i) {
    const Vec3 origin(6 * u(rng), 6 * u(rng), 40 * u(rng));
    const Vec3 dir = Vec3(0.3 * u(rng), 0.3 * u(rng), u(rng) > 0 ? 1 : -1).normalized();
    const Ray ray{origin, dir};
    double best = kInf;
    int bestObject = -1;
    Vec3 bestNormal;
    for (size_t k = 0; k < objects.size(); ++k) {
      Vec3 n;
      const double t = bruteForce(objects[k], ray, 1e-6, n);
      if (t < best) best = t, bestObject = static_cast<int>(k), bestNormal = n;
    }
    const Hit hit = scene.intersect(ray);
    if (bestObject < 0) {
      EXPECT_FALSE(hit.valid());
      continue;
    }
    ++hits;
    // Solids and rectangles are intersected exactly, in double precision; skip
    // rays that meet two surfaces within rounding of each other.
    double second = kInf;
    for (size_t k = 0; k < objects.size(); ++k) {
      Vec3 n;
      const double t = bruteForce(objects[k], ray, 1e-6, n);
      if (static_cast<int>(k) != bestObject && t < second) second = t;
    }
    if (second - best < 1e-9) continue;
    if (!hit.valid() || hit.object != bestObject || std::abs(hit.t - best) > 1e-9) {
      if (++mismatches <= 5)
        ADD_FAILURE() << "ray " << i << ": expected object " << bestObject << " at t=" << best << ", got " << hit.object
                      << " at t=" << hit.t;
      continue;
    }
    EXPECT_LT((hit.normal - bestNormal).length(), 1e-12);
  }
  EXPECT_EQ(mismatches, 0);
  EXPECT_GT(hits, 5000);
}

// The farthest a scene file places a sensor (kFarthest_mm, 1 km) costs the
// tracer no precision that matters: a ray from there aimed at a ball of
// radius 10 mm, or at a mesh beside it, meets what the same ray started
// 30 mm short of it meets, at the same point within 1 µm, in one- and
// sixteen-ray queries alike. (Embree's copy of the ray starts near the
// scene: from the sensor, a mesh's t, in float, was off by 0.06 mm.)
TEST(Scene, RaysFromTheFarthestSensorMeetWhatNearbyRaysMeet) {
  TriangleMesh tetra;
  tetra.vertices = {{0, 0, 2}, {3, 0, -1}, {-2, 2.5, -1}, {-2, -2.5, -1}};
  tetra.triangles = {{0, 1, 2}, {0, 2, 3}, {0, 3, 1}, {1, 3, 2}};
  const std::vector<Object> objects = {
      {.name = "ball",
       .shape = std::shared_ptr<const Solid>(Solid::sphere(10)),
       .worldFromObject = Rigid3::translation({20, 0, -20}),
       .material = Dielectric{}},
      {.name = "tetra", .shape = tetra, .worldFromObject = Rigid3::translation({-20, 0, 0}), .material = Absorber{}}};
  const Scene scene(objects);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  int far = 0;
  for (int n = 0; n < 2000; ++n) {
    const Vec3 target = n % 2 == 0 ? Vec3(20, 0, -20) + Vec3(u(rng), u(rng), u(rng)).normalized() * 9.99
                                   : Vec3(-20, 0, 0) + Vec3(u(rng), u(rng), u(rng)) * 0.5;
    const Vec3 d = Vec3(u(rng), u(rng), u(rng)).normalized();
    // (30 mm back: outside both parts, and within twice the scene's radius, so that Embree takes it as it is.)
    const Ray near{target - d * 30, d}, distant{target - d * kFarthest_mm, d};
    if (scene.intersect(distant, Scene::kTMin, kFarthest_mm - 30).valid()) continue;  // (the other part lies before)
    const Hit a = scene.intersect(near), b = scene.intersect(distant);
    Hit packed[1];
    scene.intersect(std::span<const Ray>(&distant, 1), packed);
    ASSERT_EQ(a.object, b.object) << "ray " << n;
    ASSERT_EQ(packed[0].object, b.object) << "ray " << n;
    if (!a.valid()) continue;
    ++far;
    EXPECT_LT((a.point - b.point).length(), 1e-3) << "ray " << n;
    EXPECT_LT((distant.at(packed[0].t) - a.point).length(), 1e-3) << "ray " << n;
  }
  EXPECT_GT(far, 1500);  // the ball's rays all hit; the tetrahedron's most
}

// The packet query answers exactly as the one-ray query, whatever the packet
// size and whichever mix of shapes: convex solids (their SIMD kernel), a CSG
// difference (the general merge), a triangle mesh and rectangles.
TEST(Scene, PacketIntersectEqualsOneRayIntersect) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-1, 1);
  TriangleMesh tetra;
  tetra.vertices = {{0, 0, 2}, {3, 0, -1}, {-2, 2.5, -1}, {-2, -2.5, -1}};
  tetra.triangles = {{0, 1, 2}, {0, 2, 3}, {0, 3, 1}, {1, 3, 2}};
  const auto cut = Solid::combine(Solid::Kind::Difference, Solid::sphericalLens(40, -40, 5, 16),
                                  Solid::sphere(2, Rigid3::translation({3, 0, 2})));
  std::vector<Object> objects = {
      {.name = "lens",
       .shape = std::shared_ptr<const Solid>(Solid::sphericalLens(20, -30, 3, 10)),
       .worldFromObject = Rigid3::translation({0, 0, 10}) * Rigid3::rotation({1, 0, 0}, 0.2),
       .material = Dielectric{}},
      {.name = "cut lens",
       .shape = std::shared_ptr<const Solid>(cut),
       .worldFromObject = Rigid3::translation({1, 0, -5}),
       .material = Dielectric{}},
      {.name = "tetra", .shape = tetra, .worldFromObject = Rigid3::translation({2, 1, 3}), .material = Dielectric{}},
      {.name = "back",
       .shape = Rectangle{30, 30},
       .worldFromObject = Rigid3::translation({0, 0, -20}),
       .emission = LambertianEmission{1}},
  };
  const Scene scene(objects);
  int hits = 0;
  for (int packet = 0; packet < 2000; ++packet) {
    const size_t n = 1 + static_cast<size_t>(packet % static_cast<int>(Scene::kPacket));
    // Half the packets coherent (one pixel's aperture samples), half scattered.
    const bool coherent = packet % 2 == 0;
    const Vec3 centre(8 * u(rng), 8 * u(rng), 30);
    std::vector<Ray> rays;
    for (size_t k = 0; k < n; ++k) {
      const Vec3 origin =
          coherent ? centre + Vec3(0.2 * u(rng), 0.2 * u(rng), 0) : Vec3(10 * u(rng), 10 * u(rng), 30 * u(rng));
      const Vec3 dir =
          coherent ? Vec3(0.01 * u(rng), 0.01 * u(rng), -1).normalized() : Vec3(u(rng), u(rng), u(rng)).normalized();
      rays.push_back({origin, dir});
    }
    std::vector<Hit> packed(n);
    scene.intersect(rays, packed);
    for (size_t k = 0; k < n; ++k) {
      const Hit one = scene.intersect(rays[k]);
      ASSERT_EQ(packed[k].object, one.object) << "packet " << packet << " ray " << k;
      if (!one.valid()) continue;
      ++hits;
      // Solids and rectangles: the same double-precision arithmetic, to the
      // bit. The mesh: Embree's float packet and single-ray kernels may round
      // differently.
      if (std::holds_alternative<TriangleMesh>(objects[static_cast<size_t>(one.object)].shape)) {
        EXPECT_NEAR(packed[k].t, one.t, 1e-5);
        EXPECT_LT((packed[k].normal - one.normal).length(), 1e-5);
      } else {
        EXPECT_EQ(packed[k].t, one.t) << "packet " << packet << " ray " << k;
        EXPECT_EQ(packed[k].normal, one.normal) << "packet " << packet << " ray " << k;
      }
    }
  }
  EXPECT_GT(hits, 5000);
  // The structure-of-arrays form, for any set of lanes: the lanes asked for
  // get the one-ray query's hits (point = ray.at(t)), the others no hit.
  int laneHits = 0;
  for (int packet = 0; packet < 500; ++packet) {
    Scene::RayPacket rays;
    for (int k = 0; k < static_cast<int>(Scene::kPacket); ++k) {
      rays.rays.set(k, {Vec3(10 * u(rng), 10 * u(rng), 30 * u(rng)), Vec3(u(rng), u(rng), u(rng)).normalized()});
      rays.inside[k] = rays.on[k] = -1;
    }
    const auto lanes = std::uniform_int_distribution<std::uint32_t>(0, (1u << Scene::kPacket) - 1)(rng);
    Scene::HitPacket out;
    scene.intersect(rays, lanes, out);
    for (int k = 0; k < static_cast<int>(Scene::kPacket); ++k) {
      const Hit one = scene.intersect(rays.rays.ray(k));
      if (!(lanes >> k & 1)) {
        EXPECT_EQ(out.object[k], -1) << "packet " << packet << " lane " << k;
        continue;
      }
      ASSERT_EQ(out.object[k], one.object) << "packet " << packet << " lane " << k;
      if (!one.valid()) continue;
      ++laneHits;
      if (std::holds_alternative<TriangleMesh>(objects[static_cast<size_t>(one.object)].shape)) {
        EXPECT_NEAR(out.t[k], one.t, 1e-5);
        EXPECT_LT((out.normal(k) - one.normal).length(), 1e-5);
      } else {
        EXPECT_EQ(out.t[k], one.t) << "packet " << packet << " lane " << k;
        EXPECT_EQ(out.normal(k), one.normal) << "packet " << packet << " lane " << k;
      }
    }
  }
  EXPECT_GT(laneHits, 1000);
  std::vector<Ray> tooMany(Scene::kPacket + 1, Ray{{0, 0, 30}, {0, 0, -1}});
  std::vector<Hit> out(tooMany.size());
  EXPECT_TRUE(throwsError([&] { scene.intersect(tooMany, out); }, Errc::InvalidArgument,
                          {"17 rays for 17 hits", "at most 16 at once"}));
}

}  // namespace

namespace {

// A rectangle in front of a solid's surface but inside its bounding box: the
// rectangle is the nearest hit whichever order Embree visits the geometries in.
TEST(Scene, RectangleInsideASolidsBoundsInFrontOfItsSurface) {
  for (bool solidFirst : {true, false}) {
    std::vector<Object> objects;
    Object ball{.name = "ball", .shape = std::shared_ptr<const Solid>(Solid::sphere(5)), .material = Dielectric{}};
    Object rect{.name = "rect",
                .shape = Rectangle{8, 8},
                .worldFromObject = Rigid3::translation({0, 0, 4.9}),
                .emission = LambertianEmission{1}};
    objects.push_back(solidFirst ? ball : rect);
    objects.push_back(solidFirst ? rect : ball);
    const Scene scene(std::move(objects));
    const int rectIndex = solidFirst ? 1 : 0;
    // At x = 3.9 the sphere's surface is at z = 3.13, the rectangle at z = 4.9.
    const Hit hit = scene.intersect({{3.9, 0, 20}, {0, 0, -1}});
    ASSERT_TRUE(hit.valid());
    EXPECT_EQ(hit.object, rectIndex) << "solid first: " << solidFirst;
    EXPECT_NEAR(hit.t, 15.1, 1e-12);
    // And from below, the sphere comes first.
    const Hit below = scene.intersect({{3.9, 0, -20}, {0, 0, 1}});
    ASSERT_TRUE(below.valid());
    EXPECT_EQ(below.object, 1 - rectIndex);
    EXPECT_NEAR(below.t, 20 - std::sqrt(25 - 3.9 * 3.9), 1e-9);
  }
}

}  // namespace

namespace {

// A solid whose bounds meet no other object's answers the rays hinted to start
// inside it without a traversal. The answer must be the one-ray query's: for
// rays inside it, rays in its box but outside it, rays that leave it without a
// crossing, and wrong hints; solids sharing their box with another object are
// never isolated.
TEST(Scene, IsolatedSolidsAnswerHintedRaysAsTheOneRayQuery) {
  std::vector<Object> objects = {
      {.name = "lone lens",
       .shape = std::shared_ptr<const Solid>(Solid::sphericalLens(20, -30, 3, 10)),
       .worldFromObject = Rigid3::translation({0, 0, 2}) * Rigid3::rotation({1, 0, 0}, 0.2),
       .material = Dielectric{}},
      {.name = "lens with a slide",
       .shape = std::shared_ptr<const Solid>(Solid::sphericalLens(20, -30, 3, 10)),
       .worldFromObject = Rigid3::translation({0, 0, 20}),
       .material = Dielectric{}},
      {.name = "slide",
       .shape = Rectangle{4, 4},
       .worldFromObject = Rigid3::translation({0, 0, 21.4}),
       .material = Absorber{}},
      {.name = "glass ball",
       .shape = std::shared_ptr<const Solid>(Solid::sphere(4)),
       .worldFromObject = Rigid3::translation({15, 0, 0}),
       .material = Dielectric{}},
      {.name = "bubble",
       .shape = std::shared_ptr<const Solid>(Solid::sphere(1)),
       .worldFromObject = Rigid3::translation({15.5, 0, 0}),
       .material = Dielectric{1.0}},
      {.name = "back",
       .shape = Rectangle{60, 60},
       .worldFromObject = Rigid3::translation({0, 0, -20}),
       .emission = LambertianEmission{1}},
  };
  const Scene scene(objects);
  EXPECT_TRUE(scene.isolated(0));
  for (int k = 1; k < 6; ++k) EXPECT_FALSE(scene.isolated(k)) << objects[static_cast<size_t>(k)].name;

  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  int direct = 0;
  for (int packet = 0; packet < 3000; ++packet) {
    const size_t n = 1 + static_cast<size_t>(packet % static_cast<int>(Scene::kPacket));
    std::vector<Ray> rays;
    std::vector<Scene::RayStart> starts;
    for (size_t k = 0; k < n; ++k) {
      // Around each solid's box (some rays start just outside), any direction,
      // hinted with the right solid, another one or none.
      const int around = packet % 3 == 0 ? 0 : packet % 3 == 1 ? 1 : 3;
      const Vec3 centre = objects[static_cast<size_t>(around)].worldFromObject.t;
      const Vec3 origin = centre + Vec3(5.5 * u(rng), 5.5 * u(rng), 3 * u(rng));
      rays.push_back({origin, Vec3(u(rng), u(rng), u(rng)).normalized()});
      const double pick = u(rng);
      starts.push_back({pick < 0.5 ? around : pick < 0.75 ? -1 : static_cast<int>(rng() % 6), -1});
    }
    std::vector<Hit> hinted(n), plain(n);
    scene.intersect(rays, hinted, Scene::kTMin, starts);
    scene.intersect(rays, plain);
    for (size_t k = 0; k < n; ++k) {
      const Hit one = scene.intersect(rays[k]);
      ASSERT_EQ(hinted[k].object, one.object) << "packet " << packet << " ray " << k;
      ASSERT_EQ(plain[k].object, one.object) << "packet " << packet << " ray " << k;
      if (!one.valid()) continue;
      direct += starts[k].inside == 0 && one.object == 0;
      // The same double-precision arithmetic however the crossing was found.
      EXPECT_EQ(hinted[k].t, one.t);
      EXPECT_EQ(hinted[k].normal, one.normal);
      EXPECT_EQ(hinted[k].point, one.point);
    }
  }
  EXPECT_GT(direct, 3000);
  std::vector<Ray> rays(2, Ray{{0, 0, 2}, {0, 0, -1}});
  std::vector<Hit> hits(2);
  const std::vector<Scene::RayStart> tooFew{{}};
  EXPECT_TRUE(throwsError([&] { scene.intersect(rays, hits, Scene::kTMin, tooFew); }, Errc::InvalidArgument,
                          {"2 rays for 2 hits and 1 starts"}));
  // A start naming no object is an error that names the lane, not a read out of bounds.
  const int objectCount = static_cast<int>(objects.size());
  for (const Scene::RayStart bad : {Scene::RayStart{objectCount, -1}, Scene::RayStart{-1, objectCount},
                                    Scene::RayStart{-2, -1}, Scene::RayStart{0, 1000}}) {
    const std::vector<Scene::RayStart> starts{{}, bad};
    try {
      scene.intersect(rays, hits, Scene::kTMin, starts);
      ADD_FAILURE() << "no error for inside " << bad.inside << ", on " << bad.on;
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), Errc::InvalidArgument);
      EXPECT_NE(std::string(e.what()).find("lane 1"), std::string::npos) << e.what();
    }
  }
}

}  // namespace

namespace {

// Rectangles are exact: a ray meets one wherever it crosses the closed
// rectangle, on its diagonal too (where a two-triangle quad may leak), at the
// plane's distance to double precision, and misses it just beyond an edge.
// Two surfaces in the same place (an emitter and a mask laid on it): the hit
// is the lower object index's, in the one-ray and the packet query alike,
// whichever order the scene lists them and whatever else the packet holds.
TEST(Scene, CoincidentSurfacesGoToTheLowerObjectIndex) {
  for (const bool maskFirst : {true, false}) {
    const Object mask{.name = "mask", .shape = Rectangle{40, 40}, .material = Absorber{}};
    const Object light{
        .name = "light", .shape = Rectangle{40, 40}, .material = Absorber{}, .emission = LambertianEmission{1.0}};
    const Object sphere{
        .name = "sphere", .shape = Solid::sphere(5, Rigid3::translation({0, 0, 20})), .material = Absorber{}};
    const Scene scene(maskFirst ? std::vector<Object>{mask, light, sphere} : std::vector<Object>{light, mask, sphere});
    std::vector<Ray> rays;
    for (int k = 0; k < 16; ++k)  // down onto the plane, every other one past the sphere first
      rays.push_back({{-15.0 + 2 * k, (k % 2) * 0.3, 50}, Vec3(0.01 * k, 0.02, -1).normalized()});
    std::vector<Hit> hits(rays.size());
    scene.intersect(rays, hits);
    for (size_t k = 0; k < rays.size(); ++k) {
      const Hit one = scene.intersect(rays[k]);
      if (!one.valid() || one.object == 2) continue;  // the sphere's
      EXPECT_EQ(one.object, 0) << "lane " << k << (maskFirst ? ", mask first" : ", light first");
      EXPECT_EQ(hits[k].object, 0) << "lane " << k << (maskFirst ? ", mask first" : ", light first");
    }
  }
}

TEST(Scene, RectanglesAreExactAndWatertight) {
  const Rigid3 placed = Rigid3::translation({1, -2, -30}) * Rigid3::rotation({1, 1, 0}, 0.3);
  const Scene scene({{.name = "plate", .shape = Rectangle{40, 20}, .worldFromObject = placed, .material = Absorber{}}});
  const Rigid3 local = placed.inverse();
  std::mt19937_64 rng(8);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int i = 0; i < 2000; ++i) {
    // A point on the diagonal from (-20, -10) to (20, 10), or just inside or outside an edge.
    const double s = u(rng);
    const int kind = i % 3;
    const double eps = 1e-9;
    const Vec3 q = kind == 0   ? Vec3(20 * s, 10 * s, 0)
                   : kind == 1 ? Vec3(20 - eps, 10 * s, 0)
                               : Vec3(20 * s, 10 + eps, 0);
    const Vec3 target = placed.point(q);
    const Vec3 dir = Vec3(0.2 * u(rng), 0.2 * u(rng), -1).normalized();
    const double distance = 50;
    const Ray ray{target - dir * distance, dir};
    const Hit hit = scene.intersect(ray);
    if (kind == 2) {
      EXPECT_FALSE(hit.valid()) << "ray " << i << " passes 1e-9 mm beyond the edge";
      continue;
    }
    ASSERT_TRUE(hit.valid()) << "ray " << i << " crosses the rectangle at (" << q.x << ", " << q.y << ")";
    EXPECT_NEAR(hit.t, distance, 1e-11);
    EXPECT_NEAR(local.point(hit.point).z, 0, 1e-11);
    EXPECT_NEAR((hit.normal - placed.vector({0, 0, 1})).length(), 0, 1e-15);
  }
}

}  // namespace

namespace {

// Rays that leave a convex solid skip it in the packet query (a line meets a
// convex solid once): the hits must still be the one-ray query's, for paths
// that refract through lenses, reflect off them outside and inside, and a
// sphere that is not isolated.
TEST(Scene, RaysLeavingAConvexSolidGetTheOneRayQuerysHits) {
  const Scene scene(std::vector<Object>{{.name = "lens",
                                         .shape = std::shared_ptr<const Solid>(Solid::sphericalLens(20, -30, 3, 10)),
                                         .worldFromObject = Rigid3::rotation({1, 0, 0}, 0.2),
                                         .material = Dielectric{}},
                                        {.name = "ball",
                                         .shape = std::shared_ptr<const Solid>(Solid::sphere(3)),
                                         .worldFromObject = Rigid3::translation({2, 0, -6}),
                                         .material = Dielectric{1.7}},
                                        {.name = "slab",
                                         .shape = Rectangle{20, 20},
                                         .worldFromObject = Rigid3::translation({0, 0, -8}),
                                         .material = Absorber{}},
                                        {.name = "back",
                                         .shape = Rectangle{60, 60},
                                         .worldFromObject = Rigid3::translation({0, 0, -20}),
                                         .emission = LambertianEmission{1}}});
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<Ray> rays;
  std::vector<Scene::RayStart> starts;
  int leaving = 0;
  for (int path = 0; path < 3000; ++path) {
    Ray ray{{6 * u(rng), 6 * u(rng), 20}, Vec3(0.2 * u(rng), 0.2 * u(rng), -1).normalized()};
    Scene::RayStart start;
    for (int bounce = 0; bounce < 6; ++bounce) {
      rays.push_back(ray);
      starts.push_back(start);
      const Hit hit = scene.intersect(ray);
      if (!hit.valid() || scene.surface(hit.object).kind != Surface::Kind::Dielectric) break;
      const bool entering = ray.direction.dot(hit.normal) < 0;
      const Vec3 facing = entering ? hit.normal : -hit.normal;
      const double ior = scene.surface(hit.object).ior;
      Vec3 out;
      const bool refracted = u(rng) > -0.6 && refract(ray.direction, facing, entering ? 1 / ior : ior, out);
      if (!refracted) out = reflect(ray.direction, facing);
      start = {refracted == entering ? hit.object : -1, hit.object};  // (the two solids do not nest)
      leaving += start.on >= 0 && start.inside != start.on;
      ray = {hit.point, out};
    }
  }
  EXPECT_GT(leaving, 1000);
  for (size_t begin = 0; begin < rays.size(); begin += Scene::kPacket) {
    const size_t n = std::min(Scene::kPacket, rays.size() - begin);
    std::vector<Hit> hits(n);
    scene.intersect(std::span(rays).subspan(begin, n), hits, Scene::kTMin, std::span(starts).subspan(begin, n));
    for (size_t k = 0; k < n; ++k) {
      const Hit one = scene.intersect(rays[begin + k]);
      ASSERT_EQ(hits[k].object, one.object) << "ray " << begin + k;
      if (!one.valid()) continue;
      EXPECT_EQ(hits[k].t, one.t);
      EXPECT_EQ(hits[k].normal, one.normal);
    }
  }
}

}  // namespace
