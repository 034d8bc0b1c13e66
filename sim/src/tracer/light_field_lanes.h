// SPDX-License-Identifier: Apache-2.0
#pragma once
// Internal to lfi_sim: the light field emitter (docs/architecture.md) for a packet's lanes
// at once. Where each lane's ray meets the emitter's plane and from which
// direction — the hit point and the direction back towards the sensor in the
// plane frame, its disc position and the spatial coordinates — is computed for
// every lane in one vectorised pass, with the arithmetic of the one-ray
// emitter (emittedRadiance, LightField::radiance), so it gives the same bits.
// The table lookups follow, one lane at a time (LightField::radianceAt).

#include "lfi/core/light_field.h"
#include "lfi/sim/solid.h"

namespace lfi::sim::detail {

struct LightFieldMapping {
  static constexpr int kSize = RayLanes::kSize;
  alignas(64) double sx[kSize], sy[kSize];        // spatial coordinates, elements (LightField::radianceAt)
  alignas(64) double discX[kSize], discY[kSize];  // disc position of the direction back towards the sensor
  alignas(64) int seen[kSize];                    // 1: the direction points into the disc (else the radiance is 0)
  alignas(64) int oneByOne[kSize];  // 1: a direction of length below 2 DBL_MIN, left to the one-ray emitter
};

// Every lane's ray rays.ray(k) ends at t[k] on the plane of an emitter placed
// by objectFromWorld (its local frame is the light field's plane frame).
void mapToLightField(const RayLanes& rays, const double* t, const Rigid3& objectFromWorld, const LightFieldGeometry& g,
                     LightFieldMapping& out);

}  // namespace lfi::sim::detail
