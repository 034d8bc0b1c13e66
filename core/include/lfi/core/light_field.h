// SPDX-License-Identifier: Apache-2.0
#pragma once
// The 4D light field of a lensless light field sensor or display (docs/file-formats.md).
//
// Parametrisation (the same in memory and in files):
//   parameter        symbol  units  meaning
//   spatialX/Y       Sx,Sy   -      spatial elements along x and y
//   angular          n       -      angular elements per side of a spatial element (n x n)
//   pixelPitch_mm    p       mm     pitch of the underlying pixel grid
//   distance_mm      Δ       mm     distance from the light field plane to the part
//                                   (recorded for the emitter; 0 = not set)
//
// Plane frame: origin at the centre of the pixel grid, x and y in the plane,
// +z the normal on the side the sensor looks at and the display emits into
// (in the bench, world +z towards the part and the camera). Spatial element
// (ex, ey) covers x in [(ex - Sx/2) e, (ex + 1 - Sx/2) e] with e = n p, likewise y.
//
// Direction mapping: the position of a sample inside its element, normalised to
// [-1,1]^2, is (px, py); its ray of sight starts at the element centre and
// points along d = normalise(-px, -py, sqrt(1 - px^2 - py^2)). Samples with
// px^2 + py^2 >= 1 see nothing (radiance 0). The inverse, used by the emitter:
// a unit direction d with dz > 0 lands at (px, py) = (-dx, -dy).
//
// Storage: one CV_32FC1 "lenslet image" of (Sx n) x (Sy n) pixels, spatial
// elements as macro pixels; pixel (col, row) = (ex n + u, ey n + v) where u runs
// with px and v with py. Row index therefore increases with +y.
// Values are linear radiance along the ray of sight (relative units).

#include "lfi/core/geometry.h"

#include <opencv2/core.hpp>

namespace lfi {

struct LightFieldGeometry {
  int spatialX = 0;
  int spatialY = 0;
  int angular = 0;
  double pixelPitch_mm = 0;
  double distance_mm = 0;

  double elementPitch_mm() const { return angular * pixelPitch_mm; }
  int width() const { return spatialX * angular; }
  int height() const { return spatialY * angular; }
  double extentX_mm() const { return spatialX * elementPitch_mm(); }
  double extentY_mm() const { return spatialY * elementPitch_mm(); }
  // Throws Errc::InvalidArgument naming the first field out of range.
  void validate() const;
  friend bool operator==(const LightFieldGeometry&, const LightFieldGeometry&) = default;
};

enum class LightFieldLookup {
  Nearest,       // the reference model: the angular pixel the direction falls in
  Interpolated,  // bilinear in angle and bilinear in position across elements
};

class LightField {
 public:
  LightField() = default;
  // A zero light field with the given geometry (validated).
  explicit LightField(const LightFieldGeometry& geometry);
  // Wraps a lenslet image; throws if its size or type does not match or a
  // pixel is not finite or negative (what at() and lensletImage() write is not
  // checked).
  LightField(const LightFieldGeometry& geometry, cv::Mat lensletImage);

  const LightFieldGeometry& geometry() const { return geometry_; }
  const cv::Mat& lensletImage() const { return lenslet_; }
  cv::Mat& lensletImage() { return lenslet_; }

  float& at(int ex, int ey, int u, int v) {
    return lenslet_.at<float>(ey * geometry_.angular + v, ex * geometry_.angular + u);
  }
  float at(int ex, int ey, int u, int v) const {
    return lenslet_.at<float>(ey * geometry_.angular + v, ex * geometry_.angular + u);
  }

  // Centre of spatial element (ex, ey) in the plane frame, mm.
  Vec2 elementCentre(int ex, int ey) const;
  // Normalised in-element position (px, py) of the centre of angular pixel (u, v).
  Vec2 angularCentre(int u, int v) const;

  // The sensor mapping: ray-of-sight direction (plane frame) of a normalised
  // in-element position; requires px^2 + py^2 < 1.
  static Vec3 directionFromDisc(const Vec2& discPosition);
  // The emitter mapping, the inverse: returns false for directions with dz <= 0.
  static bool discFromDirection(const Vec3& direction, Vec2& discPosition);

  // Radiance along the ray of sight that starts at plane position q (mm, plane
  // frame) with direction d (unit, plane frame). 0 outside the plane and for
  // directions that point away from the +z half space.
  double radiance(const Vec2& q, const Vec3& d, LightFieldLookup mode) const;
  // radiance() once d is mapped to its disc position (discFromDirection,
  // inside the unit disc): for callers that find the disc position directly.
  double radianceFromDisc(const Vec2& q, const Vec2& disc, LightFieldLookup mode) const {
    const double e = geometry_.elementPitch_mm();
    return radianceAt(q.x / e + 0.5 * geometry_.spatialX, q.y / e + 0.5 * geometry_.spatialY, disc, mode);
  }
  // radiance()'s lookup once q and d are mapped: (sx, sy) = q / elementPitch_mm
  // + (spatialX, spatialY) / 2, in elements; disc = discFromDirection(d), inside
  // the unit disc. 0 outside the plane. For callers that map many rays at once.
  double radianceAt(double sx, double sy, const Vec2& disc, LightFieldLookup mode) const;

 private:
  double nearestSample(int ex, int ey, const Vec2& disc) const;

  LightFieldGeometry geometry_;
  cv::Mat lenslet_;
};

// The light field a display shows lit or dark for a captured reference
// (docs/study.md, "The reference's drive"): 1 in every angular pixel whose
// radiance is at least `threshold` times the brightest pixel's, 0 elsewhere;
// the geometry is the captured one's. A captured angular pixel holds the flux
// that fell into it spread over the whole pixel, so its value says how much
// of the pixel the light met, not the light's radiance; a display that shows
// that value shows the pixel's edges. Throws Errc::InvalidArgument for a
// threshold outside (0, 1] or a light field without light.
LightField binaryDrive(const LightField& captured, double threshold);

}  // namespace lfi
