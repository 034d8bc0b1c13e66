// SPDX-License-Identifier: Apache-2.0
#include "lfi/sim/sensors.h"

#include "lfi/core/error.h"
#include "lfi/core/exr_io.h"

#include <cmath>
#include <limits>
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
    fail(Errc::InvalidArgument,
         "telecentric camera: imageDistance_mm = {} must exceed focalLength_mm = {} "
         "(otherwise no real object is in focus)",
         imageDistance_mm, focalLength_mm);
  if (width < 1 || height < 1 || width > 65536 || height > 65536 || static_cast<long>(width) * height > kMaxExrPixels)
    fail(Errc::InvalidArgument,
         "telecentric camera: size {}x{} is out of range (1..65536 a side, at most 2^30 "
         "pixels: what a radiance EXR holds)",
         width, height);
  if (knifeEdge && !(*knifeEdge >= -1 && *knifeEdge <= 1))
    fail(Errc::InvalidArgument, "telecentric camera: knifeEdge = {} is outside [-1, 1] (units of the stop's radius)",
         *knifeEdge);
}

TelecentricCamera::RayMap::RayMap(const TelecentricCamera& cam)
    : world(cam.worldFromCamera),
      halfW(0.5 * cam.width),
      halfH(0.5 * cam.height),
      edge(cam.knifeEdge ? *cam.knifeEdge : std::numeric_limits<double>::infinity()) {
  // Thin lens: the plane in focus is at wz = b f / (b - f) = focusDistance_mm().
  const double b = cam.imageDistance_mm, f = cam.focalLength_mm, k = 1 / (b - f), wz = b * f * k;
  pixel = f * k * cam.pixelPitch_mm;
  stop = b * k * 0.5 * cam.stopDiameter_mm;
  slope = stop / wz;
}

Ray TelecentricCamera::ray(int i, int j, const Vec2& pixelOffset, const Vec2& disc) const {
  return RayMap(*this)(i, j, pixelOffset, disc);
}

Vec2 TelecentricCamera::project(const Vec3& worldPoint) const {
  const Vec3 c = worldFromCamera.inverse().point(worldPoint);
  const double m = magnification();
  // Chief ray is parallel to the axis: w = (c.x, c.y); s = -m w; s = -(i - W/2) p.
  return {c.x * m / pixelPitch_mm + 0.5 * width, c.y * m / pixelPitch_mm + 0.5 * height};
}

TelecentricCamera TelecentricCamera::binned(int b) const {
  if (b < 1) fail(Errc::InvalidArgument, "telecentric camera: binning {} must be >= 1", b);
  TelecentricCamera c = *this;
  c.width = width / b, c.height = height / b;
  c.pixelPitch_mm = pixelPitch_mm * b;
  // The grid is centred on the axis: with a remainder its centre would sit half
  // the dropped pixels off the blocks' centre. Moved sideways in its own frame
  // by that much (object side; a telecentric camera images the same then).
  const double dx = 0.5 * (width % b) * objectPixel_mm(), dy = 0.5 * (height % b) * objectPixel_mm();
  c.worldFromCamera.t = worldFromCamera.point({-dx, -dy, 0});
  return c;
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
