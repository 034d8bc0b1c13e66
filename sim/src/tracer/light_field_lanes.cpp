// SPDX-License-Identifier: Apache-2.0
#include "light_field_lanes.h"

#include "simd.h"

#include <cmath>
#include <limits>

namespace lfi::sim::detail {

LFI_SIMD_CLONES void mapToLightField(const RayLanes& __restrict rays, const double* __restrict t,
                                     const Rigid3& objectFromWorld, const LightFieldGeometry& g,
                                     LightFieldMapping& __restrict out) {
  const auto& r = objectFromWorld.r;
  const Vec3 shift = objectFromWorld.t;
  const double e = g.elementPitch_mm(), halfX = 0.5 * g.spatialX, halfY = 0.5 * g.spatialY;
  constexpr double kTiny = 2 * std::numeric_limits<double>::min();   // below it Imath's length() rescales
  constexpr double kHuge = std::numeric_limits<double>::infinity();  // (discFromDirection refuses it)
  for (int k = 0; k < LightFieldMapping::kSize; ++k) {
    const double dx = rays.dx[k], dy = rays.dy[k], dz = rays.dz[k];
    // The hit point, ray.at(t), and Rigid3::point / Rigid3::vector of it and of -d.
    const double px = rays.ox[k] + dx * t[k], py = rays.oy[k] + dy * t[k], pz = rays.oz[k] + dz * t[k];
    const double qx = r[0] * px + r[1] * py + r[2] * pz + shift.x, qy = r[3] * px + r[4] * py + r[5] * pz + shift.y;
    const double ux = r[0] * -dx + r[1] * -dy + r[2] * -dz, uy = r[3] * -dx + r[4] * -dy + r[5] * -dz,
                 uz = r[6] * -dx + r[7] * -dy + r[8] * -dz;
    // LightField::discFromDirection, then radiance()'s disc test and spatial coordinates.
    const double length2 = ux * ux + uy * uy + uz * uz, length = std::sqrt(length2);
    const double discX = -ux / length, discY = -uy / length;
    out.oneByOne[k] = length2 < kTiny;
    out.seen[k] = length > 0 && length < kHuge && uz > 0 && discX * discX + discY * discY < 1;
    out.discX[k] = discX, out.discY[k] = discY;
    out.sx[k] = qx / e + halfX, out.sy[k] = qy / e + halfY;
  }
}

}  // namespace lfi::sim::detail
