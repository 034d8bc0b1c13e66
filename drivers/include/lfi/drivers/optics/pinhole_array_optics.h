#pragma once
// A 2-D array of pinholes over the panel (a parallax barrier with holes instead
// of slits): full parallax. Each pinhole lets every panel pixel under it out as
// one narrow beam, in a 2-D grid of directions.
//
//   parameter           units  meaning
//   packing             -      square or hexagonal pinhole centres (lens_lattice.h)
//   arrayPitch_mm       mm     centre distance of neighbouring pinholes, >= one pixel
//   rotation_rad        rad    the lattice rows' angle from the panel rows, |θ| <= π/4
//   arrayOffsetX/Y      mm     centre of pinhole (0, 0) from the panel centre
//   gap_mm              mm     pixel plane to barrier plane
//   pinholeDiameter_mm  mm     each hole's diameter, at most the pitch
//
// Frame (display.h): origin at the panel centre, x along the columns, y up, z = 0
// the barrier plane, +z towards the part; the pixel plane is z = -gap. Millimetres.
//
// Model. A panel point p belongs to the pinhole whose lattice cell holds it
// (centre c); its chief ray leaves c with direction ∝ ((c - p) / gap, 1). The
// inverse takes the pinhole the ray passes (|q - c| <= D/2) and the point
// p = c - gap (dx, dy)/dz, which must lie in that pinhole's cell. Physically
// (sourceOfRay) a ray through a hole at q came from p = q - gap (dx, dy)/dz,
// under any pinhole's cell (crosstalk at steep angles); a ray that meets the
// barrier outside every hole is blocked. The light passed is the hole's area
// over the cell's: (π D² / 4) / P² for a square array.
// Not modelled: diffraction at the holes. A hole of diameter D spreads a beam by
// about 1.22 λ / D (Airy disc, first zero): for the default 0.1 mm hole at
// 550 nm, 6.7 mrad, under a third of the default display's 23 mrad per pixel, and a
// blur of 1.22 λ gap / D ≈ 9 µm on the pixel plane at its 1.37 mm gap.
// Geometric penumbra (a hole passes directions within D / gap of each other
// from one pixel) is modelled, since rays are traced through the hole's area.

#include "lfi/core/geometry.h"
#include "lfi/drivers/display.h"
#include "lfi/drivers/optics/lens_lattice.h"
#include "lfi/drivers/optics/panel_grid.h"

#include <optional>

namespace lfi {

class PinholeArrayOptics {
public:
  // `info` validated; its optics are a PinholeArray.
  explicit PinholeArrayOptics(const DisplayInfo& info);

  DisplayRay rayFromPanelPoint(const Vec2& p) const;
  std::optional<Vec2> panelPointFromRay(const Vec2& q, const Vec3& d) const;
  std::optional<Vec2> sourceOfRay(const Vec2& q, const Vec3& d) const;
  Vec2 apertureCentre(const Vec2& q) const { return lattice_.nearestCentre(q); }
  // Whether two points of the panel or lens plane lie in the same lens's cell
  // (points on the border between two cells are in both).
  bool sameAperture(const Vec2& a, const Vec2& b) const {
    return lattice_.insideCell(b, lattice_.nearestCentre(a), 1);
  }
  double viewCone_rad() const;
  const LensLattice& lattice() const { return lattice_; }

private:
  LensLattice lattice_;
  double gap_, radius_;
};

}  // namespace lfi
