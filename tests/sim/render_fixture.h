// SPDX-License-Identifier: Apache-2.0
#pragma once
// The renderer's test bench: a telecentric camera looking down -z and a back
// light below it (render_transport_test.cpp, render_driver_test.cpp).

#include "lfi/core/geometry.h"
#include "lfi/sim/scene.h"
#include "lfi/sim/sensors.h"

#include <cmath>
#include <numbers>

namespace lfi::testing_support {

// A camera looking down -z, focused on the plane z = focusZ, with an object
// pixel of fieldMm / size and acceptance half-angle acceptance (f = 100, b = 200, m = 1).
inline sim::TelecentricCamera cameraAbove(double focusZ, int size, double fieldMm, double acceptance) {
  sim::TelecentricCamera cam;
  cam.focalLength_mm = 100;
  cam.imageDistance_mm = 200;
  cam.stopDiameter_mm = 2 * cam.focalLength_mm * std::tan(acceptance);
  cam.pixelPitch_mm = fieldMm / size;  // magnification b / wz = 1
  cam.width = size;
  cam.height = size;
  cam.worldFromCamera = sim::TelecentricCamera::lookingDownFrom(focusZ + cam.focusDistance_mm());
  return cam;
}

inline sim::Object emitterBelow(double z, sim::Emission emission, bool facingUp = true) {
  Rigid3 x = facingUp ? Rigid3() : Rigid3::rotation({1, 0, 0}, std::numbers::pi);
  x.t = {0, 0, z};
  return {.name = "backlight", .shape = sim::Rectangle{400, 400}, .worldFromObject = x, .emission = emission};
}

}  // namespace lfi::testing_support
