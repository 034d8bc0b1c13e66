#include "lfi/drivers/optics/pinhole_array_optics.h"

#include <cmath>

namespace lfi {

PinholeArrayOptics::PinholeArrayOptics(const DisplayInfo& info)
    : lattice_(info.optics.packing, info.optics.arrayPitch_mm, info.optics.rotation_rad,
               {info.optics.arrayOffsetX_mm, info.optics.arrayOffsetY_mm}),
      gap_(info.optics.gap_mm), radius_(0.5 * info.optics.pinholeDiameter_mm) {}

DisplayRay PinholeArrayOptics::rayFromPanelPoint(const Vec2& p) const {
  const Vec2 c = lattice_.nearestCentre(p);
  const Vec2 t = (c - p) / gap_;
  return {{c.x, c.y, 0}, Vec3(t.x, t.y, 1).normalized()};
}

std::optional<Vec2> PinholeArrayOptics::panelPointFromRay(const Vec2& q, const Vec3& d) const {
  if (!(d.z > 0) || !std::isfinite(d.x) || !std::isfinite(d.y)) return std::nullopt;
  if (!(std::abs(q.x) < 1e9 && std::abs(q.y) < 1e9)) return std::nullopt;  // (NaN too): off any panel
  const Vec2 c = lattice_.nearestCentre(q);
  if (!((q - c).length2() <= radius_ * radius_)) return std::nullopt;
  const Vec2 p = c - gap_ / d.z * Vec2(d.x, d.y);
  if (!lattice_.insideCell(p, c, 1)) return std::nullopt;  // under another pinhole: outside the view cone
  return p;
}

std::optional<Vec2> PinholeArrayOptics::sourceOfRay(const Vec2& q, const Vec3& d) const {
  if (!(d.z > 0)) return std::nullopt;
  const Vec2 c = lattice_.nearestCentre(q);
  if (!((q - c).length2() <= radius_ * radius_)) return std::nullopt;
  return q - gap_ / d.z * Vec2(d.x, d.y);
}

double PinholeArrayOptics::viewCone_rad() const { return 2 * std::atan(lattice_.inradius_mm() / gap_); }

}  // namespace lfi
