// SPDX-License-Identifier: Apache-2.0
#include "lfi/core/geometry.h"

#include <gtest/gtest.h>

#include <numbers>
#include <random>

namespace {

using lfi::Rigid3;
using lfi::Vec3;

constexpr double kTol = 1e-12;

void expectNear(const Vec3& actual, const Vec3& expected, double tol = kTol) {
  EXPECT_NEAR(actual.x, expected.x, tol);
  EXPECT_NEAR(actual.y, expected.y, tol);
  EXPECT_NEAR(actual.z, expected.z, tol);
}

// A transform with a rotation about an oblique axis and a translation, so no
// component is trivially zero.
Rigid3 generalTransform() {
  return Rigid3::translation({3.5, -1.25, 7.0}) * Rigid3::rotation(Vec3(1, 2, -0.5), 0.73);
}

TEST(Rigid3, QuarterTurnAboutZMapsXToY) {
  const Rigid3 r = Rigid3::rotation({0, 0, 1}, std::numbers::pi / 2);
  expectNear(r.vector({1, 0, 0}), {0, 1, 0});
  expectNear(r.vector({0, 1, 0}), {-1, 0, 0});
  expectNear(r.vector({0, 0, 1}), {0, 0, 1});
  // Rodrigues normalises the axis: a scaled axis gives the same rotation.
  expectNear(Rigid3::rotation({0, 0, 5}, std::numbers::pi / 2).vector({1, 0, 0}), {0, 1, 0});
}

TEST(Rigid3, PointAppliesTranslationButVectorDoesNot) {
  const Rigid3 t = Rigid3::translation({1, 2, 3});
  expectNear(t.point({0, 0, 0}), {1, 2, 3});
  expectNear(t.vector({1, 0, 0}), {1, 0, 0});
}

TEST(Rigid3, InverseComposesToIdentity) {
  const Rigid3 a = generalTransform();
  const Rigid3 inv = a.inverse();
  for (const Rigid3& product : {a * inv, inv * a}) {
    for (int i = 0; i < 9; ++i) EXPECT_NEAR(product.r[i], (i % 4 == 0) ? 1.0 : 0.0, kTol) << "r[" << i << "]";
    expectNear(product.t, {0, 0, 0});
  }
  const Vec3 p{-4.0, 0.5, 2.25};
  expectNear(inv.point(a.point(p)), p);
  expectNear(a.point(inv.point(p)), p);
}

TEST(Rigid3, CompositionAppliesRightOperandFirst) {
  const Rigid3 shift = Rigid3::translation({1, 0, 0});
  const Rigid3 turn = Rigid3::rotation({0, 0, 1}, std::numbers::pi / 2);
  // shift * turn: turn first (x -> y), then shift by +x.
  expectNear((shift * turn).point({1, 0, 0}), {1, 1, 0});
  // turn * shift: shift first (x -> 2x), then turn (2x -> 2y).
  expectNear((turn * shift).point({1, 0, 0}), {0, 2, 0});
  // And in general (a * b)(p) == a(b(p)).
  const Rigid3 a = generalTransform();
  const Rigid3 b = Rigid3::translation({-2, 0.5, 1}) * Rigid3::rotation({0.3, -1, 0.2}, -1.9);
  const Vec3 p{0.7, -3.1, 4.4};
  expectNear((a * b).point(p), a.point(b.point(p)));
}

TEST(Rigid3, RotationPreservesLengthsAndAngles) {
  std::mt19937 rng(12345);
  std::uniform_real_distribution<double> uni(-10, 10);
  for (int trial = 0; trial < 100; ++trial) {
    const Rigid3 r = Rigid3::rotation({uni(rng), uni(rng), uni(rng)}, uni(rng));
    const Vec3 v{uni(rng), uni(rng), uni(rng)}, w{uni(rng), uni(rng), uni(rng)};
    EXPECT_NEAR(r.vector(v).length(), v.length(), 1e-12 * v.length());
    EXPECT_NEAR(r.vector(v).dot(r.vector(w)), v.dot(w), 1e-11 * v.length() * w.length());
    // Proper rotation, not a reflection: the cross product is preserved too.
    expectNear(r.vector(v).cross(r.vector(w)), r.vector(v.cross(w)), 1e-10);
  }
}

TEST(Rigid3, RotationByAngleTurnsVectorByThatAngleAboutAxis) {
  const Vec3 axis = Vec3(1, 1, 1).normalized();
  const double angle = 0.4;
  const Vec3 v{1, 0, 0};
  const Vec3 rotated = Rigid3::rotation(axis, angle).vector(v);
  // The component along the axis is unchanged; the perpendicular part turns by `angle`.
  EXPECT_NEAR(rotated.dot(axis), v.dot(axis), kTol);
  const Vec3 before = v - axis * v.dot(axis), after = rotated - axis * rotated.dot(axis);
  EXPECT_NEAR(std::acos(before.dot(after) / (before.length() * after.length())), angle, 1e-9);
  // Right-handed: the turn is positive about the axis.
  EXPECT_GT(before.cross(after).dot(axis), 0);
}

}  // namespace
