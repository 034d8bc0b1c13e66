#include "lfi/drivers/display_optics.h"

#include "lfi/core/error.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace lfi {

DisplayOptics::DisplayOptics(const DisplayInfo& info) : info_(info) {
  info_.validate();
  const double s = info_.optics.slant_rad;
  normal_ = {std::cos(s), -std::sin(s)};
  perpPitch_ = info_.optics.lensPitch_px * info_.pixelPitch_mm * std::cos(s);
  invPerpPitch_ = 1 / perpPitch_;
  w0_ = info_.optics.offset_px * info_.pixelPitch_mm * std::cos(s);
}

Vec2 DisplayOptics::subpixelCentre(int col, int row, int subpixel) const {
  const double p = info_.pixelPitch_mm;
  const double sub = info_.subpixelsPerPixel();
  return {(col + (subpixel + 0.5) / sub - 0.5 * info_.panelWidth_px) * p,
          (0.5 * info_.panelHeight_px - row - 0.5) * p};
}

namespace {

// std::round (halves away from zero) for |x| < 2^62 without a libm call: the
// baseline x86-64 build has no rounding instruction, and the call was a tenth
// of encodeLightField's time.
double roundHalfAway(double x) { return static_cast<double>(static_cast<long long>(x + (x < 0 ? -0.5 : 0.5))); }

}  // namespace

double DisplayOptics::acrossLens(const Vec2& p) const {
  const double w = p.x * normal_.x + p.y * normal_.y;
  const double m = roundHalfAway((w - w0_) * invPerpPitch_);
  return w - (w0_ + m * perpPitch_);
}

DisplayRay DisplayOptics::rayFromPixel(int col, int row, int subpixel) const {
  const Vec2 p = subpixelCentre(col, row, subpixel);
  const double d = acrossLens(p);
  const double t = -d / info_.optics.gap_mm;
  DisplayRay ray;
  ray.origin_mm = {p.x - d * normal_.x, p.y - d * normal_.y, 0};
  ray.direction = Vec3(t * normal_.x, t * normal_.y, 1).normalized();
  return ray;
}

std::optional<PanelSample> DisplayOptics::pixelFromRay(const Vec3& origin, const Vec3& direction) const {
  if (!(direction.z > 0) || !std::isfinite(direction.x) || !std::isfinite(direction.y)) return std::nullopt;
  if (!(std::abs(origin.x) < 1e9 && std::abs(origin.y) < 1e9)) return std::nullopt;  // (NaN too): off any panel
  const double t = (direction.x * normal_.x + direction.y * normal_.y) / direction.z;
  const double d = -t * info_.optics.gap_mm;
  if (!(std::abs(d) <= 0.5 * perpPitch_)) return std::nullopt;
  const double shift = d - acrossLens({origin.x, origin.y});  // from the origin across the lens to the pixel
  const double x = origin.x + shift * normal_.x, y = origin.y + shift * normal_.y;
  const double p = info_.pixelPitch_mm;
  const double colF = x / p + 0.5 * info_.panelWidth_px;
  const double rowF = 0.5 * info_.panelHeight_px - y / p;
  if (!(colF >= 0 && colF < info_.panelWidth_px && rowF >= 0 && rowF < info_.panelHeight_px)) return std::nullopt;
  PanelSample s;
  s.col = static_cast<int>(std::floor(colF));
  s.row = static_cast<int>(std::floor(rowF));
  const int sub = info_.subpixelsPerPixel();
  s.subpixel = std::clamp(static_cast<int>(std::floor((colF - s.col) * sub)), 0, sub - 1);
  return s;
}

double DisplayOptics::viewCone_rad() const { return 2 * std::atan(0.5 * perpPitch_ / info_.optics.gap_mm); }

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
  info.optics.type = OpticsType::Lenslet;
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

cv::Mat encodeLightField(const LightField& lightField, const DisplayOptics& optics, double white) {
  if (!(white > 0) || !std::isfinite(white))
    fail(Errc::InvalidArgument, "encodeLightField: white = {} must be finite and > 0", white);
  if (lightField.lensletImage().empty()) fail(Errc::InvalidArgument, "encodeLightField: the light field is empty");
  const DisplayInfo& info = optics.info();
  const int sub = info.subpixelsPerPixel();
  cv::Mat panel(info.panelHeight_px, info.panelWidth_px, info.panelType());
  const double scale = 255.0 / white;
  // rayFromPixel and LightField::radiance, with the ray's direction taken
  // straight to the disc: the unit direction (-t n, 1) / sqrt(1 + t^2) lands
  // at t n / sqrt(1 + t^2) (inside it: the cone is below 180 degrees).
  const Vec2 n = optics.lensNormal();
  const double invGap = 1.0 / info.optics.gap_mm;
  cv::parallel_for_(cv::Range(0, info.panelHeight_px), [&](const cv::Range& rows) {
    for (int row = rows.start; row < rows.end; ++row) {
      std::uint8_t* out = panel.ptr<std::uint8_t>(row);
      for (int col = 0; col < info.panelWidth_px; ++col) {
        for (int k = 0; k < sub; ++k) {
          const Vec2 p = optics.subpixelCentre(col, row, k);
          const double d = optics.acrossLens(p), t = d * invGap, s = t / std::sqrt(1 + t * t);
          const double r = lightField.radianceFromDisc({p.x - d * n.x, p.y - d * n.y}, {s * n.x, s * n.y},
                                                       LightFieldLookup::Interpolated);
          const double level = r * scale + 0.5;  // rounded below; NaN gives 0
          out[col * sub + k] = !(level > 0) ? 0 : level >= 255 ? 255 : static_cast<std::uint8_t>(level);
        }
      }
    }
  });
  return panel;
}

}  // namespace lfi
