// SPDX-License-Identifier: Apache-2.0
// Analytic solids and CSG against closed-form geometry: ray-sphere roots,
// spherical sag, normals of booleans, contains() versus intervals, bounds.
#include "lfi/sim/solid.h"

#include "lfi_test_support.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <numbers>
#include <random>

namespace {

using namespace lfi;
using namespace lfi::sim;

using lfi::testing_support::expectNear;

// z of a spherical face with its vertex at z0 and signed radius r (centre at
// z0 + r) at height h: the sag formula z0 + r - sign(r) sqrt(r^2 - h^2).
double faceZ(double z0, double r, double h) {
  if (r == 0) return z0;
  return z0 + r - std::copysign(std::sqrt(r * r - h * h), r);
}

TEST(Solid, SphereIntervalIsTheTwoRootsWithRadialNormals) {
  // Sphere of radius 5 centred at c; ray from p0 along unit d. Roots of
  // |p0 + t d - c|^2 = r^2: t = -b +- sqrt(b^2 - (|p0-c|^2 - r^2)), b = (p0-c).d.
  const Vec3 c(1, -2, 3);
  const double r = 5;
  auto s = Solid::sphere(r, Rigid3::translation(c) * Rigid3::rotation({0.3, 1, 0.2}, 0.8));
  const Vec3 p0(-10, 1, 2);
  const Vec3 d = Vec3(1, -0.1, 0.05).normalized();
  const Vec3 oc = p0 - c;
  const double b = oc.dot(d), cc = oc.dot(oc) - r * r;
  const double t0 = -b - std::sqrt(b * b - cc), t1 = -b + std::sqrt(b * b - cc);

  IntervalList list;
  s->intervals({p0, d}, list);
  ASSERT_EQ(list.size(), 1);
  EXPECT_NEAR(list[0].enter.t, t0, 1e-12);
  EXPECT_NEAR(list[0].exit.t, t1, 1e-12);
  expectNear(list[0].enter.normal, (p0 + d * t0 - c) / r, 1e-12);
  expectNear(list[0].exit.normal, (p0 + d * t1 - c) / r, 1e-12);
  // Outward: against the ray where it enters, along it where it leaves.
  EXPECT_LT(list[0].enter.normal.dot(d), 0);
  EXPECT_GT(list[0].exit.normal.dot(d), 0);

  // A line that misses (closest approach 6 > 5) has no interval.
  s->intervals({c + Vec3(0, 6, -20), Vec3(0, 0, 1)}, list);
  EXPECT_EQ(list.size(), 0);
}

TEST(Solid, LensAxialRayEntersAndExitsAtTheVertices) {
  const double tc = 7;
  auto lens = Solid::sphericalLens(100, -100, tc, 50);
  IntervalList list;
  lens->intervals({{0, 0, -50}, {0, 0, 1}}, list);
  ASSERT_EQ(list.size(), 1);
  EXPECT_NEAR(list[0].enter.t - 50, -tc / 2, 1e-12);
  EXPECT_NEAR(list[0].exit.t - 50, tc / 2, 1e-12);
  expectNear(list[0].enter.normal, {0, 0, -1}, 1e-12);
  expectNear(list[0].exit.normal, {0, 0, 1}, 1e-12);
}

// For several lens shapes, a ray parallel to the axis at height h enters and
// leaves where the sag formula puts the two faces, with the outward normals of
// the face spheres: (P - C1) / R1 at the front, -(P - C2) / R2 at the back.
TEST(Solid, LensOffAxisRayFollowsTheSagFormula) {
  struct Case {
    double r1, r2, tc, d;
  };
  for (const Case& k : {Case{100, -100, 7, 50}, Case{60, 0, 5, 40}, Case{-100, 0, 3, 50}, Case{-80, 120, 4, 40},
                        Case{50, 120, 6, 40} /* meniscus: concave back */, Case{0, 0, 5, 30}}) {
    SCOPED_TRACE(testing::Message() << "R1=" << k.r1 << " R2=" << k.r2 << " tc=" << k.tc << " D=" << k.d);
    auto lens = Solid::sphericalLens(k.r1, k.r2, k.tc, k.d);
    for (double h : {0.0, 3.0, 0.3 * k.d, 0.45 * k.d}) {
      SCOPED_TRACE(testing::Message() << "h=" << h);
      const Vec3 dir = Vec3(std::cos(0.7), std::sin(0.7), 0);  // the height direction in xy
      const Vec3 o = dir * h + Vec3(0, 0, -100);
      IntervalList list;
      lens->intervals({o, {0, 0, 1}}, list);
      ASSERT_EQ(list.size(), 1);
      const double zf = faceZ(-k.tc / 2, k.r1, h), zb = faceZ(k.tc / 2, k.r2, h);
      EXPECT_NEAR(sphericalFaceZ(k.r1, -k.tc / 2, h), zf, 1e-12);  // what file readers check lenses with
      EXPECT_NEAR(sphericalFaceZ(k.r2, k.tc / 2, h), zb, 1e-12);
      EXPECT_NEAR(o.z + list[0].enter.t, zf, 1e-9);
      EXPECT_NEAR(o.z + list[0].exit.t, zb, 1e-9);
      const Vec3 pf = o + Vec3(0, 0, list[0].enter.t), pb = o + Vec3(0, 0, list[0].exit.t);
      const Vec3 nf = k.r1 == 0 ? Vec3(0, 0, -1) : (pf - Vec3(0, 0, -k.tc / 2 + k.r1)) / k.r1;
      const Vec3 nb = k.r2 == 0 ? Vec3(0, 0, 1) : -(pb - Vec3(0, 0, k.tc / 2 + k.r2)) / k.r2;
      expectNear(list[0].enter.normal, nf, 1e-12);
      expectNear(list[0].exit.normal, nb, 1e-12);
    }
    // Beyond the rim there is no glass.
    IntervalList list;
    lens->intervals({{0.5 * k.d + 0.01, 0, -100}, {0, 0, 1}}, list);
    EXPECT_EQ(list.size(), 0);
  }
}

TEST(Solid, ConcaveFrontFaceIsThickerAtTheRim) {
  // Plano-concave, R1 = -100: thickness tc on the axis, tc + sag(h) at height h.
  const double r = -100, tc = 3, d = 50;
  auto lens = Solid::sphericalLens(r, 0, tc, d);
  double previous = 0;
  for (double h : {0.0, 5.0, 10.0, 20.0, 24.9}) {
    IntervalList list;
    lens->intervals({{0, h, -50}, {0, 0, 1}}, list);
    ASSERT_EQ(list.size(), 1);
    const double thickness = list[0].exit.t - list[0].enter.t;
    const double sag = std::abs(r) - std::sqrt(r * r - h * h);
    EXPECT_NEAR(thickness, tc + sag, 1e-9) << "h=" << h;
    EXPECT_GT(thickness, previous - 1e-12);
    previous = thickness;
  }
  EXPECT_GT(previous, tc + 3);  // sag at h = 24.9 is 3.13 mm
  // The vertex is a hollow: a point just in front of the front vertex, on the
  // axis, is air, while the same z near the rim is glass.
  EXPECT_FALSE(lens->contains({0, 0, -tc / 2 - 0.5}));
  EXPECT_TRUE(lens->contains({0, 24, -tc / 2 - 0.5}));
}

// A steep dome (R 5 on Ø10, vertex at z = -5) on a 10 mm thick lens with a
// flat back at z = 5: the dome's ball (centre z = 0) ends at z = 5 on the axis
// but at z = 1 at 4.9 mm from it, so the ball alone cut away the glass behind
// the dome (the lens came out a sphere). The face is its ball joined with the
// space beyond the rim's plane: a ray down the side meets the flat back.
TEST(Solid, ASteepConvexFaceKeepsTheGlassBehindIt) {
  const auto lens = Solid::sphericalLens(5, 0, 10, 10);  // front vertex at z = -5, rim plane at z = 0, back at z = 5
  EXPECT_TRUE(lens->contains({4.9, 0, 3}));
  EXPECT_TRUE(lens->contains({0, 0, 4.9}));
  EXPECT_FALSE(lens->contains({4.9, 0, -4}));  // in front of the dome near its rim: air
  IntervalList list;
  lens->intervals({{4.9, 0, 20}, {0, 0, -1}}, list);
  ASSERT_GE(list.size(), 1);
  EXPECT_NEAR(list[0].enter.t, 15, 1e-9);  // the flat back at z = 5
  expectNear(list[0].enter.normal, Vec3(0, 0, 1), 1e-12);
  EXPECT_TRUE(sphericalLensHolds(5, 0, 10, 10, {2, 0, 2.5}, 1));
  EXPECT_FALSE(sphericalLensHolds(5, 0, 10, 10, {4.5, 0, -4}, 0.2));
  // The reference lens keeps its plain convex faces (its balls reach nowhere near the other face).
  EXPECT_TRUE(Solid::sphericalLens(100, -100, 7, 50)->convex());
}

// A lens whose faces meet inside its diameter would silently be a narrower
// lens; one with a face flatter than a hemisphere cannot be made at all.
TEST(Solid, LensShapesThatCannotBeMadeAreNamed) {
  using Part = LensFault::Part;
  EXPECT_FALSE(sphericalLensFault(100, -100, 7, 50));
  EXPECT_FALSE(sphericalLensFault(0, 0, 5, 30));
  // Bi-convex R = 25.4 on Ø50: each face sags 25.4 - sqrt(25.4^2 - 25^2) = 20.91 mm at the rim.
  const double sag = 25.4 - std::sqrt(25.4 * 25.4 - 25.0 * 25.0);
  EXPECT_FALSE(sphericalLensFault(25.4, -25.4, 2 * sag + 1e-9, 50));  // a knife edge is still a lens
  const auto meet = sphericalLensFault(25.4, -25.4, 2 * sag - 0.1, 50);
  ASSERT_TRUE(meet);
  EXPECT_EQ(meet->part, Part::Edge);
  EXPECT_NE(meet->why.find("-0.1 mm thick"), std::string::npos) << meet->why;
  // A meniscus whose faces cross: both bend towards +z, the back one more.
  EXPECT_EQ(sphericalLensFault(-100, -26, 3, 50)->part, Part::Edge);
  EXPECT_EQ(sphericalLensFault(-100, -26, 30, 50), std::nullopt);
  EXPECT_EQ(sphericalLensFault(24, -100, 7, 50)->part, Part::FrontRadius);
  EXPECT_EQ(sphericalLensFault(100, 24.9, 7, 50)->part, Part::BackRadius);
  EXPECT_EQ(sphericalLensFault(100, -100, 0, 50)->part, Part::Thickness);
  EXPECT_EQ(sphericalLensFault(100, -100, 7, NAN)->part, Part::Diameter);
  EXPECT_TRUE(lfi::testing_support::throwsError([] { Solid::sphericalLens(25.4, -25.4, 10, 50); },
                                                lfi::Errc::InvalidArgument, {"lens: the faces meet"}));
}

// Whether a ball lies inside a lens: known answers for a bi-convex and a
// plano-concave lens, and every ball said to be inside is, on its surface,
// by contains().
TEST(Solid, LensHoldsABallExactlyWhenItLiesInsideTheGlass) {
  // Bi-convex R = ±51.5, 5 mm, Ø25.4 (the reference bench's lens).
  EXPECT_TRUE(sphericalLensHolds(51.5, -51.5, 5, 25.4, {0, 0, 0}, 2.4));
  EXPECT_FALSE(sphericalLensHolds(51.5, -51.5, 5, 25.4, {0, 0, 0}, 2.5));     // touches both vertices
  EXPECT_TRUE(sphericalLensHolds(51.5, -51.5, 5, 25.4, {11.5, 0, 0}, 1.0));   // 0.17 mm of glass all round
  EXPECT_FALSE(sphericalLensHolds(51.5, -51.5, 5, 25.4, {11.0, 0, 0}, 1.5));  // 11 + 1.5 < 12.7, but the faces cut it
  EXPECT_FALSE(sphericalLensHolds(51.5, -51.5, 5, 25.4, {0, 12.0, 0}, 0.8));  // through the edge cylinder
  // Plano-concave R1 = -100, 3 mm, Ø50: thinnest on the axis, 3 + 3.18 mm at the rim.
  EXPECT_TRUE(sphericalLensHolds(-100, 0, 3, 50, {0, 0, 0}, 1.4));
  EXPECT_FALSE(sphericalLensHolds(-100, 0, 3, 50, {0, 0, 0}, 1.6));
  EXPECT_TRUE(sphericalLensHolds(-100, 0, 3, 50, {24, 0, -3}, 0.5));     // below the vertex, in the thick rim
  EXPECT_FALSE(sphericalLensHolds(-100, 0, 3, 50, {24, 0, -4.5}, 0.5));  // through the front face

  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  int held = 0;
  for (const auto& [r1, r2, tc, d] :
       {std::tuple{51.5, -51.5, 5.0, 25.4}, std::tuple{-100.0, 0.0, 3.0, 50.0}, std::tuple{50.0, 120.0, 6.0, 40.0}}) {
    const auto lens = Solid::sphericalLens(r1, r2, tc, d);
    for (int i = 0; i < 400; ++i) {
      const Vec3 c(0.5 * d * u(rng), 0.5 * d * u(rng), 4 * u(rng));
      const double radius = 0.05 + 2 * std::abs(u(rng));
      if (!sphericalLensHolds(r1, r2, tc, d, c, radius)) continue;
      ++held;
      for (int k = 0; k < 64; ++k) {
        const Vec3 v = Vec3(u(rng), u(rng), u(rng)).normalized();
        ASSERT_TRUE(lens->contains(c + v * radius)) << "ball at " << c << " radius " << radius;
      }
    }
  }
  EXPECT_GT(held, 50);  // the property was exercised
}

TEST(Solid, DifferenceFlipsTheSubtractedNormals) {
  // A spherical shell: ball 10 minus ball 5. Along x from -20 the shell gives
  // [-10, -5] and [5, 10] (in x); at the cavity the outward normal of the
  // result points into the cavity, i.e. against B's outward normal.
  auto shell = Solid::combine(Solid::Kind::Difference, Solid::sphere(10), Solid::sphere(5));
  IntervalList list;
  shell->intervals({{-20, 0, 0}, {1, 0, 0}}, list);
  ASSERT_EQ(list.size(), 2);
  EXPECT_NEAR(list[0].enter.t, 10, 1e-12);
  EXPECT_NEAR(list[0].exit.t, 15, 1e-12);
  EXPECT_NEAR(list[1].enter.t, 25, 1e-12);
  EXPECT_NEAR(list[1].exit.t, 30, 1e-12);
  expectNear(list[0].enter.normal, {-1, 0, 0}, 1e-12);
  expectNear(list[0].exit.normal, {1, 0, 0}, 1e-12);    // at x = -5: B's outward is -x, flipped
  expectNear(list[1].enter.normal, {-1, 0, 0}, 1e-12);  // at x = +5: B's outward is +x, flipped
  expectNear(list[1].exit.normal, {1, 0, 0}, 1e-12);
  // Every boundary normal is outward: against the ray at entries, along it at exits.
  for (int i = 0; i < list.size(); ++i) {
    EXPECT_LT(list[i].enter.normal.x, 0);
    EXPECT_GT(list[i].exit.normal.x, 0);
  }
  // Union and intersection of the same balls: one interval each.
  auto both =
      Solid::combine(Solid::Kind::Intersection, Solid::sphere(10), Solid::sphere(5, Rigid3::translation({8, 0, 0})));
  both->intervals({{-20, 0, 0}, {1, 0, 0}}, list);
  ASSERT_EQ(list.size(), 1);
  EXPECT_NEAR(list[0].enter.t, 23, 1e-12);  // x = 3: B's surface, B's normal -x
  EXPECT_NEAR(list[0].exit.t, 30, 1e-12);   // x = 10: A's surface
  expectNear(list[0].enter.normal, {-1, 0, 0}, 1e-12);
  auto either = Solid::combine(Solid::Kind::Union, Solid::sphere(10), Solid::sphere(5, Rigid3::translation({8, 0, 0})));
  either->intervals({{-20, 0, 0}, {1, 0, 0}}, list);
  ASSERT_EQ(list.size(), 1);
  EXPECT_NEAR(list[0].enter.t, 10, 1e-12);  // x = -10: A's surface
  EXPECT_NEAR(list[0].exit.t, 33, 1e-12);   // x = 13: B's surface, B's normal +x
  expectNear(list[0].exit.normal, {1, 0, 0}, 1e-12);
}

// A ray tangent to a cut-out (the discriminant exactly 0: one point in
// common) passes through the part as if the cut-out were not there: one
// interval, not two touching at the tangent point (an exit and a re-entry at
// grazing incidence). The general merge (intervals) and the convex-difference
// kernel (nearestCrossings) agree.
TEST(Solid, ATangentCutOutLeavesTheIntervalWhole) {
  const auto part =
      Solid::combine(Solid::Kind::Difference, Solid::sphere(10), Solid::sphere(1, Rigid3::translation({0, 1, 0})));
  const Ray ray{{-20, 0, 0}, {1, 0, 0}};  // touches the cut-out's ball at (0, 0, 0)
  IntervalList list;
  part->intervals(ray, list);
  ASSERT_EQ(list.size(), 1);
  EXPECT_EQ(list[0].enter.t, 10);
  EXPECT_EQ(list[0].exit.t, 30);
  // The lane kernel (a difference of two convex solids): the first crossing past 11 is the far side, x = 10.
  RayLanes lanes;
  lanes.set(0, ray);
  double t[RayLanes::kSize];
  Vec3 normal[RayLanes::kSize];
  part->nearestCrossings(lanes, 1u, 11, t, normal);
  EXPECT_EQ(t[0], 30);
}

// Random lines through a few solids: sample points along each line; a point
// strictly inside an interval is contained, a point outside all intervals is
// not (away from the boundaries by more than the rounding).
TEST(Solid, ContainsAgreesWithIntervals) {
  std::vector<std::shared_ptr<const Solid>> solids = {
      Solid::sphericalLens(100, -100, 7, 50),
      Solid::sphericalLens(-80, 120, 4, 40),
      Solid::sphericalLens(50, 120, 6, 40),
      Solid::combine(Solid::Kind::Difference, Solid::sphere(10), Solid::sphere(5, Rigid3::translation({1, 2, 0}))),
      Solid::combine(Solid::Kind::Union, Solid::sphere(6),
                     Solid::cylinder(3, Rigid3::translation({2, 0, 0}) * Rigid3::rotation({1, 0, 0}, 1.0))),
  };
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> u(-1, 1);
  int inside = 0, outside = 0;
  for (const auto& solid : solids) {
    for (int line = 0; line < 200; ++line) {
      const Vec3 origin(30 * u(rng), 30 * u(rng), 30 * u(rng));
      const Vec3 target(15 * u(rng), 15 * u(rng), 5 * u(rng));
      const Vec3 dir = (target - origin).normalized();
      IntervalList list;
      solid->intervals({origin, dir}, list);
      for (int i = 0; i + 1 < list.size(); ++i) EXPECT_LT(list[i].exit.t, list[i + 1].enter.t);
      for (int k = 0; k <= 400; ++k) {
        const double t = -10 + k * 0.2;
        bool inInterval = false, nearBoundary = false;
        for (int i = 0; i < list.size(); ++i) {
          if (t > list[i].enter.t && t < list[i].exit.t) inInterval = true;
          if (std::abs(t - list[i].enter.t) < 1e-7 || std::abs(t - list[i].exit.t) < 1e-7) nearBoundary = true;
        }
        if (nearBoundary) continue;
        ASSERT_EQ(solid->contains(origin + dir * t), inInterval) << "line " << line << " t " << t;
        (inInterval ? inside : outside)++;
      }
    }
  }
  EXPECT_GT(inside, 10000);  // the lines really cross the solids
  EXPECT_GT(outside, 10000);
}

// An intersection of convex primitives takes a flattened single-interval path;
// wrapping each primitive in a union with itself forces the general event
// merge. Both must give the same interval and normals on random lines,
// including placed (rotated, shifted) primitives and half spaces.
TEST(Solid, ConvexIntersectionFastPathMatchesTheGeneralMerge) {
  using K = Solid::Kind;
  auto general = [](std::shared_ptr<const Solid> s) { return Solid::combine(K::Union, s, s); };
  const Rigid3 tilt = Rigid3::translation({1, -2, 0.5}) * Rigid3::rotation({1, 1, 0}, 0.3);
  const Rigid3 flip = Rigid3::translation({0, 0, 3}) * Rigid3::rotation({1, 0, 0}, std::numbers::pi);
  const auto cyl = Solid::cylinder(12, tilt), ball = Solid::sphere(14, Rigid3::translation({0, 1, 2}));
  const auto below = Solid::halfSpace(Rigid3::translation({0, 0, 4})), above = Solid::halfSpace(flip);
  const auto fast = Solid::combine(K::Intersection, Solid::combine(K::Intersection, cyl, ball),
                                   Solid::combine(K::Intersection, below, above), Rigid3::rotation({0, 1, 0}, 0.2));
  const auto slow =
      Solid::combine(K::Intersection, Solid::combine(K::Intersection, general(cyl), general(ball)),
                     Solid::combine(K::Intersection, general(below), general(above)), Rigid3::rotation({0, 1, 0}, 0.2));
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  int hits = 0;
  for (int line = 0; line < 2000; ++line) {
    const Vec3 origin(40 * u(rng), 40 * u(rng), 40 * u(rng));
    const Vec3 dir = (Vec3(10 * u(rng), 10 * u(rng), 4 * u(rng)) - origin).normalized();
    IntervalList a, b;
    fast->intervals({origin, dir}, a);
    slow->intervals({origin, dir}, b);
    ASSERT_EQ(a.size(), b.size()) << "line " << line;
    if (a.size() == 0) continue;
    ++hits;
    EXPECT_NEAR(a[0].enter.t, b[0].enter.t, 1e-12);
    EXPECT_NEAR(a[0].exit.t, b[0].exit.t, 1e-12);
    expectNear(a[0].enter.normal, b[0].enter.normal, 1e-12);
    expectNear(a[0].exit.normal, b[0].exit.normal, 1e-12);
  }
  EXPECT_GT(hits, 200);
}

// nearestCrossings (many rays at once; lane-parallel for convex intersections)
// finds the same first crossing beyond tMin as the intervals do, for the
// first n rays of an array or for any set of lanes of a RayLanes (sparse or
// dense, so both the one-ray and the lane-parallel path); lanes not asked for
// are not written.
TEST(Solid, NearestCrossingsAgreeWithIntervals) {
  const std::vector<std::shared_ptr<const Solid>> solids = {
      Solid::sphericalLens(100, -100, 7, 50),  // convex kernel
      Solid::sphericalLens(50, 120, 6, 40),    // concave back: general merge
      Solid::combine(Solid::Kind::Intersection, Solid::cylinder(8), Solid::halfSpace(Rigid3::translation({0, 0, 2})),
                     Rigid3::rotation({0, 1, 0}, 0.4)),  // unbounded along some lines
      // Differences of convex solids (cut-outs): the lane-parallel difference.
      Solid::combine(Solid::Kind::Difference, Solid::sphericalLens(100, -100, 7, 50),
                     Solid::sphere(8, Rigid3::translation({10, 0, 4}))),
      Solid::combine(Solid::Kind::Difference, Solid::sphericalLens(100, -100, 7, 50),
                     Solid::sphere(6, Rigid3::translation({-5, 3, -2})),
                     Rigid3::translation({1, -2, 3}) * Rigid3::rotation({1, 0.2, 0}, 0.3)),
      Solid::combine(Solid::Kind::Difference, Solid::sphere(15, Rigid3::translation({1, 2, 0})),
                     Solid::cylinder(5, Rigid3::rotation({1, 0, 0}, 1.2))),  // a hole through a ball
      Solid::combine(Solid::Kind::Difference, Solid::sphere(20),
                     Solid::combine(Solid::Kind::Intersection, Solid::cylinder(8, Rigid3::rotation({0, 1, 0}, 0.7)),
                                    Solid::halfSpace(Rigid3::translation({0, 0, 2})))),  // B unbounded and convex
  };
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  int found = 0;
  constexpr double kUnwritten = -12345;
  for (size_t which = 0; which < solids.size(); ++which)
    for (int batch = 0; batch < 300; ++batch) {
      const Solid* solid = solids[which].get();
      const double tMin = batch % 3 == 0 ? 1e-6 : 30 * (u(rng) + 1);  // also from inside
      Ray rays[Solid::kBatch];
      RayLanes lanes;
      double t[Solid::kBatch];
      Vec3 normal[Solid::kBatch];
      for (int k = 0; k < Solid::kBatch; ++k) {
        const Vec3 origin(40 * u(rng), 40 * u(rng), 40 * u(rng));
        rays[k] = {origin, (Vec3(20 * u(rng), 20 * u(rng), 4 * u(rng)) - origin).normalized()};
        lanes.set(k, rays[k]);
        t[k] = kUnwritten;
      }
      std::uint32_t asked;
      if (batch % 2 == 0) {  // the first n rays
        const int n = 1 + batch / 2 % Solid::kBatch;
        solid->nearestCrossings(n, rays, tMin, t, normal);
        asked = (1u << n) - 1;
      } else {  // random lanes, from one to all
        asked = std::uniform_int_distribution<std::uint32_t>(1, (1u << Solid::kBatch) - 1)(rng);
        if (batch % 4 == 1) asked &= asked >> 3 | 1;  // sparser
        solid->nearestCrossings(lanes, asked, tMin, t, normal);
      }
      for (int k = 0; k < Solid::kBatch; ++k) {
        if (!(asked >> k & 1)) {
          EXPECT_EQ(t[k], kUnwritten) << "batch " << batch << " lane " << k;
          continue;
        }
        IntervalList list;
        solid->intervals(rays[k], list);
        double expected = std::numeric_limits<double>::infinity();
        Vec3 expectedNormal;
        for (int i = list.size() - 1; i >= 0; --i)
          for (const SurfacePoint* s : {&list[i].exit, &list[i].enter})
            if (s->t > tMin && std::isfinite(s->t)) expected = s->t, expectedNormal = s->normal;
        ASSERT_EQ(std::isfinite(t[k]), std::isfinite(expected)) << "batch " << batch << " ray " << k;
        if (!std::isfinite(expected)) continue;
        ++found;
        // The lane-parallel kernels round as the one-ray code does.
        EXPECT_EQ(t[k], expected) << "solid " << which << ", batch " << batch << " ray " << k;
        EXPECT_EQ(normal[k], expectedNormal) << "solid " << which << ", batch " << batch << " ray " << k;
      }
    }
  EXPECT_GT(found, 1000);
}

TEST(Solid, LensBoundsAreFiniteAndEncloseTheLens) {
  struct Lens {
    double r1, r2, thickness, diameter;
  };
  for (const Lens& l : {Lens{100, -100, 7, 50}, Lens{-100, 0, 3, 50}, Lens{0, 0, 5, 30}}) {
    const Bounds b = Solid::sphericalLens(l.r1, l.r2, l.thickness, l.diameter)->bounds();
    ASSERT_TRUE(b.finite());
    // Both vertices, and both faces' rims all round (for the plano-concave lens
    // the lowest glass is at the rim: -1.5 - 3.175 mm), lie inside the box.
    const double rim = l.diameter / 2;
    std::vector<Vec3> points = {{0, 0, -l.thickness / 2}, {0, 0, l.thickness / 2}};
    for (int k = 0; k < 8; ++k) {
      const double a = std::numbers::pi * k / 4, x = rim * std::cos(a), y = rim * std::sin(a);
      points.push_back({x, y, sphericalFaceZ(l.r1, -l.thickness / 2, rim)});
      points.push_back({x, y, sphericalFaceZ(l.r2, l.thickness / 2, rim)});
    }
    for (const Vec3& p : points) {
      EXPECT_TRUE(p.x >= b.lo.x - 1e-9 && p.x <= b.hi.x + 1e-9 && p.y >= b.lo.y - 1e-9 && p.y <= b.hi.y + 1e-9 &&
                  p.z >= b.lo.z - 1e-9 && p.z <= b.hi.z + 1e-9)
          << "R " << l.r1 << ", " << l.r2 << ": (" << p.x << ", " << p.y << ", " << p.z << ") outside the box";
    }
  }
}

// A flat window built by hand: a cylinder between two half spaces, one of them
// turned over by a rotation of pi (whose matrix carries ~1e-16 residues).
TEST(Solid, SlabFromHalfSpacesIsBounded) {
  auto below = Solid::halfSpace(Rigid3::translation({0, 0, 2}));  // z <= 2
  auto above =
      Solid::halfSpace(Rigid3::translation({0, 0, -2}) * Rigid3::rotation({1, 0, 0}, std::numbers::pi));  // z >= -2
  auto slab = Solid::combine(Solid::Kind::Intersection, Solid::cylinder(10),
                             Solid::combine(Solid::Kind::Intersection, below, above));
  const Bounds b = slab->bounds();
  ASSERT_TRUE(b.finite());
  EXPECT_NEAR(b.lo.z, -2, 1e-9);
  EXPECT_NEAR(b.hi.z, 2, 1e-9);
  EXPECT_NEAR(b.lo.x, -10, 1e-9);
  EXPECT_NEAR(b.hi.y, 10, 1e-9);
  IntervalList list;
  slab->intervals({{1, 1, 10}, {0, 0, -1}}, list);
  ASSERT_EQ(list.size(), 1);
  EXPECT_NEAR(list[0].enter.t, 8, 1e-12);
  EXPECT_NEAR(list[0].exit.t, 12, 1e-12);
  expectNear(list[0].enter.normal, {0, 0, 1}, 1e-12);
  expectNear(list[0].exit.normal, {0, 0, -1}, 1e-12);
}

}  // namespace
