#include "lfi/sim/sensors.h"

#include "lfi/core/error.h"

#include <cmath>
#include <numbers>

namespace lfi::sim {

void TelecentricCamera::validate() const {
  auto positive = [](double v, const char* name) {
    if (!(v > 0) || !std::isfinite(v)) fail(Errc::InvalidArgument, "telecentric camera: {} = {} must be > 0", name, v);
  };
  positive(focalLength_mm, "focalLength_mm");
  positive(imageDistance_mm, "imageDistance_mm");
  positive(stopDiameter_mm, "stopDiameter_mm");
  positive(pixelPitch_mm, "pixelPitch_mm");
  if (imageDistance_mm <= focalLength_mm)
    fail(Errc::InvalidArgument, "telecentric camera: imageDistance_mm = {} must exceed focalLength_mm = {} "
         "(otherwise no real object is in focus)", imageDistance_mm, focalLength_mm);
  if (width < 1 || height < 1 || width > 65536 || height > 65536)
    fail(Errc::InvalidArgument, "telecentric camera: size {}x{} is out of range", width, height);
}

Ray TelecentricCamera::ray(int i, int j, const Vec2& pixelOffset, const Vec2& disc) const {
  // Thin lens: the plane in focus is at wz = b f / (b - f) = focusDistance_mm(),
  // imaged with wz / b = f / (b - f); one division for all of it.
  const double b = imageDistance_mm, f = focalLength_mm, k = 1 / (b - f), wz = b * f * k;
  const Vec3 s(-(i + pixelOffset.x - 0.5 * width) * pixelPitch_mm, -(j + pixelOffset.y - 0.5 * height) * pixelPitch_mm,
               -b);
  const Vec3 a(0.5 * stopDiameter_mm * disc.x, 0.5 * stopDiameter_mm * disc.y, -f);
  const Vec3 w(-(f * k) * s.x, -(f * k) * s.y, wz);
  const Vec3 o = s + (a - s) * (b * k);  // z: -b + (b - f) b / (b - f) = 0
  const Vec3 chord = w - o;
  const Vec3 dir = chord * (1 / std::sqrt(chord.dot(chord)));
  return {worldFromCamera.point(Vec3(o.x, o.y, 0)), worldFromCamera.vector(dir)};
}

Vec2 TelecentricCamera::project(const Vec3& worldPoint) const {
  const Vec3 c = worldFromCamera.inverse().point(worldPoint);
  const double m = magnification();
  // Chief ray is parallel to the axis: w = (c.x, c.y); s = -m w; s = -(i - W/2) p.
  return {c.x * m / pixelPitch_mm + 0.5 * width, c.y * m / pixelPitch_mm + 0.5 * height};
}

Rigid3 TelecentricCamera::lookingDownFrom(double lensZ) {
  Rigid3 x = Rigid3::rotation({1, 0, 0}, std::numbers::pi);  // x -> x, y -> -y, z -> -z
  x.t = {0, 0, lensZ};
  return x;
}

std::optional<Ray> LightFieldSensor::ray(int col, int row, const Vec2& pixelOffset) const {
  const int n = geometry.angular;
  const int ex = col / n, ey = row / n, u = col % n, v = row % n;
  const Vec2 disc((2.0 * (u + pixelOffset.x)) / n - 1, (2.0 * (v + pixelOffset.y)) / n - 1);
  if (disc.x * disc.x + disc.y * disc.y >= 1) return std::nullopt;
  const double e = geometry.elementPitch_mm();
  const Vec3 origin((ex + 0.5 - 0.5 * geometry.spatialX) * e, (ey + 0.5 - 0.5 * geometry.spatialY) * e, 0);
  return Ray{worldFromSensor.point(origin), worldFromSensor.vector(LightField::directionFromDisc(disc))};
}

}  // namespace lfi::sim
