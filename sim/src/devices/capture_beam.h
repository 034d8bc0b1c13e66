// SPDX-License-Identifier: Apache-2.0
#pragma once
// Internal to lfi_sim: the scene of a reference capture, the parts of a scene
// file under the collimated capture beam (a parallel emitter facing -z at
// world z = beamDistance), shared by the light field and the panel captures.

#include "lfi/sim/scene.h"

#include <numbers>
#include <utility>
#include <vector>

namespace lfi::sim::detail {

// `size`: the beam's side, mm (wide enough for every ray that leaves the parts).
inline Scene captureScene(std::vector<Object> parts, double ambientIor, double beamDistance_mm,
                          double beamHalfAngle_rad, double size_mm) {
  Rigid3 facingDown = Rigid3::rotation({1, 0, 0}, std::numbers::pi);
  facingDown.t = {0, 0, beamDistance_mm};
  parts.push_back({"collimated beam", Rectangle{size_mm, size_mm}, facingDown, Absorber{},
                   ParallelEmission{1.0, beamHalfAngle_rad}});
  return Scene(std::move(parts), ambientIor);
}

}  // namespace lfi::sim::detail
