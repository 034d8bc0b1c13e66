// SPDX-License-Identifier: Apache-2.0
#pragma once
// Lenticular and line-barrier optics: slanted cylinder lenses (or slits) over
// the panel. Horizontal parallax only: every ray a lens sends fans out across the
// lens axis, none along it, so a part that bends light along the axes sees no
// display ray from that direction.
//
//   parameter     units      meaning
//   lensPitch_px  px         lens (slit) pitch along a panel row
//   slant_rad     rad        lens axis angle from the panel vertical, |s| < π/4
//   offset_px     px         x of lens 0's axis on the panel's centre row, from the centre
//   gap_mm        mm         pixel plane to lens/barrier plane
//   focalLength   mm         lenticular: each lens's focal length (= gap: focused on the panel)
//   slitWidth     mm         line barrier: each slit's width
//
// Frame (display.h): origin at the panel centre, x along the columns, y up, z = 0
// the lens plane, +z towards the part; the pixel plane is z = -gap.
//
// Model. Lens axes are parallel lines with unit direction a = (sin s, cos s) and
// in-plane normal n = (cos s, -sin s). With w(p) = p·n, axis m is w = w0 + m P⊥,
// P⊥ = lensPitch_px · pixelPitch · cos s, w0 = offset_px · pixelPitch · cos s. A
// panel point p belongs to the nearest axis; d = w(p) - w_m in [-P⊥/2, P⊥/2) is
// its distance across the lens. Its chief ray leaves the axis across from it,
// o = p - d n, with direction ∝ (-d/gap · n, 1): a lens focused on the panel turns
// the pixel into a beam along it, a slit passes the same ray. The view cone (full
// angle across the lens) is 2 atan(P⊥ / (2 gap)).
// Physically (sourceOfRay), a ray leaving the lens plane at q, at h = w(q) - w_m
// from its lens axis, with slope t⊥ across and t∥ along the axis, comes from the
// panel point at w = w_m + h (1 - gap/f) - gap t⊥, u = u(q) - gap t∥ (a thin
// cylinder lens: f = gap makes every point of a lens see one pixel per
// direction; a slit is 1/f = 0 and passes only |h| <= slitWidth/2). Pixels under
// the neighbouring lens are reached at steep angles: the repeated view zones of
// a real lenticular display. Not modelled: lens aberrations, diffraction at the
// slits, reflections between panel and sheet.

#include "lfi/core/geometry.h"
#include "lfi/drivers/display.h"
#include "lfi/drivers/optics/panel_grid.h"

#include <optional>

namespace lfi {

class LenticularOptics {
 public:
  // `info` validated; its optics are Lenticular or LineBarrier.
  explicit LenticularOptics(const DisplayInfo& info);

  // The chief ray of a point on the pixel plane (x, y).
  DisplayRay rayFromPanelPoint(const Vec2& p) const;
  // The panel point whose chief ray leaves the lens axis across from q with
  // direction d; empty for directions outside the view cone or with d.z <= 0.
  // A direction's component along the axis is not selected by the optics.
  std::optional<Vec2> panelPointFromRay(const Vec2& q, const Vec3& d) const;
  // Where a ray that leaves the lens plane at q with direction d comes from on
  // the pixel plane, through its own lens or slit; empty where the barrier
  // blocks it or d.z <= 0.
  std::optional<Vec2> sourceOfRay(const Vec2& q, const Vec3& d) const;
  // The point of q's lens axis across from q, where chief rays through q's lens leave.
  Vec2 apertureCentre(const Vec2& q) const;
  // Whether two points of the panel or lens plane lie under the same lens.
  bool sameAperture(const Vec2& a, const Vec2& b) const { return lensIndex(a) == lensIndex(b); }

  // Distance across its lens (along lensNormal(), in [-P⊥/2, P⊥/2]) of a point of
  // the panel or lens plane: p·n minus the nearest lens axis.
  double acrossLens(const Vec2& p) const;
  double lensPitchPerp_mm() const { return perpPitch_; }
  Vec2 lensNormal() const { return normal_; }
  double viewCone_rad() const;

 private:
  double lensIndex(const Vec2& p) const;

  bool barrier_;
  Vec2 axis_, normal_;
  double perpPitch_ = 0, invPerpPitch_ = 0, w0_ = 0;
  double gap_ = 0, defocus_ = 1, halfSlit_ = 0;
};

}  // namespace lfi
