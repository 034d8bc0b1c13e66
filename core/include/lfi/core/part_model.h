// SPDX-License-Identifier: Apache-2.0
#pragma once
// A part's optics as a calibration and the inspection trace them: where a
// ray that comes down the optical axis's direction at a lateral position
// leaves the part, and where it is at a depth inside it. The
// simulation implements it from a scene file's objects
// (lfi/sim/scene_part_model.h); the calibration through the part
// (controller/part_calibration.h) only asks.
//
// Frame: the part's own, the display frame's axes (x along the panel's
// columns, y up the panel, +z from the display towards the camera) with the
// origin at the part's reference point, the point whose height above the
// display plane is the bench's Δ. Millimetres.

#include "lfi/core/geometry.h"

#include <optional>
#include <string>

namespace lfi {

struct PartRay {
  Vec3 point;      // on the ray, below the part
  Vec3 direction;  // unit, z < 0 (towards the display)
};

class PartModel {
 public:
  virtual ~PartModel() = default;
  // The ray along −z at lateral position `x` above the part, once it has left
  // the part downwards (refracted at each surface, reflected only where
  // totally); empty when it misses the part, or the part absorbs it or sends
  // it back up. Safe to call from several threads at once.
  virtual std::optional<PartRay> exit(const Vec2& x) const = 0;
  // Where that ray crosses the plane at height `z` on its way down, through
  // the part's surfaces: the lateral position inside the part that the
  // camera pixel seeing `x` sees at that depth. Empty when the ray does not
  // reach the plane (it misses nothing: a ray that meets no part crosses at
  // `x` itself; it is absorbed, or turned back, above it). Thread-safe.
  virtual std::optional<Vec2> atDepth(const Vec2& x, double z) const = 0;
  // One line naming the model, for records.
  virtual std::string description() const = 0;
};

}  // namespace lfi
