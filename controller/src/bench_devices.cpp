// SPDX-License-Identifier: Apache-2.0
#include "lfi/controller/bench_devices.h"

#include "lfi/controller/frame_correction.h"

#include "lfi/core/error.h"
#include "lfi/core/exr_io.h"
#include "lfi/drivers/camera_registry.h"
#include "lfi/drivers/capture_registry.h"
#include "lfi/drivers/display_registry.h"

#include <fmt/format.h>

namespace lfi {

LightField NoCapture::capture(const std::function<void(double)>&) {
  fail(Errc::InvalidArgument, "this controller has no reference capture: it only shows panels and takes images");
}

std::unique_ptr<Camera> openBenchCamera(const BenchFile& bench, BenchExposures exposures) {
  auto camera = openCamera(bench.cameraUri);
  CameraSettings settings = bench.camera;
  if (exposures == BenchExposures::OnRequest && settings.trigger == TriggerMode::Line)
    settings.trigger = TriggerMode::Software;
  camera->configure(settings);
  return camera;
}

namespace {

// The bench's display with the optics its [display.optics] states in place of the device's own (or in place of
// none, for a monitor): what a light field is encoded through (Display::show) and what a coded capture decodes
// with.
class CalibratedDisplay final : public Display {
 public:
  CalibratedDisplay(std::unique_ptr<Display> inner, const DisplayOpticsParams& optics, std::string benchFile)
      : inner_(std::move(inner)), optics_(optics), benchFile_(std::move(benchFile)) {}
  State state() const override { return inner_->state(); }
  std::string name() const override { return inner_->name(); }
  void open() override { inner_->open(); }
  void close() noexcept override { inner_->close(); }
  DisplayInfo info() const override {
    DisplayInfo info = inner_->info();
    if (info.opticsStated && info.optics.type != optics_.type)
      fail(Errc::Config, "{}: [display.optics] states {} optics; display '{}' has {} optics", benchFile_,
           toString(optics_.type), inner_->name(), toString(info.optics.type));
    info.optics = optics_;
    info.opticsStated = true;
    try {
      info.validate();
    } catch (const Error& e) {
      fail(Errc::Config, "{}: [display.optics] on display '{}': {}", benchFile_, inner_->name(), e.what());
    }
    return info;
  }
  PresentResult show(const cv::Mat& panel) override { return inner_->show(panel); }
  void blank() override { inner_->blank(); }
  void setBrightness(int level) override { inner_->setBrightness(level); }
  DisplayStatus status() override { return inner_->status(); }

 private:
  std::unique_ptr<Display> inner_;
  DisplayOpticsParams optics_;
  std::string benchFile_;
};

}  // namespace

std::unique_ptr<Display> openBenchDisplay(const BenchFile& bench) {
  auto display = openDisplay(bench.displayUri);
  if (!bench.displayOptics) return display;
  auto calibrated = std::make_unique<CalibratedDisplay>(std::move(display), *bench.displayOptics, bench.file.string());
  if (calibrated->state() != Display::State::Closed) calibrated->info();  // a class that does not fit: named now
  return calibrated;
}

void StoredLightField::setDistance(double distance_mm) {
  const double recorded = lightField_.geometry().distance_mm;
  if (recorded != 0 && recorded != distance_mm)
    fail(Errc::Config, "{} was recorded {} mm below the part, not at Δ = {} mm", description_, recorded, distance_mm);
}

std::unique_ptr<LightFieldCapture> openBenchCapture(const BenchFile& bench) {
  std::unique_ptr<LightFieldCapture> capture =
      bench.captureUri ? openLightFieldCapture(*bench.captureUri)
                       : std::make_unique<StoredLightField>(readLightFieldExr(bench.lightFieldFile),
                                                            "light field file " + bench.lightFieldFile.string());
  try {
    capture->setDistance(bench.distance_mm);
  } catch (const Error& e) {
    fail(Errc::Config, "{}: [geometry] distance_mm = {}: {}", bench.file.string(), bench.distance_mm, e.what());
  }
  return capture;
}

ControllerOptions controllerOptions(const BenchFile& bench, int frames, bool correctFrames) {
  ControllerOptions o;
  o.grabTimeout = std::chrono::milliseconds(bench.grabTimeout_ms);
  o.frames = frames;
  o.retries = bench.retries;
  o.white = bench.white;
  o.settle = std::chrono::milliseconds(bench.settle_ms);
  if (correctFrames) o.correction = loadFrameCorrection(bench);
  o.panelResponse = bench.panelResponse;
  return o;
}

std::string describeCamera(Camera& camera, const DeviceUri& uri) {
  const CameraInfo info = camera.info();
  return fmt::format("{} {} {} ({})", info.vendor, info.model, info.serial, uri);
}

}  // namespace lfi
