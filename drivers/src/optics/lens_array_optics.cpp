// SPDX-License-Identifier: Apache-2.0
#include "lfi/drivers/optics/lens_array_optics.h"

#include <cmath>

namespace lfi {

LensArrayOptics::LensArrayOptics(const DisplayInfo& info)
    : lattice_(info.optics.packing, info.optics.arrayPitch_mm, info.optics.rotation_rad,
               {info.optics.arrayOffsetX_mm, info.optics.arrayOffsetY_mm}),
      pinhole_(info.optics.type == OpticsType::PinholeArray),
      gap_(info.optics.gap_mm),
      power_(pinhole_ ? 0 : 1 / info.optics.focalLength_mm),
      fill_(info.optics.fillFactor),
      radius_(0.5 * info.optics.pinholeDiameter_mm) {}

bool LensArrayOptics::insideAperture(const Vec2& q, const Vec2& centre) const {
  if (pinhole_) return (q - centre).length2() <= radius_ * radius_;
  return lattice_.insideCell(q, centre, fill_);
}

DisplayRay LensArrayOptics::rayFromPanelPoint(const Vec2& p) const {
  const Vec2 c = lattice_.nearestCentre(p);
  const Vec2 t = (c - p) / gap_;
  return {{c.x, c.y, 0}, Vec3(t.x, t.y, 1).normalized()};
}

std::optional<Vec2> LensArrayOptics::panelPointFromRay(const Vec2& q, const Vec3& d) const {
  if (!(d.z > 0) || !std::isfinite(d.x) || !std::isfinite(d.y)) return std::nullopt;
  if (!(std::abs(q.x) < 1e9 && std::abs(q.y) < 1e9)) return std::nullopt;  // (NaN too): off any panel
  const Vec2 c = lattice_.nearestCentre(q);
  if (!insideAperture(q, c)) return std::nullopt;
  const Vec2 p = c - gap_ / d.z * Vec2(d.x, d.y);
  if (!lattice_.insideCell(p, c, 1)) return std::nullopt;  // under another lens: outside the view cone
  return p;
}

std::optional<Vec2> LensArrayOptics::sourceOfRay(const Vec2& q, const Vec3& d) const {
  // Back through a thin lens at q = c + h: the ray came in with slope t + h / f.
  if (!(d.z > 0)) return std::nullopt;
  const Vec2 c = lattice_.nearestCentre(q);
  if (!insideAperture(q, c)) return std::nullopt;
  return q - gap_ * power_ * (q - c) - gap_ / d.z * Vec2(d.x, d.y);
}

double LensArrayOptics::viewCone_rad() const {
  return 2 * std::atan(lattice_.inradius_mm() / gap_);
}

}  // namespace lfi
