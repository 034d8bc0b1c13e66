// SPDX-License-Identifier: Apache-2.0
#pragma once
// The light field display's optics model, one code path for every class of
// optics (display.h, OpticsType): which ray each panel (sub)pixel emits, the
// inverse (ray → the subpixel whose chief ray it is), where a ray leaving the
// display came from physically (through its own lens, slit or pinhole), the
// encoding of a light field (lfi/core/light_field.h) into a panel image and the
// decoding of a panel image back into a light field. The classes' models, their
// parameter tables and what they leave out are in optics/: lenticular_optics.h
// (lenticular, line barrier) and lens_array_optics.h (lenslet and pinhole arrays).
//
// Frame (display.h): origin at the centre of the panel's active area, x along panel
// columns, y up the panel (row 0 at the top), z = 0 the lens/barrier plane, +z
// towards the part. The panel's pixel plane is at z = -gap. Millimetres, radians.
//
// The chief ray of a subpixel is the ray through the centre of its lens (or
// slit, pinhole) from the subpixel's centre: what a lens focused on the panel
// sends as a collimated beam. rayFromPixel and pixelFromRay are exact inverses
// over the whole panel (pixel → ray → pixel gives the pixel back).

#include "lfi/core/geometry.h"
#include "lfi/core/light_field.h"
#include "lfi/drivers/display.h"
#include "lfi/drivers/optics/lens_array_optics.h"
#include "lfi/drivers/optics/lenticular_optics.h"
#include "lfi/drivers/optics/panel_grid.h"

#include <opencv2/core.hpp>

#include <optional>
#include <variant>

namespace lfi {

class PanelResponse;

class DisplayOptics {
 public:
  // Validates `info` (throws Errc::InvalidArgument naming the field).
  explicit DisplayOptics(const DisplayInfo& info);

  const DisplayInfo& info() const { return info_; }
  const PanelGrid& grid() const { return grid_; }

  // Centre of a subpixel on the pixel plane (z = -gap), x and y in mm.
  Vec2 subpixelCentre(int col, int row, int subpixel) const { return grid_.subpixelCentre(col, row, subpixel); }

  // The chief ray of a subpixel. Requires a sample inside the panel.
  DisplayRay rayFromPixel(int col, int row, int subpixel = 0) const;
  DisplayRay rayFromPixel(const PanelSample& sample) const {
    return rayFromPixel(sample.col, sample.row, sample.subpixel);
  }

  // The subpixel whose chief ray leaves the lens (slit, pinhole) that a ray from
  // `origin_mm` (z ignored) crosses, in `direction`. Empty where the ray passes no
  // lens or pinhole (an opaque part of the array, the barrier), for directions
  // outside the view cone or with z <= 0, and where the pixel is off the panel.
  // Lenticular optics do not select a direction's component along the lens axis.
  std::optional<PanelSample> pixelFromRay(const Vec3& origin_mm, const Vec3& direction) const;

  // Physically: the subpixel a ray leaving the display plane at `origin_mm` in
  // `direction` comes from, back through its own lens (thin lens, defocused when
  // the focal length differs from the gap), slit or pinhole, which may lie under
  // a neighbouring lens (crosstalk); empty where the array blocks the ray or the
  // point is off the panel. The simulated display's emitter is this.
  std::optional<PanelSample> sourceOfRay(const Vec2& origin_mm, const Vec3& direction) const;

  // Where the chief rays of the lens (slit, pinhole) nearest to `q` leave: its
  // centre (for a lenticular sheet, the point of the axis across from q).
  Vec2 apertureCentre(const Vec2& q) const;

  // The full view cone across the lenses (across a lattice row for 2-D arrays), rad.
  double viewCone_rad() const;
  bool fullParallax() const { return lfi::fullParallax(info_.optics.type); }

  // The class's own model, for what only it has (e.g. LenticularOptics::acrossLens);
  // nullptr for another class.
  template <typename Model>
  const Model* model() const {
    return std::get_if<Model>(&model_);
  }

 private:
  DisplayInfo info_;
  PanelGrid grid_;
  std::variant<LenticularOptics, LensArrayOptics> model_;
};

// Defaults (their parameter tables and sources are in display_optics.cpp): a
// lenticular display of the Looking Glass 8.9" class (horizontal parallax
// only), and full-parallax lenslet-array and pinhole-array displays on a 5.5"
// 3840 x 2160 panel, with a view cone that covers the reference lens's rays
// (about ±15 degrees) with margin.
DisplayInfo defaultLenticularDisplay();
DisplayInfo defaultLensletArrayDisplay();
DisplayInfo defaultPinholeArrayDisplay();
// The default display of a class (a line barrier: the lenticular display's, no slit width).
DisplayInfo defaultDisplay(OpticsType type);

// Samples `lightField` along every subpixel's chief ray and returns the panel
// image: CV_8UC1 or CV_8UC3 (channels in subpixel order), drive level =
// round(255 · radiance / white) clamped to 0..255 (a linear panel), or with a
// measured `response` the level that emits radiance / white of the dimmest
// pixel's full light (panel_response.h). The light field's plane frame is the
// display frame.
cv::Mat encodeLightField(const LightField& lightField, const DisplayOptics& optics, double white = 1.0,
                         LightFieldLookup lookup = LightFieldLookup::Interpolated,
                         const PanelResponse* response = nullptr);

// The inverse: a light field of `geometry` (plane frame = display frame) whose
// every sample (element centre, angular pixel direction) holds the radiance
// white · level / 255 of the subpixel whose chief ray leaves the sample's lens in
// the sample's direction (pixelFromRay from that lens's centre), 0 where no
// subpixel does. `panel` as show() takes it.
LightField decodePanelImage(const cv::Mat& panel, const DisplayOptics& optics, const LightFieldGeometry& geometry,
                            double white = 1.0);

}  // namespace lfi
