// SPDX-License-Identifier: Apache-2.0
#pragma once
// Vectors and rigid transforms. Units: millimetres and radians. World frame:
// +z is the optical axis from the illumination side towards the camera.
// Transforms are named <to>From<from> (worldFromCamera) and compose right to
// left: worldFromPart = worldFromBench * benchFromPart.

#include <Imath/ImathVec.h>

#include <array>
#include <cmath>

namespace lfi {

using Vec2 = Imath::V2d;
using Vec3 = Imath::V3d;

// p' = R p + t with R a rotation (row-major, column-vector convention).
struct Rigid3 {
  std::array<double, 9> r{1, 0, 0, 0, 1, 0, 0, 0, 1};
  Vec3 t{0, 0, 0};

  Vec3 rotate(const Vec3& v) const {
    return {r[0] * v.x + r[1] * v.y + r[2] * v.z, r[3] * v.x + r[4] * v.y + r[5] * v.z,
            r[6] * v.x + r[7] * v.y + r[8] * v.z};
  }
  Vec3 point(const Vec3& p) const { return rotate(p) + t; }
  Vec3 vector(const Vec3& v) const { return rotate(v); }
  bool isIdentity() const { return r == Rigid3().r && t == Vec3(0, 0, 0); }

  Rigid3 inverse() const {
    Rigid3 inv;
    inv.r = {r[0], r[3], r[6], r[1], r[4], r[7], r[2], r[5], r[8]};
    inv.t = -inv.rotate(t);
    return inv;
  }
  friend Rigid3 operator*(const Rigid3& a, const Rigid3& b) {
    Rigid3 c;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        c.r[3 * i + j] = a.r[3 * i] * b.r[j] + a.r[3 * i + 1] * b.r[3 + j] + a.r[3 * i + 2] * b.r[6 + j];
    c.t = a.point(b.t);
    return c;
  }

  static Rigid3 translation(const Vec3& t) {
    Rigid3 x;
    x.t = t;
    return x;
  }
  // Rotation by angle (rad) about a unit axis (Rodrigues).
  static Rigid3 rotation(const Vec3& axis, double angle) {
    const Vec3 k = axis.normalized();
    const double c = std::cos(angle), s = std::sin(angle), v = 1 - c;
    Rigid3 x;
    x.r = {c + k.x * k.x * v,       k.x * k.y * v - k.z * s, k.x * k.z * v + k.y * s,
           k.y * k.x * v + k.z * s, c + k.y * k.y * v,       k.y * k.z * v - k.x * s,
           k.z * k.x * v - k.y * s, k.z * k.y * v + k.x * s, c + k.z * k.z * v};
    return x;
  }
};

}  // namespace lfi
