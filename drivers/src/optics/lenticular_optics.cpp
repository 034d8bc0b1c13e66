// SPDX-License-Identifier: Apache-2.0
#include "lfi/drivers/optics/lenticular_optics.h"

#include <cmath>
#include <limits>

namespace lfi {

namespace {

// std::round (halves away from zero) for |x| < 2^62 without a libm call: the
// baseline x86-64 build has no rounding instruction, and the call was a tenth
// of encodeLightField's time.
double roundHalfAway(double x) {
  return static_cast<double>(static_cast<long long>(x + (x < 0 ? -0.5 : 0.5)));
}

}  // namespace

LenticularOptics::LenticularOptics(const DisplayInfo& info) : barrier_(info.optics.type == OpticsType::LineBarrier) {
  const DisplayOpticsParams& o = info.optics;
  const double s = o.slant_rad;
  axis_ = {std::sin(s), std::cos(s)};
  normal_ = {std::cos(s), -std::sin(s)};
  perpPitch_ = o.lensPitch_px * info.pixelPitch_mm * std::cos(s);
  invPerpPitch_ = 1 / perpPitch_;
  w0_ = o.offset_px * info.pixelPitch_mm * std::cos(s);
  gap_ = o.gap_mm;
  defocus_ = barrier_ ? 1 : 1 - o.gap_mm / o.focalLength_mm;
  halfSlit_ = barrier_ ? 0.5 * o.slitWidth_mm : std::numeric_limits<double>::infinity();
}

double LenticularOptics::acrossLens(const Vec2& p) const {
  const double w = p.x * normal_.x + p.y * normal_.y;
  const double m = roundHalfAway((w - w0_) * invPerpPitch_);
  return w - (w0_ + m * perpPitch_);
}

double LenticularOptics::lensIndex(const Vec2& p) const {
  return roundHalfAway((p.x * normal_.x + p.y * normal_.y - w0_) * invPerpPitch_);
}

Vec2 LenticularOptics::apertureCentre(const Vec2& q) const {
  const double d = acrossLens(q);
  return {q.x - d * normal_.x, q.y - d * normal_.y};
}

DisplayRay LenticularOptics::rayFromPanelPoint(const Vec2& p) const {
  const double d = acrossLens(p);
  const double t = -d / gap_;
  DisplayRay ray;
  ray.origin_mm = {p.x - d * normal_.x, p.y - d * normal_.y, 0};
  ray.direction = Vec3(t * normal_.x, t * normal_.y, 1).normalized();
  return ray;
}

std::optional<Vec2> LenticularOptics::panelPointFromRay(const Vec2& q, const Vec3& d) const {
  if (!(d.z > 0) || !std::isfinite(d.x) || !std::isfinite(d.y)) return std::nullopt;
  if (!(std::abs(q.x) < 1e9 && std::abs(q.y) < 1e9)) return std::nullopt;  // (NaN too): off any panel
  const double t = (d.x * normal_.x + d.y * normal_.y) / d.z;
  const double across = -t * gap_;
  if (!(std::abs(across) <= 0.5 * perpPitch_)) return std::nullopt;
  const double shift = across - acrossLens(q);  // from q across the lens to the pixel
  return Vec2(q.x + shift * normal_.x, q.y + shift * normal_.y);
}

std::optional<Vec2> LenticularOptics::sourceOfRay(const Vec2& q, const Vec3& d) const {
  if (!(d.z > 0)) return std::nullopt;
  const double w = q.x * normal_.x + q.y * normal_.y;
  const double u = q.x * axis_.x + q.y * axis_.y;
  const double wm = w0_ + lensIndex(q) * perpPitch_;  // (the lens the chief-ray model assigns q to)
  const double h = w - wm;
  if (!(std::abs(h) <= halfSlit_)) return std::nullopt;
  const double invZ = 1 / d.z;
  const double tAcross = (d.x * normal_.x + d.y * normal_.y) * invZ;
  const double tAlong = (d.x * axis_.x + d.y * axis_.y) * invZ;
  const double wp = wm + h * defocus_ - gap_ * tAcross;
  const double up = u - gap_ * tAlong;
  return Vec2(up * axis_.x + wp * normal_.x, up * axis_.y + wp * normal_.y);
}

double LenticularOptics::viewCone_rad() const {
  return 2 * std::atan(0.5 * perpPitch_ / gap_);
}

}  // namespace lfi
