// SPDX-License-Identifier: Apache-2.0
#pragma once
// The sim: light field capture (the method's capture step): the parts of a scene file,
// lit by a collimated beam from the camera side, recorded by the lensless
// light field sensor (sensors.h) on the plane Δ below the part.
//
//   URI: sim:<scene-file>[?<key>=<value>&...]
//   key                  default  units  meaning
//   spatial              40       -      spatial elements per side
//   angular              16       -      angular elements per side
//   pitch_mm             0.05     mm     sensor pixel pitch
//   beam_half_angle_rad  0.0087   rad    divergence of the collimated beam
//   beam_distance_mm     50       mm     beam plane at world z = +beam_distance_mm, facing -z
//   spp                  64       -      samples per sensor pixel
//
// Δ is not a key: the sensor's plane lies at world z = -Δ, looking +z, with Δ
// the bench's [geometry] distance_mm, handed in by setDistance()
// (SimCaptureSettings's geometry.distance_mm until then).
//
// The scene's emitters (back lights, displays) are left out; its sensor and
// render settings are not used (the seed is). Every part's bounding box must
// lie between the sensor's plane and the beam's (Errc::Config at open).

#include "lfi/drivers/light_field_capture.h"

#include <opencv2/core.hpp>

#include <filesystem>
#include <functional>
#include <memory>

namespace lfi::sim {

struct SimCaptureSettings {
  LightFieldGeometry geometry{.spatialX = 40, .spatialY = 40, .angular = 16, .pixelPitch_mm = 0.05, .distance_mm = 30};
  double beamHalfAngle_rad = 0.0087;
  double beamDistance_mm = 50;
  int samplesPerPixel = 64;
  int threads = 0;
};

std::unique_ptr<LightFieldCapture> openSimLightFieldCapture(const std::filesystem::path& sceneFile,
                                                            const SimCaptureSettings& settings);

// The reference in the display's own ray space, the other way to capture it:
// for every panel subpixel of the scene file's [display] (a lenslet or pinhole
// array), the radiance the collimated capture beam sends back along the rays
// that subpixel emits through its own lens or pinhole (by reversibility),
// traced through the scene's parts from `samplesPerPixel` points spread over
// the subpixel and over the lens's clear aperture (or pinhole). Nothing is
// resampled through the light field's parametrisation: this panel image, scaled
// to drive levels, is what the display shows. CV_32FC1 of panelHeight x
// (panelWidth · subpixels), relative radiance (the beam's is 1), the layout of
// the sim: display's level image (scene.h, panelLevels). Uses the settings'
// beam and spp, not its light field geometry.
cv::Mat capturePanelReference(const std::filesystem::path& sceneFile, const SimCaptureSettings& settings,
                              const std::function<void(double)>& progress = {});

// Registers the "sim" light field capture scheme. Idempotent.
void registerSimLightFieldCapture();

}  // namespace lfi::sim
