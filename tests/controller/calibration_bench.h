// SPDX-License-Identifier: Apache-2.0
#pragma once
// The ray-traced bench the calibration tests measure through: the camera of
// data/scenes/inspection_bench.toml (56 x 56 Mono12 pixels of 0.1215 mm at
// magnification 0.2435: 0.5 mm on the part, focused 102.5 mm below it), and
// the bench's devices opened on a scene file with the controller's probe.

#include "lfi/controller/bench_devices.h"
#include "lfi/controller/controller.h"
#include "lfi/drivers/camera_registry.h"
#include "lfi/drivers/display_registry.h"

#include "normalised_errors.h"
#include "scene_text.h"

#include <cmath>
#include <string>

namespace lfi::testing_support {

inline constexpr double kBenchFocal_mm = 20.03, kBenchImageDistance_mm = 24.9075, kBenchSensorPixel_mm = 0.1215;

// The camera looking down at the plane z = 0 from above, its axis at `axis_mm` across it; `sensorPixel_mm` sets
// its scale on the part (objectPixel_mm).
inline SceneCamera inspectionBenchCamera(int samplesPerPixel, int seed, double sensorPixel_mm = kBenchSensorPixel_mm,
                                         double axisX_mm = 0, double axisY_mm = 0) {
  return {.samplesPerPixel = samplesPerPixel,
          .seed = seed,
          .focalLength_mm = kBenchFocal_mm,
          .imageDistance_mm = kBenchImageDistance_mm,
          .stopDiameter_mm = 0.609,
          .pixelPitch_mm = sensorPixel_mm,
          .width_px = 56,
          .height_px = 56,
          .positionX_mm = axisX_mm,
          .positionY_mm = axisY_mm,
          .positionZ_mm = 102.5,
          .fullWell_e = 10500,
          .readNoise_e = 2.4,
          .bitDepth = 12};
}

// One camera pixel on the part: the sensor pixel over the magnification b / w (docs/camera.md).
inline double objectPixel_mm(double sensorPixel_mm) {
  const double w = 1 / (1 / kBenchFocal_mm - 1 / kBenchImageDistance_mm);
  return sensorPixel_mm * w / kBenchImageDistance_mm;
}

// The camera's settings: 10 ms, Mono12, software-triggered.
inline CameraSettings benchCameraSettings() {
  CameraSettings settings;
  settings.exposure_us = 10000;
  settings.pixelFormat = PixelFormat::Mono12;
  settings.trigger = TriggerMode::Software;
  return settings;
}

// Opens the sim: display and camera on `uri`, the camera configured with `settings`, and returns what `f` makes
// of the controller's probe.
template <typename F>
auto throughSimBench(const std::string& uri, F&& f, const CameraSettings& settings = benchCameraSettings()) {
  auto display = openDisplay(uri);
  auto camera = openCamera(uri);
  camera->configure(settings);
  NoCapture nothing;
  Controller controller(nothing, *display, *camera);
  return f(controller.probe());
}

}  // namespace lfi::testing_support
