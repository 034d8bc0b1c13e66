// SPDX-License-Identifier: Apache-2.0
#pragma once
// The scene-file text (docs/scene-files.md) of the device tests' benches: a
// camera looking down the z axis at the plane z = 0, and the objects under it.

#include <fmt/format.h>

#include <optional>
#include <string>

namespace lfi::testing_support {

// What the benches' cameras differ in; the defaults are a 100 mm lens that
// images the plane z = 0 at magnification 1 from 200 mm above it.
struct SceneCamera {
  int samplesPerPixel = 1;
  int seed = 1;
  double focalLength_mm = 100;
  double imageDistance_mm = 200;
  double stopDiameter_mm = 2;
  double pixelPitch_mm = 0.5;
  int width_px = 64;
  int height_px = 64;
  double positionX_mm = 0;  // the camera's axis across the plane
  double positionY_mm = 0;
  double positionZ_mm = 200;
  double fullWell_e = 20000;
  double readNoise_e = 5;
  int bitDepth = 12;
  std::optional<double> electronsPerUnitPerUs;  // none: the scene file's default
};

// The start of a scene file: its format line and the [render], [camera] and
// [camera_sensor] tables; the caller appends the rest.
inline std::string cameraSceneText(const SceneCamera& c) {
  std::string text = fmt::format(R"(format = "lfi-scene"
version = 1
[render]
samples_per_pixel = {}
seed = {}
[camera]
focal_length_mm = {}
image_distance_mm = {}
stop_diameter_mm = {}
pixel_pitch_mm = {}
width = {}
height = {}
position_mm = [{}, {}, {}]
rotation_deg = [180, 0, 0]
[camera_sensor]
full_well_e = {}
read_noise_e = {}
bit_depth = {}
)",
                                 c.samplesPerPixel, c.seed, c.focalLength_mm, c.imageDistance_mm, c.stopDiameter_mm,
                                 c.pixelPitch_mm, c.width_px, c.height_px, c.positionX_mm, c.positionY_mm,
                                 c.positionZ_mm, c.fullWell_e, c.readNoise_e, c.bitDepth);
  if (c.electronsPerUnitPerUs) text += fmt::format("electrons_per_unit_per_us = {}\n", *c.electronsPerUnitPerUs);
  return text;
}

// A Lambertian back light of radiance 1, 400 mm square, 100 mm below the plane
// z = 0: it fills the field of the cameras above.
inline constexpr const char* kBackLightObject = R"([[object]]
name = "back light"
shape = "rectangle"
size_mm = [400, 400]
position_mm = [0, 0, -100]
emitter = "lambertian"
radiance = 1
)";

// A symmetric biconvex glass lens at the origin.
struct SceneLens {
  double radius_mm;  // of both faces
  double centreThickness_mm;
  double diameter_mm;
  double ior;
};

inline std::string lensObject(const SceneLens& l) {
  return fmt::format(R"([[object]]
name = "lens"
shape = "lens"
front_radius_mm = {}
back_radius_mm = {}
centre_thickness_mm = {}
diameter_mm = {}
material = "dielectric"
ior = {}
)",
                     l.radius_mm, -l.radius_mm, l.centreThickness_mm, l.diameter_mm, l.ior);
}

}  // namespace lfi::testing_support
