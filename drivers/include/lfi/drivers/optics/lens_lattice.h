// SPDX-License-Identifier: Apache-2.0
#pragma once
// The centres of a 2-D lens (or pinhole) array in the display's lens plane: a
// square or hexagonal lattice of pitch P, rotated by θ against the panel rows,
// with lens (0, 0) at offset o from the panel centre (display frame, mm):
//   square:    c(i, j) = o + R(θ) (i P, j P)
//   hexagonal: c(i, j) = o + R(θ) ((i + j / 2) P, j P √3 / 2)
// Each lens owns its Voronoi cell (a square, or a regular hexagon with two
// vertical sides at θ = 0): the points nearer its centre than any other's.

#include "lfi/core/geometry.h"
#include "lfi/drivers/display.h"

namespace lfi {

class LensLattice {
 public:
  LensLattice(LensPacking packing, double pitch_mm, double rotation_rad, const Vec2& offset_mm);

  // The centre of the lens whose cell holds `p` (ties: any of the nearest).
  Vec2 nearestCentre(const Vec2& p) const;
  // Whether `p` lies in the cell of the lens at `centre` shrunk about its centre
  // by `fraction` (0 < fraction <= 1): the clear aperture of a lens with that
  // fill factor.
  bool insideCell(const Vec2& p, const Vec2& centre, double fraction) const;
  double pitch_mm() const { return pitch_; }
  LensPacking packing() const { return packing_; }
  // The distance from a centre to the nearest point of its cell's boundary
  // (P/2 both ways) and to the farthest (P/√2 square, P/√3 hexagonal).
  double inradius_mm() const { return 0.5 * pitch_; }
  double circumradius_mm() const;

 private:
  LensPacking packing_;
  double pitch_;
  Vec2 offset_;
  double cos_, sin_;
  // Lattice vectors in the array's own frame (before the rotation).
  Vec2 a1_, a2_;
  double inverse_[4];  // the inverse of [a1 a2], row-major
};

}  // namespace lfi
