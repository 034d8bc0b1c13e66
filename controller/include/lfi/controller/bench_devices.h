// SPDX-License-Identifier: Apache-2.0
#pragma once
// A bench file's devices, opened through the backend registries (which the
// program fills first: registerDriverBackends(), lfi::sim::registerSimBackends()).

#include "lfi/controller/bench_file.h"
#include "lfi/controller/controller.h"
#include "lfi/drivers/camera.h"
#include "lfi/drivers/display.h"
#include "lfi/drivers/light_field_capture.h"

#include <memory>
#include <string>

namespace lfi {

// A light field held in memory (read from a file or a reference package) in
// the place of a capture device: capture() returns it.
class StoredLightField final : public LightFieldCapture {
 public:
  StoredLightField(LightField lightField, std::string description)
      : lightField_(std::move(lightField)), description_(std::move(description)) {}
  LightFieldGeometry geometry() const override { return lightField_.geometry(); }
  // The light field was recorded at its own Δ: Errc::Config naming the
  // description when that is set (not 0) and another than `distance_mm`.
  void setDistance(double distance_mm) override;
  LightField capture(const std::function<void(double)>&) override { return lightField_; }
  const LightField& lightField() const { return lightField_; }
  std::string description() const override { return description_; }

 private:
  LightField lightField_;
  std::string description_;
};

// The capture of a controller that only shows panels and takes images (the
// calibrations, through Controller::probe()): there is nothing to capture,
// and capture() throws Errc::InvalidArgument.
class NoCapture final : public LightFieldCapture {
 public:
  LightFieldGeometry geometry() const override { return {}; }
  void setDistance(double) override {}
  LightField capture(const std::function<void(double)>&) override;
  std::string description() const override { return "none (a controller that only shows panels and takes images)"; }
};

// Who says when the bench's camera exposes.
enum class BenchExposures {
  AsBench,    // its [camera] trigger: a line-triggered camera exposes when a part sensor fires (inspect, train, run)
  OnRequest,  // lfi, whatever the bench's trigger: a line-triggered camera is software-triggered, since no part
              // passes the sensor while the bench calibrates or takes its reference (calibrate, capture)
};

// The camera, opened and configured with the bench's settings (its trigger as `exposures` says).
std::unique_ptr<Camera> openBenchCamera(const BenchFile& bench, BenchExposures exposures = BenchExposures::AsBench);
// The display, with the optics of [display.optics] in place of the device's own when the bench states them
// (Errc::Config naming the bench file when they are of another class than the device's, or out of range).
std::unique_ptr<Display> openBenchDisplay(const BenchFile& bench);
// The capture device, or the bench's light field file as a StoredLightField,
// handed the bench's Δ ([geometry] distance_mm). Errc::Config naming the bench
// file when the capture cannot record at Δ, or the file was recorded at another.
std::unique_ptr<LightFieldCapture> openBenchCapture(const BenchFile& bench);
// The controller's options from the bench's [camera], [display] and `frames`;
// with `correctFrames`, the correction of its dark and flat frames
// (frame_correction.h).
ControllerOptions controllerOptions(const BenchFile& bench, int frames, bool correctFrames = true);
// "<vendor> <model> <serial> (<uri>)" for records.
std::string describeCamera(Camera& camera, const DeviceUri& uri);

}  // namespace lfi
