// SPDX-License-Identifier: Apache-2.0
#pragma once
// The simulated camera's fixed pattern: what stays the same from frame to
// frame and differs from pixel to pixel ([camera_sensor] in a scene file,
// docs/scene-files.md). The truth that dark and flat frames
// (docs/calibration.md) measure.
//
//   response   relative response of each pixel to radiance, the product of
//              vignetting, 1 - v (r / r_corner)^2 with r the pixel centre's
//              distance from the sensor's centre and r_corner the half
//              diagonal (1 at the centre, 1 - v at the corners), and the
//              photo-response non-uniformity, 1 + gainFpn N(0, 1) per pixel
//              (clipped at 0)
//   offset_dn  black level + darkFpn_dn N(0, 1) per pixel, DN at the ADC's
//              bit depth, before quantisation (camera_sensor_model.h)
//
// The deviates are drawn once from patternSeed, per physical pixel, so that
// every camera opened on the scene has the same pattern at every binning: a
// binned pixel's response and offset are the means of its pixels'.

#include "lfi/sim/scene_file.h"

#include <opencv2/core.hpp>

namespace lfi::sim {

struct SensorPattern {
  cv::Mat response;   // CV_32FC1; empty when uniform (no vignetting, no gainFpn)
  cv::Mat offset_dn;  // CV_32FC1; empty when 0 everywhere
};

// The pattern of a width x height sensor binned by `binning` (width / binning
// x height / binning pixels, as TelecentricCamera::binned).
SensorPattern sensorPattern(const CameraSensorParameters& parameters, int width, int height, int binning);

}  // namespace lfi::sim
