// SPDX-License-Identifier: Apache-2.0
#pragma once
// The method's reference step (README, "the method"): the light field an intact part
// produces under a collimated beam, recorded on the plane where the display
// will sit (plane frame of lfi/core/light_field.h; +z towards the part). One
// interface whatever records it:
//
//   scheme  backend                                          where
//   sim:    the simulated lensless light field sensor         lfi_sim (registerSimBackends)
//           behind the part of a scene file, lit by a
//           collimated beam from the camera side
//   coded:  coded patterns through the bench's own display    lfi_controller (registerControllerBackends)
//           and camera: the panel pixels that reach the
//           camera through the intact part (coded_capture.h)
//
// A sensor of its own records the light field; a capture through the bench
// (measuresThroughBench()) is handed the bench's display and camera as a
// BenchProbe by the controller, and measures the panel image the display is
// to show (panelImage()) besides the light field it stands for.
//
// Opened by URI from its registry (capture_registry.h), like cameras and displays.

#include "lfi/core/light_field.h"
#include "lfi/drivers/display.h"

#include <opencv2/core.hpp>

#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace lfi {

// The bench as a capture through it sees it: its display, and the camera's
// image of the part under a panel image.
class BenchProbe {
 public:
  virtual ~BenchProbe() = default;
  // The display's info (panel size, optics).
  virtual DisplayInfo display() const = 0;
  // The camera's full scale in its digital numbers (255, 4095, 65535).
  virtual double cameraFullScale_dn() const = 0;
  // Shows `levels` (CV_8UC1 drive levels, or CV_32FC1 in [0, 1] of full drive;
  // the panel's size; every subpixel of a pixel alike) and returns the camera's
  // image of it, every frame exposed after the show: CV_32FC1, DN. Throws
  // Errc::Device when the display refuses the frame or the camera fails.
  virtual cv::Mat take(const cv::Mat& levels) = 0;
};

class LightFieldCapture {
 public:
  LightFieldCapture() = default;
  LightFieldCapture(const LightFieldCapture&) = delete;
  LightFieldCapture& operator=(const LightFieldCapture&) = delete;
  LightFieldCapture(LightFieldCapture&&) = delete;
  LightFieldCapture& operator=(LightFieldCapture&&) = delete;
  virtual ~LightFieldCapture() = default;

  // What the capture will record (distance_mm = Δ, the plane's distance to the part).
  virtual LightFieldGeometry geometry() const = 0;
  // Sets Δ, the distance from the recording plane to the part: where a sensor
  // of its own records, or what a capture through the bench writes into the
  // light field. Its one owner is the bench file's [geometry] distance_mm,
  // which the controller hands in before capture(); a URI never carries it.
  // Throws Errc::InvalidArgument or Errc::Config for a distance the capture
  // cannot record at.
  virtual void setDistance(double distance_mm) = 0;
  // Records the light field; `progress` gets the fraction done (0..1) from any thread.
  virtual LightField capture(const std::function<void(double)>& progress = {}) = 0;
  // One line naming the source, for logs and file headers.
  virtual std::string description() const = 0;

  // Whether capture() measures through the bench's display and camera: then
  // it needs setBench() first.
  virtual bool measuresThroughBench() const { return false; }
  // The bench to measure through (nullptr: none); the probe outlives capture().
  virtual void setBench(BenchProbe* /*bench*/) {}
  // After capture(): the panel image that shows the reference on the bench's
  // display, CV_32FC1 drive levels in [0, 1] (the panel's size), when the
  // capture measured it there; empty when the display is to show the light
  // field, encoded through its optics.
  virtual cv::Mat panelImage() const { return {}; }
};

}  // namespace lfi
