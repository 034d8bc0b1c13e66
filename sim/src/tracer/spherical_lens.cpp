// SPDX-License-Identifier: Apache-2.0
// The spherical lens: its faces' shape, the checks of a lens's dimensions, and
// the lens as a solid (an edge cylinder cut by its two faces).

#include "lfi/sim/solid.h"

#include "lfi/core/error.h"

#include <cmath>
#include <memory>
#include <numbers>
#include <optional>
#include <utility>

namespace lfi::sim {

double sphericalFaceZ(double radius, double z0, double r) {
  if (radius == 0) return z0;
  return z0 + radius - std::copysign(std::sqrt(radius * radius - r * r), radius);
}

namespace {

// Whether a convex face's whole ball would cut into the glass from behind: its
// far side reaches past the other face somewhere inside the diameter (a steep
// dome on a thick lens). Such a face is then its ball joined with the half
// space beyond its rim's plane, which is the glass above (below) the cap.
bool farSideCutsGlass(double r1, double r2, double tc, double semi, bool front) {
  const double r = front ? r1 : r2;
  if (front ? !(r > 0) : !(r < 0)) return false;  // flat or concave
  for (int i = 0; i <= 64; ++i) {
    const double x = semi * i / 64, far = std::sqrt(r * r - x * x);
    if (front ? sphericalFaceZ(r2, tc / 2, x) > -tc / 2 + r + far : sphericalFaceZ(r1, -tc / 2, x) < tc / 2 + r - far)
      return true;
  }
  return false;
}

}  // namespace

std::optional<LensFault> sphericalLensFault(double r1, double r2, double tc, double diameter) {
  using Part = LensFault::Part;
  if (!(tc > 0) || !std::isfinite(tc))
    return LensFault{Part::Thickness, fmt::format("thickness {} must be finite and > 0", tc)};
  if (!(diameter > 0) || !std::isfinite(diameter))
    return LensFault{Part::Diameter, fmt::format("diameter {} must be finite and > 0", diameter)};
  const double semi = diameter / 2;
  for (const auto& [r, part] : {std::pair{r1, Part::FrontRadius}, std::pair{r2, Part::BackRadius}}) {
    if (!std::isfinite(r)) return LensFault{part, fmt::format("radius {} must be finite (0 for a flat face)", r)};
    if (r != 0 && std::abs(r) < semi)
      return LensFault{
          part, fmt::format("|radius| {} is smaller than the semi-diameter {} (0 for a flat face)", std::abs(r), semi)};
  }
  if (const double edge = sphericalFaceZ(r2, tc / 2, semi) - sphericalFaceZ(r1, -tc / 2, semi); edge < 0)
    return LensFault{Part::Edge, fmt::format("the faces meet inside the diameter {}: the edge would be {:.4g} mm "
                                             "thick (centre thickness {}); make the lens thicker or narrower",
                                             diameter, edge, tc)};
  return std::nullopt;
}

bool sphericalLensHolds(double r1, double r2, double tc, double diameter, const Vec3& c, double radius) {
  if (std::hypot(c.x, c.y) + radius >= diameter / 2) return false;  // the edge cylinder
  // Each face as sphericalLens() builds it; `glassUp`: the glass lies towards +z of it (the front face).
  auto holds = [&](double r, double z0, bool glassUp) {
    const double side = glassUp ? 1 : -1;  // the glass is where side * (z - plane) > 0
    if (r == 0) return side * (c.z - z0) > radius;
    const double d = (c - Vec3(0, 0, z0 + r)).length();
    const double sag = std::abs(r) - std::sqrt(r * r - diameter * diameter / 4);
    if (glassUp ? r > 0 : r < 0)  // convex: inside the face's sphere (or beyond the rim's plane, if it is joined)
      return d + radius < std::abs(r) ||
             (farSideCutsGlass(r1, r2, tc, diameter / 2, glassUp) && side * (c.z - (z0 + side * sag)) > radius);
    // Concave: outside the face's sphere, and on the glass side of the rim's plane.
    return d - radius > std::abs(r) && side * (c.z - (z0 - side * sag)) > radius;
  };
  return holds(r1, -tc / 2, true) && holds(r2, tc / 2, false);
}

std::shared_ptr<Solid> Solid::sphericalLens(double r1, double r2, double tc, double diameter) {
  if (const auto fault = sphericalLensFault(r1, r2, tc, diameter)) fail(Errc::InvalidArgument, "lens: {}", fault->why);
  // The half space on the glass side of the plane z = z0.
  auto glassSide = [](double z0, bool glassTowardsPlusZ) {
    Rigid3 x = glassTowardsPlusZ ? Rigid3::rotation({1, 0, 0}, std::numbers::pi) : Rigid3();
    x.t = {0, 0, z0};
    return halfSpace(x);
  };
  std::shared_ptr<const Solid> body = cylinder(diameter / 2);
  // A face with its vertex at z0; the glass lies towards +z for the front face.
  auto applyFace = [&](double radius, double z0, bool glassTowardsPlusZ) {
    if (radius == 0) {
      body = combine(Kind::Intersection, body, glassSide(z0, glassTowardsPlusZ));
      return;
    }
    auto ball = sphere(std::abs(radius), Rigid3::translation({0, 0, z0 + radius}));
    const bool convex = glassTowardsPlusZ ? radius > 0 : radius < 0;
    const double sag = std::abs(radius) - std::sqrt(radius * radius - diameter * diameter / 4);
    if (convex) {  // (a ball that would cut the glass from behind is joined with the space beyond its rim)
      body = combine(
          Kind::Intersection, body,
          farSideCutsGlass(r1, r2, tc, diameter / 2, glassTowardsPlusZ)
              ? combine(Kind::Union, ball, glassSide(glassTowardsPlusZ ? z0 + sag : z0 - sag, glassTowardsPlusZ))
              : ball);
      return;
    }
    // Concave: the glass is outside the ball, bounded by the plane of the rim.
    body = combine(Kind::Difference, body, ball);
    body = combine(Kind::Intersection, body, glassSide(glassTowardsPlusZ ? z0 - sag : z0 + sag, glassTowardsPlusZ));
  };
  applyFace(r1, -tc / 2, true);
  applyFace(r2, tc / 2, false);
  return std::const_pointer_cast<Solid>(body);
}

}  // namespace lfi::sim
