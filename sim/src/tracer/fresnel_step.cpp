// SPDX-License-Identifier: Apache-2.0
#include "fresnel_step.h"

#include "simd.h"

namespace lfi::sim::detail {

LFI_SIMD_CLONES void fresnelLanes(const RayLanes& __restrict rays, const Scene::HitPacket& __restrict hits,
                                  FresnelLanes& __restrict out) {
  for (int k = 0; k < FresnelLanes::kSize; ++k) fresnelLane(rays, hits, out, k);
}

}  // namespace lfi::sim::detail
