// SPDX-License-Identifier: Apache-2.0
#include "lfi/drivers/optics/lens_lattice.h"

#include <cmath>
#include <limits>

namespace lfi {

LensLattice::LensLattice(LensPacking packing, double pitch_mm, double rotation_rad, const Vec2& offset_mm)
    : packing_(packing),
      pitch_(pitch_mm),
      offset_(offset_mm),
      cos_(std::cos(rotation_rad)),
      sin_(std::sin(rotation_rad)) {
  a1_ = {pitch_, 0};
  a2_ = packing == LensPacking::Square ? Vec2(0, pitch_) : Vec2(0.5 * pitch_, 0.5 * std::sqrt(3.0) * pitch_);
  const double det = a1_.x * a2_.y - a2_.x * a1_.y;
  inverse_[0] = a2_.y / det;
  inverse_[1] = -a2_.x / det;
  inverse_[2] = -a1_.y / det;
  inverse_[3] = a1_.x / det;
}

double LensLattice::circumradius_mm() const {
  return packing_ == LensPacking::Square ? pitch_ / std::sqrt(2.0) : pitch_ / std::sqrt(3.0);
}

Vec2 LensLattice::nearestCentre(const Vec2& p) const {
  // Into the array's frame, then lattice coordinates. For both lattices the
  // nearest point is a corner of the parallelogram cell (floor(i), floor(j)) +
  // {0, 1}²: the square's cell is itself a Voronoi cell's dual, and the
  // hexagonal lattice's parallelogram is two equilateral triangles, each
  // covered by its corners' Voronoi cells.
  const Vec2 r = p - offset_;
  const Vec2 v(cos_ * r.x + sin_ * r.y, -sin_ * r.x + cos_ * r.y);
  const double fi = inverse_[0] * v.x + inverse_[1] * v.y, fj = inverse_[2] * v.x + inverse_[3] * v.y;
  const double i0 = std::floor(fi), j0 = std::floor(fj);
  Vec2 best(0, 0);
  double bestDistance = std::numeric_limits<double>::infinity();
  for (int di = 0; di <= 1; ++di)
    for (int dj = 0; dj <= 1; ++dj) {
      const Vec2 c = (i0 + di) * a1_ + (j0 + dj) * a2_;
      const double distance = (v - c).length2();
      if (distance < bestDistance) {
        bestDistance = distance;
        best = c;
      }
    }
  return offset_ + Vec2(cos_ * best.x - sin_ * best.y, sin_ * best.x + cos_ * best.y);
}

bool LensLattice::insideCell(const Vec2& p, const Vec2& centre, double fraction) const {
  // Scaling the point away from the centre by 1/fraction must keep it in the same cell.
  // (A point on the boundary between two cells belongs to both, so that a point
  // computed from a centre a rounding error away does not flip to its neighbour.)
  const Vec2 scaled = centre + (p - centre) / fraction;
  const double own = (scaled - centre).length2(), nearest = (scaled - nearestCentre(scaled)).length2();
  return own <= nearest * (1 + 1e-12) + 1e-24 * pitch_ * pitch_;
}

}  // namespace lfi
