#pragma once
// The light field display's optics model: which ray each panel (sub)pixel emits
// through its lenslet or slit, the inverse (ray → panel pixel), and the encoding of a
// light field (lfi/core/light_field.h) into a panel image.
//
// Frame (display.h): origin at the centre of the panel's active area, x along panel
// columns, y up the panel (row 0 at the top), z = 0 the lens/barrier plane, +z
// towards the part. The panel's pixel plane is at z = -gap. Millimetres, radians.
//
// Model. Lens axes (lenticular: cylinder lens axes; barrier: slit centre lines) are
// parallel lines in the plane with unit direction a = (sin s, cos s) and in-plane
// normal n = (cos s, -sin s), s = slant. With w(p) = p·n, lens m's axis is
// w = w0 + m P⊥ with P⊥ = lensPitch_px · pixelPitch · cos s (the perpendicular pitch)
// and w0 = offset_px · pixelPitch · cos s. A subpixel centre p (at z = -gap) belongs
// to the nearest axis m; d = w(p) - w_m in [-P⊥/2, P⊥/2) is its distance across the
// lens. It emits the chief ray through the lens centre line (a lenslet focused on
// the panel, f ≈ gap, turns the pixel into a collimated beam along this ray; a slit
// passes the same ray): origin o = p - d n on the plane z = 0 (the point of the axis
// across from the pixel) and direction ∝ (-d/gap · n, 1). Lenticular optics only
// deflect across the lens: every ray's direction lies in the plane spanned by n and
// z, so the display has horizontal parallax only, and the view cone (full angle) is
// 2 atan(P⊥ / (2 gap)). Subpixels of an RGB stripe sit at x = (col + (k + 0.5)/3)
// pixel pitches from the panel's left edge; each has its own ray.
//
// Defaults (defaultLenticularDisplay()): a lenticular display of the Looking Glass
// 8.9" class, from its published per-device calibration ("visual.json" as read by
// the HoloPlay SDK and open-source viewers; values of one such device):
//
//   parameter       value        source
//   panel           2560 x 1600  calibration screenW, screenH
//   pixelPitch      0.07515 mm   25.4 mm / DPI, DPI = 338
//   subpixels       RGB stripe   calibration subp = 1/(3 screenW): RGB subpixel views
//   lens pitch ⊥    0.5338 mm    25.4 mm / pitch, pitch = 47.584 lenses per inch (across the lenses)
//   lensPitch_px    7.22 px      lens pitch ⊥ / cos(slant) / pixelPitch (along a row): ~7 pixels per lens
//   slant           0.1826 rad   atan(1 / |slope|), slope = -5.4207 (10.5 degrees)
//   offset_px       0.30 px      calibration center = 0.042 of a lens pitch
//   view cone       40 degrees   calibration viewCone = 40
//   gap             0.7333 mm    derived: P⊥ / (2 tan(viewCone / 2))
//   focalLength     0.7333 mm    lenses focused on the panel (= gap)
//   viewCount       45           the 45-view quilt the maker's software renders for it
//   brightness      0..255       8-bit backlight level
//
// The slanted lens spreads the 3 x 7.22 ≈ 21.7 subpixels under each lens over the
// view cone (the slant trades horizontal for vertical resolution, van Berkel 1999).

#include "lfi/core/geometry.h"
#include "lfi/core/light_field.h"
#include "lfi/drivers/display.h"

#include <opencv2/core.hpp>

#include <optional>

namespace lfi {

// A ray the display emits: origin on the plane z = 0, unit direction with z > 0.
struct DisplayRay {
  Vec3 origin_mm;
  Vec3 direction;
};

struct PanelSample {
  int col = 0;
  int row = 0;
  int subpixel = 0;  // 0..subpixelsPerPixel-1, left to right
  friend bool operator==(const PanelSample&, const PanelSample&) = default;
};

class DisplayOptics {
public:
  // Validates `info` (throws Errc::InvalidArgument naming the field).
  explicit DisplayOptics(const DisplayInfo& info);

  const DisplayInfo& info() const { return info_; }

  // Centre of a subpixel on the pixel plane (z = -gap), x and y in mm.
  Vec2 subpixelCentre(int col, int row, int subpixel) const;

  // The chief ray of a subpixel. Requires a sample inside the panel.
  DisplayRay rayFromPixel(int col, int row, int subpixel = 0) const;
  DisplayRay rayFromPixel(const PanelSample& sample) const {
    return rayFromPixel(sample.col, sample.row, sample.subpixel);
  }

  // The subpixel whose chief ray passes through `origin_mm` (z ignored) with
  // `direction`: the lens containing the origin and the place under it that the
  // direction selects. Empty for directions outside the view cone, with z <= 0, or
  // landing off the panel. A ray with a component along the lens axis is accepted
  // (lenticular optics do not select it).
  std::optional<PanelSample> pixelFromRay(const Vec3& origin_mm, const Vec3& direction) const;

  // Distance d across its lens (in [-P⊥/2, P⊥/2], along lensNormal()) of a
  // point p of the panel or lens plane: p·n minus the nearest lens axis.
  double acrossLens(const Vec2& p) const;

  // Perpendicular lens pitch P⊥ in mm and the full view cone angle in rad.
  double lensPitchPerp_mm() const { return perpPitch_; }
  double viewCone_rad() const;
  // In-plane unit normal to the lens axes (the direction in which rays fan out).
  Vec2 lensNormal() const { return normal_; }

private:
  DisplayInfo info_;
  Vec2 normal_;
  double perpPitch_ = 0;
  double invPerpPitch_ = 0;
  double w0_ = 0;
};

// A display of the Looking Glass 8.9" class (parameter table above).
DisplayInfo defaultLenticularDisplay();

// Samples `lightField` (interpolated lookup) along every subpixel's chief ray and
// returns the panel image: CV_8UC1 or CV_8UC3 (channels in subpixel order), drive
// level = round(255 · radiance / white) clamped to 0..255 (a linear panel).
// The light field's plane frame is the display frame.
cv::Mat encodeLightField(const LightField& lightField, const DisplayOptics& optics, double white = 1.0);

}  // namespace lfi
