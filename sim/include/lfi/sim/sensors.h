// SPDX-License-Identifier: Apache-2.0
#pragma once
// Sensors of the ray tracer: each maps a pixel sample (and, for the camera, an
// aperture sample) to a ray of sight in the world frame, exactly as the paper models them.
//
// TelecentricCamera (object-side telecentric thin lens with depth of field)
//   parameter         symbol  units  meaning
//   focalLength_mm    f       mm     focal length of the thin lens
//   imageDistance_mm  b       mm     sensor to lens; focused object distance wz = (1/f - 1/b)^-1
//   stopDiameter_mm   D       mm     telecentric stop in the image-side focal plane;
//                                    object-side acceptance half-angle ≈ D / (2 f)
//   pixelPitch_mm     -       mm     sensor pixel pitch (after binning)
//   width, height     -       px     pixel counts
//   worldFromCamera   -       -      camera frame: lens centre at the origin, +z towards the
//                                    object (the viewing direction), x right, y down in the
//                                    image; the sensor lies at z = -b, the stop at z = -f.
// Pixel (i, j) with in-pixel offset (ju, jv) in [0,1)^2 sits at sensor position
// s = -((i + ju - W/2) p, (j + jv - H/2) p): the sign undoes the lens's
// inversion, so images come out upright (row 0 = camera -y).
// A stop sample a (uniform on the disc of diameter D) gives
//   w = (-(wz/b) sx, -(wz/b) sy, wz), o = line(s, a) ∩ {z = 0}, ray o + α (w - o).
// A knife edge in the stop plane (conventional schlieren) blocks the stop
// where a.x > knifeEdge (camera frame, in units of the stop's radius): the
// object-side rays tilted towards camera -x by more than knifeEdge times the
// acceptance half-angle; a blocked sample is 0.
//
// LightFieldSensor (lensless): see lfi/core/light_field.h for the
// parametrisation; worldFromSensor places the plane frame. A pixel sample p
// starts at the centre of its spatial element and looks along
// d = normalise(-px, -py, sqrt(1 - px^2 - py^2)); samples with px^2+py^2 >= 1
// carry no ray (radiance 0).

#include "lfi/core/geometry.h"
#include "lfi/core/light_field.h"
#include "lfi/sim/solid.h"

#include <cmath>
#include <optional>
#include <variant>

namespace lfi::sim {

struct TelecentricCamera {
  double focalLength_mm = 100;
  double imageDistance_mm = 200;
  double stopDiameter_mm = 2;
  double pixelPitch_mm = 0.1;
  int width = 256;
  int height = 256;
  Rigid3 worldFromCamera;
  std::optional<double> knifeEdge;  // in [-1, 1]; none: the whole circular stop

  double focusDistance_mm() const { return 1.0 / (1.0 / focalLength_mm - 1.0 / imageDistance_mm); }
  double magnification() const { return imageDistance_mm / focusDistance_mm(); }
  double objectPixel_mm() const { return pixelPitch_mm / magnification(); }
  double acceptanceHalfAngle_rad() const { return std::atan(0.5 * stopDiameter_mm / focalLength_mm); }
  void validate() const;  // throws Errc::InvalidArgument naming the field

  // pixel + offset in [0,1)^2, stop sample in the unit disc.
  Ray ray(int i, int j, const Vec2& pixelOffset, const Vec2& unitDiscSample) const;
  // Whether the stop passes the sample (the knife edge's side of it).
  bool passes(const Vec2& unitDiscSample) const { return !knifeEdge || unitDiscSample.x <= *knifeEdge; }

  // ray() with the camera's constants worked out once, for the renderer's inner loop.
  // With k = 1/(b - f) the formulas above reduce to: o = (P (i + ju - W/2) + Q ax,
  // P (j + jv - H/2) + Q ay, 0) and w - o = (-Q ax, -Q ay, wz), where P = f k p is
  // the object-side pixel, Q = b k D/2 and wz = b f k: rays through one stop point
  // are parallel (telecentric), and the stop sample alone sets the direction.
  struct RayMap {
    explicit RayMap(const TelecentricCamera& cam);
    Ray operator()(int i, int j, const Vec2& pixelOffset, const Vec2& disc) const {
      Ray ray;
      trace(i + pixelOffset.x, j + pixelOffset.y, disc.x, disc.y, ray.origin.x, ray.origin.y, ray.origin.z,
            ray.direction.x, ray.direction.y, ray.direction.z);
      return ray;
    }
    // The same on plain numbers (the renderer's vectorised pass): sensor
    // position (x, y) in pixels, stop sample (ax, ay); world-frame origin o and direction d.
    void trace(double x, double y, double ax, double ay, double& ox, double& oy, double& oz, double& dx, double& dy,
               double& dz) const {
      const double cx = pixel * (x - halfW) + stop * ax, cy = pixel * (y - halfH) + stop * ay;  // camera frame, z = 0
      const double sx = -slope * ax, sy = -slope * ay, inv = 1 / std::sqrt(1 + sx * sx + sy * sy);
      const double ex = sx * inv, ey = sy * inv;
      const double* r = world.r.data();
      ox = r[0] * cx + r[1] * cy + world.t.x, oy = r[3] * cx + r[4] * cy + world.t.y;
      oz = r[6] * cx + r[7] * cy + world.t.z;
      dx = r[0] * ex + r[1] * ey + r[2] * inv, dy = r[3] * ex + r[4] * ey + r[5] * inv;
      dz = r[6] * ex + r[7] * ey + r[8] * inv;
    }
    Rigid3 world;                             // worldFromCamera
    double pixel, stop, slope, halfW, halfH;  // P, Q, Q / wz, W/2, H/2
    double edge;  // the knife edge (+infinity without one): stop samples with ax > edge are blocked
  };
  // Where the world point projects on the image (continuous pixel coordinates;
  // exact on the focal plane, the chief ray elsewhere).
  Vec2 project(const Vec3& worldPoint) const;
  // A camera looking down -z from z = lensZ, focused at world z = lensZ - wz.
  static Rigid3 lookingDownFrom(double lensZ);
  // The same camera binned b x b, as a sensor bins: pixel (i, j) covers the
  // block of pixels b i .. b i + b - 1, b j .. b j + b - 1; a remainder of
  // width or height that makes no whole block is dropped (right, bottom).
  TelecentricCamera binned(int b) const;
};

struct LightFieldSensor {
  LightFieldGeometry geometry;
  Rigid3 worldFromSensor;

  // The ray of sight of a sample at (col + offset.x, row + offset.y) of the
  // lenslet image; nullopt outside the hemisphere mapping.
  std::optional<Ray> ray(int col, int row, const Vec2& pixelOffset) const;
};

using Sensor = std::variant<TelecentricCamera, LightFieldSensor>;

inline int sensorWidth(const Sensor& s) {
  return std::visit(
      [](const auto& x) {
        if constexpr (std::is_same_v<std::decay_t<decltype(x)>, TelecentricCamera>)
          return x.width;
        else
          return x.geometry.width();
      },
      s);
}
inline int sensorHeight(const Sensor& s) {
  return std::visit(
      [](const auto& x) {
        if constexpr (std::is_same_v<std::decay_t<decltype(x)>, TelecentricCamera>)
          return x.height;
        else
          return x.geometry.height();
      },
      s);
}

}  // namespace lfi::sim
