// SPDX-License-Identifier: Apache-2.0
#pragma once
// Internal to lfi_sim: what building solids (solid.cpp) and meeting them with
// rays (solid_crossings.cpp) share.

#include "lfi/sim/solid.h"

#include <limits>

namespace lfi::sim::detail {

inline constexpr double kInf = std::numeric_limits<double>::infinity();

inline bool isPrimitive(Solid::Kind kind) {
  return kind == Solid::Kind::Sphere || kind == Solid::Kind::Cylinder || kind == Solid::Kind::HalfSpace;
}

}  // namespace lfi::sim::detail
