// SPDX-License-Identifier: Apache-2.0
#include "lfi/drivers/display_optics.h"
#include "lfi/drivers/panel_response.h"

#include "lfi/core/error.h"

#include <cmath>
#include <numbers>

namespace lfi {

namespace {

std::variant<LenticularOptics, LensArrayOptics> makeModel(const DisplayInfo& info) {
  switch (info.optics.type) {
    case OpticsType::Lenticular:
    case OpticsType::LineBarrier:
      return LenticularOptics(info);
    case OpticsType::LensletArray:
    case OpticsType::PinholeArray:
      return LensArrayOptics(info);
  }
  fail(Errc::InvalidArgument, "display info optics type {} is not a known class", static_cast<int>(info.optics.type));
}

const DisplayInfo& validated(const DisplayInfo& info) {
  info.validate();
  return info;
}

}  // namespace

DisplayOptics::DisplayOptics(const DisplayInfo& info)
    : info_(validated(info)), grid_(info_), model_(makeModel(info_)) {}

DisplayRay DisplayOptics::rayFromPixel(int col, int row, int subpixel) const {
  const Vec2 p = grid_.subpixelCentre(col, row, subpixel);
  return std::visit([&](const auto& m) { return m.rayFromPanelPoint(p); }, model_);
}

std::optional<PanelSample> DisplayOptics::pixelFromRay(const Vec3& origin, const Vec3& direction) const {
  const Vec2 q(origin.x, origin.y);
  return std::visit(
      [&](const auto& m) -> std::optional<PanelSample> {
        const std::optional<Vec2> p = m.panelPointFromRay(q, direction);
        const std::optional<PanelSample> s = p ? grid_.sampleAt(*p) : std::nullopt;
        // The subpixel holding the point may have its centre, and so its chief
        // ray, under the neighbouring lens: then no subpixel of this lens sends the ray.
        if (!s || !m.sameAperture(q, grid_.subpixelCentre(s->col, s->row, s->subpixel))) return std::nullopt;
        return s;
      },
      model_);
}

std::optional<PanelSample> DisplayOptics::sourceOfRay(const Vec2& origin, const Vec3& direction) const {
  const std::optional<Vec2> p = std::visit([&](const auto& m) { return m.sourceOfRay(origin, direction); }, model_);
  return p ? grid_.sampleAt(*p) : std::nullopt;
}

Vec2 DisplayOptics::apertureCentre(const Vec2& q) const {
  return std::visit([&](const auto& m) { return m.apertureCentre(q); }, model_);
}

double DisplayOptics::viewCone_rad() const {
  return std::visit([](const auto& m) { return m.viewCone_rad(); }, model_);
}

// A lenticular display of the Looking Glass 8.9" class, from its published
// per-device calibration ("visual.json" as read by the HoloPlay SDK and
// open-source viewers; values of one such device):
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
DisplayInfo defaultLenticularDisplay() {
  DisplayInfo info;
  info.vendor = "lfi";
  info.model = "lenticular 8.9in class";
  info.panelWidth_px = 2560;
  info.panelHeight_px = 1600;
  info.pixelPitch_mm = 25.4 / 338.0;
  info.subpixels = SubpixelLayout::RgbStripe;
  const double slope = 5.420652;
  const double slant = std::atan(1.0 / slope);
  const double perpPitch_mm = 25.4 / 47.58427;
  const double viewCone = 40.0 * std::numbers::pi / 180.0;
  info.optics.type = OpticsType::Lenticular;
  info.optics.slant_rad = slant;
  info.optics.lensPitch_px = perpPitch_mm / std::cos(slant) / info.pixelPitch_mm;
  info.optics.offset_px = 0.042 * info.optics.lensPitch_px;
  info.optics.gap_mm = 0.5 * perpPitch_mm / std::tan(0.5 * viewCone);
  info.optics.focalLength_mm = info.optics.gap_mm;
  info.viewCount = 45;
  info.brightnessMin = 0;
  info.brightnessMax = 255;
  return info;
}

// A full-parallax integral-imaging display the method can use:
//
//   parameter     value           source
//   panel         3840 x 2160     a 5.5" UHD LCD (806 ppi, 121.0 x 68.0 mm active area: the class of
//                                 the Sharp LS055T1SX01 phone and VR panels)
//   pixelPitch    0.0315 mm       121.0 mm / 3840
//   subpixels     RGB stripe      the panel's
//   lens array    square, 1.0 mm  a molded fly's-eye array; 31.7 pixels (95 subpixel columns) per lens
//   focal length  1.37 mm         f/1.37: the fast end of molded arrays, chosen for the view cone
//   gap           1.37 mm         = f: lenses focused on the panel
//   view cone     40.1 degrees    2 atan(P / (2 gap)) across the rows, 54.6 along the diagonals
//   fill factor   1               lenses touching (molded arrays reach 100 % in square packing)
//   brightness    0..255          8-bit backlight level
//
// The reference lens (f ≈ 50 mm, Ø 25.4 mm) sends the capture beam through the
// display plane at up to about 15 degrees from the axis (atan(12.7 / 49.8) =
// 14.3 plus its spherical aberration); the 20-degree half-cone leaves a third
// more. A subpixel's beam is 0.0315 / 1.37 = 23 mrad wide. The 1 mm-pitch,
// 3.3 mm-focus arrays of many integral-imaging prototypes give a 17-degree cone:
// too narrow for this lens.
DisplayInfo defaultLensletArrayDisplay() {
  DisplayInfo info;
  info.vendor = "lfi";
  info.model = "lenslet array 5.5in UHD class";
  info.panelWidth_px = 3840;
  info.panelHeight_px = 2160;
  info.pixelPitch_mm = 0.0315;
  info.subpixels = SubpixelLayout::RgbStripe;
  info.optics.type = OpticsType::LensletArray;
  info.optics.packing = LensPacking::Square;
  info.optics.arrayPitch_mm = 1.0;
  info.optics.gap_mm = 1.37;
  info.optics.focalLength_mm = 1.37;
  info.optics.fillFactor = 1;
  info.viewCount = 32 * 32;
  info.brightnessMin = 0;
  info.brightnessMax = 255;
  return info;
}

// The same panel, pitch and gap behind a pinhole array of 0.1 mm holes (1 % of
// a cell's area passes: a pinhole display trades light for sharp beams).
DisplayInfo defaultPinholeArrayDisplay() {
  DisplayInfo info = defaultLensletArrayDisplay();
  info.model = "pinhole array 5.5in UHD class";
  info.optics.type = OpticsType::PinholeArray;
  info.optics.focalLength_mm = 0;
  info.optics.pinholeDiameter_mm = 0.1;
  return info;
}

DisplayInfo defaultDisplay(OpticsType type) {
  switch (type) {
    case OpticsType::LensletArray:
      return defaultLensletArrayDisplay();
    case OpticsType::PinholeArray:
      return defaultPinholeArrayDisplay();
    case OpticsType::Lenticular:
    case OpticsType::LineBarrier:
      break;
  }
  return defaultLenticularDisplay();
}

cv::Mat encodeLightField(const LightField& lightField, const DisplayOptics& optics, double white,
                         LightFieldLookup lookup, const PanelResponse* response) {
  if (!(white > 0) || !std::isfinite(white))
    fail(Errc::InvalidArgument, "encodeLightField: white = {} must be finite and > 0", white);
  if (lightField.lensletImage().empty()) fail(Errc::InvalidArgument, "encodeLightField: the light field is empty");
  const DisplayInfo& info = optics.info();
  const int sub = info.subpixelsPerPixel();
  cv::Mat panel(info.panelHeight_px, info.panelWidth_px, info.panelType());
  const double scale = 255.0 / white;
  cv::parallel_for_(cv::Range(0, info.panelHeight_px), [&](const cv::Range& rows) {
    for (int row = rows.start; row < rows.end; ++row) {
      std::uint8_t* out = panel.ptr<std::uint8_t>(row);
      for (int col = 0; col < info.panelWidth_px; ++col) {
        for (int k = 0; k < sub; ++k) {
          // A unit direction d with d.z > 0 lands on the light field's disc at (-dx, -dy).
          const DisplayRay ray = optics.rayFromPixel(col, row, k);
          const double r = lightField.radianceFromDisc({ray.origin_mm.x, ray.origin_mm.y},
                                                       {-ray.direction.x, -ray.direction.y}, lookup);
          if (response) {
            out[col * sub + k] = response->driveLevel(r / white, col, row, k);  // (NaN: level 0)
            continue;
          }
          const double level = r * scale + 0.5;  // rounded below; NaN gives 0
          out[col * sub + k] = !(level > 0) ? 0 : level >= 255 ? 255 : static_cast<std::uint8_t>(level);
        }
      }
    }
  });
  return panel;
}

LightField decodePanelImage(const cv::Mat& panel, const DisplayOptics& optics, const LightFieldGeometry& geometry,
                            double white) {
  if (!(white > 0) || !std::isfinite(white))
    fail(Errc::InvalidArgument, "decodePanelImage: white = {} must be finite and > 0", white);
  requirePanelImage(optics.info(), panel, "decodePanelImage");
  LightField out(geometry);
  const int n = geometry.angular, sub = optics.info().subpixelsPerPixel();
  const double scale = white / 255.0;
  cv::parallel_for_(cv::Range(0, geometry.spatialY), [&](const cv::Range& rows) {
    for (int ey = rows.start; ey < rows.end; ++ey)
      for (int ex = 0; ex < geometry.spatialX; ++ex) {
        const Vec2 lens = optics.apertureCentre(out.elementCentre(ex, ey));
        for (int v = 0; v < n; ++v)
          for (int u = 0; u < n; ++u) {
            const Vec2 disc = out.angularCentre(u, v);
            if (!(disc.length2() < 1)) continue;
            const std::optional<PanelSample> s =
                optics.pixelFromRay({lens.x, lens.y, 0}, LightField::directionFromDisc(disc));
            if (s)
              out.at(ex, ey, u, v) =
                  static_cast<float>(scale * panel.ptr<std::uint8_t>(s->row)[s->col * sub + s->subpixel]);
          }
      }
  });
  return out;
}

}  // namespace lfi
