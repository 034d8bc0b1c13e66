// SPDX-License-Identifier: Apache-2.0
#pragma once
// The full-parallax classes: a 2-D array of lenses or of pinholes over the
// panel, one model (a pinhole is a lens of no power whose aperture is the hole).
//
// A 2-D microlens array over the panel (integral imaging): full parallax. Every
// lens sends the panel pixels under it out as beams in a 2-D grid of
// directions, so a round part is lit from every direction it needs.
//
//   parameter         units  meaning
//   packing           -      square or hexagonal lens centres (lens_lattice.h)
//   arrayPitch_mm     mm     centre distance of neighbouring lenses, >= one pixel
//   rotation_rad      rad    the lattice rows' angle from the panel rows, |θ| <= π/4
//   arrayOffsetX/Y    mm     centre of lens (0, 0) from the panel centre
//   gap_mm            mm     pixel plane to lens plane
//   focalLength_mm    mm     each lens's focal length (= gap: focused on the panel)
//   fillFactor        -      clear aperture as a linear fraction of the lens's cell
//                            (1: the whole square or hexagon transmits)
//
// Frame (display.h): origin at the panel centre, x along the columns, y up, z = 0
// the lens plane, +z towards the part; the pixel plane is z = -gap. Millimetres.
//
// Model. A panel point p belongs to the lens whose cell holds it (centre c, the
// lens straight above). Its chief ray leaves the lens centre with direction
// ∝ ((c - p) / gap, 1): a lens focused on the panel (f = gap) turns every point
// of the pixel into a collimated beam, the pixel's centre into the beam along
// the chief ray. The view cone across a lattice row is 2 atan(P / (2 gap)),
// wider along the cell's diagonals. The inverse (panelPointFromRay) takes the
// lens whose clear aperture the ray crosses and the point p = c - gap (dx, dy)/dz
// under it; a direction whose point lies under another lens is outside the view
// cone. Physically (sourceOfRay), a ray leaving the lens plane at q = c + h with
// slope t = (dx, dy)/dz came through a thin lens from the panel point
// p = c + h (1 - gap/f) - gap t, which may lie under a neighbouring lens: the
// repeated view zones (crosstalk) of a real integral-imaging display. A ray
// through the opaque part between clear apertures is blocked.
// Not modelled: lens aberrations (each lens is ideal and thin), diffraction at
// the apertures (a 1 mm lens at 550 nm spreads a beam by about 1.22 λ / D =
// 0.7 mrad, well below the default display's 23 mrad per pixel), reflections
// and stray light between panel and array, the panel's own angular emission
// profile.
//
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

class LensArrayOptics {
 public:
  // `info` validated; its optics are a LensletArray or a PinholeArray.
  explicit LensArrayOptics(const DisplayInfo& info);

  // The chief ray of a point on the pixel plane (x, y).
  DisplayRay rayFromPanelPoint(const Vec2& p) const;
  // The panel point whose chief ray leaves the lens (pinhole) whose clear
  // aperture holds q, with direction d; empty where q is in no clear aperture,
  // for d.z <= 0, and where the point lies under another lens (outside the view cone).
  std::optional<Vec2> panelPointFromRay(const Vec2& q, const Vec3& d) const;
  // Where a ray that leaves the array at q with direction d comes from on the
  // pixel plane, back through its own thin lens or pinhole; empty where the
  // array blocks it or d.z <= 0.
  std::optional<Vec2> sourceOfRay(const Vec2& q, const Vec3& d) const;
  // The centre of the lens whose cell holds q.
  Vec2 apertureCentre(const Vec2& q) const { return lattice_.nearestCentre(q); }
  // Whether two points of the panel or lens plane lie in the same lens's cell
  // (points on the border between two cells are in both).
  bool sameAperture(const Vec2& a, const Vec2& b) const { return lattice_.insideCell(b, lattice_.nearestCentre(a), 1); }
  // Whether q lies in the clear aperture of the lens (pinhole) at `centre`.
  bool insideAperture(const Vec2& q, const Vec2& centre) const;
  // The farthest a point of a clear aperture lies from its centre, mm.
  double apertureReach_mm() const { return pinhole_ ? radius_ : fill_ * lattice_.circumradius_mm(); }
  // 1 / focal length, per mm: 0 for pinholes.
  double power_per_mm() const { return power_; }
  double viewCone_rad() const;
  const LensLattice& lattice() const { return lattice_; }

 private:
  LensLattice lattice_;
  bool pinhole_;
  double gap_, power_, fill_, radius_;
};

}  // namespace lfi
