// SPDX-License-Identifier: Apache-2.0
// ServedBench (served_bench.h): a SimImager behind a GvCameraServer, and an
// EmulatedUsbDisplay whose panel drives the imager's SimBench.

#include "lfi/emulation/served_bench.h"

#include "lfi/core/error.h"
#include "lfi/drivers/driver_trace.h"
#include "lfi/drivers/usb/usb_display_protocol.h"
#include "lfi/sim/devices/sim_camera.h"

#include <fmt/format.h>

#include <chrono>
#include <mutex>
#include <optional>
#include <utility>

namespace lfi::emulation {

namespace fs = std::filesystem;
namespace proto = usbdisplay;

namespace {

proto::SubpixelCode subpixelCode(SubpixelLayout layout) {
  switch (layout) {
    case SubpixelLayout::RgbStripe:
      return proto::SubpixelCode::RgbStripe;
    case SubpixelLayout::BgrStripe:
      return proto::SubpixelCode::BgrStripe;
    case SubpixelLayout::Mono:
      break;
  }
  return proto::SubpixelCode::Mono;
}

// The USB device that is the scene's display: its panel, optics and brightness range, the identity given.
EmulatedDisplayConfig displayConfig(const sim::SimBench& bench, EmulatedDisplayConfig config) {
  if (!bench.hasDisplay())
    fail(Errc::Config, "simulated bench: the scene file '{}' has no [display] table (docs/scene-files.md)",
         bench.sceneFile().string());
  const DisplayInfo& info = bench.description().display->info;
  constexpr int kMaxU16 = 0xffff;
  if (info.panelWidth_px > kMaxU16 || info.panelHeight_px > kMaxU16 || info.brightnessMax > kMaxU16)
    fail(Errc::Config,
         "simulated bench '{}': a {} x {} panel with brightness_max {} does not fit the USB display "
         "protocol's 16-bit fields",
         bench.sceneFile().string(), info.panelWidth_px, info.panelHeight_px, info.brightnessMax);
  config.vendor = info.vendor;
  config.model = info.model;
  config.panelWidth_px = info.panelWidth_px;
  config.panelHeight_px = info.panelHeight_px;
  config.subpixels = subpixelCode(info.subpixels);
  config.brightnessMax = info.brightnessMax;
  config.viewCount = info.viewCount;
  config.calibration = proto::toCalibrationBlock(info.pixelPitch_mm, info.optics);
  return config;
}

}  // namespace

struct ServedBench::Impl {
  ServedBenchOptions options;
  sim::TelecentricCamera camera0;  // the bench's camera and display panel, which every part's scene has
  DisplayInfo displayInfo;

  // The part: its imager (used on Aravis's device thread only, under partMutex).
  mutable std::mutex partMutex;
  std::unique_ptr<sim::SimImager> imager;
  fs::path part;
  cv::Mat frame;

  // What the display shows, replayed onto each new part's bench (under displayMutex, taken before partMutex).
  mutable std::mutex displayMutex;
  cv::Mat panel;  // the last presented (the device keeps it; a new frame is a new image)
  bool lit = false;
  int backlight = 0;

  mutable std::mutex devicesMutex;  // the servers' lifetimes
  std::unique_ptr<GvCameraServer> camera;
  std::unique_ptr<EmulatedUsbDisplay> display;
  double packetLoss = 0;

  mutable std::mutex countersMutex;
  ServedBenchCounters counters;

  // Applies the display's state to `bench` (under displayMutex).
  void replay(sim::SimBench& bench) const {
    bench.setBacklight(backlight);
    if (lit)
      bench.showPanel(panel);
    else
      bench.blankPanel();
  }

  sim::SimBench& bench() const {
    std::lock_guard lock(partMutex);
    return imager->bench();
  }

  void fill(const ServedFrameRequest& request, cv::Mat& image) {
    const auto start = std::chrono::steady_clock::now();
    {
      std::lock_guard lock(partMutex);
      imager->capture(imager->resolve(request.settings(), "served camera '" + options.camera.serial + "'"),
                      request.frameId, frame);
      writeServedFrame(frame, image);
    }
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    traceDriverCall("served", options.camera.serial, "frame",
                    fmt::format("{} in {:.3f} ms", request.frameId, 1e3 * seconds));
    std::lock_guard lock(countersMutex);
    ++counters.framesServed;
    counters.frameSeconds += seconds;
  }

  void startCamera() {
    GvCameraServerOptions o = options.camera;
    o.sensorWidth_px = camera0.width;
    o.sensorHeight_px = camera0.height;
    camera =
        std::make_unique<GvCameraServer>(o, [this](const ServedFrameRequest& r, cv::Mat& image) { fill(r, image); });
    if (packetLoss > 0) camera->setPacketLoss(packetLoss);
  }

  // The display's observer: each change goes to the part's bench, before the device answers the request.
  EmulatedUsbDisplay::PanelObserver observer() {
    return {.presented =
                [this](const cv::Mat& presented, std::uint32_t sequence) {
                  std::lock_guard lock(displayMutex);
                  panel = presented;
                  lit = true;
                  bench().showPanel(panel);
                  traceDriverCall("served", options.display.serial, "present", std::to_string(sequence));
                  std::lock_guard counting(countersMutex);
                  ++counters.panelsPresented;
                },
            .brightness =
                [this](int level) {
                  std::lock_guard lock(displayMutex);
                  backlight = level;
                  bench().setBacklight(level);
                },
            .blanked =
                [this] {
                  std::lock_guard lock(displayMutex);
                  lit = false;
                  bench().blankPanel();
                }};
  }
};

ServedBench::ServedBench(ServedBenchOptions options) : impl_(new Impl) {
  Impl& d = *impl_;
  d.options = std::move(options);
  d.imager = std::make_unique<sim::SimImager>(d.options.scene);
  d.imager->setRenderOptions(d.options.renderThreads, {});
  d.part = d.options.scene;
  d.camera0 = d.imager->camera();
  d.options.display = displayConfig(d.imager->bench(), d.options.display);
  d.displayInfo = d.imager->bench().description().display->info;
  d.backlight = d.imager->bench().backlight();
  d.replay(d.imager->bench());
  d.startCamera();
  d.display = std::make_unique<EmulatedUsbDisplay>(d.options.display);
  d.display->observePanel(d.observer());
  d.display->plug();
}

ServedBench::~ServedBench() {
  // The devices first: their threads call into the part.
  impl_->display.reset();
  impl_->camera.reset();
}

DeviceUri ServedBench::cameraUri() const {
  const GvCameraServerOptions& o = impl_->options.camera;
  return {.scheme = "aravis", .path = fmt::format("{}-{}-{}", o.vendor, o.model, o.serial)};
}

DeviceUri ServedBench::displayUri() const {
  const EmulatedDisplayConfig& c = impl_->options.display;
  return {.scheme = "usb", .path = fmt::format("{:04x}:{:04x}/{}", c.vendorId, c.productId, c.serial)};
}

bool ServedBench::putPart(const fs::path& scene) {
  Impl& d = *impl_;
  auto imager = std::make_unique<sim::SimImager>(scene);
  imager->setRenderOptions(d.options.renderThreads, {});
  const sim::TelecentricCamera &ours = d.camera0, &theirs = imager->camera();
  if (theirs.width != ours.width || theirs.height != ours.height || theirs.pixelPitch_mm != ours.pixelPitch_mm)
    fail(Errc::Config,
         "part '{}': its camera ({} x {} pixels of {} mm) is not the bench's ({} x {} of {} mm); a "
         "part's scene is the bench's with another part in place",
         scene.string(), theirs.width, theirs.height, theirs.pixelPitch_mm, ours.width, ours.height,
         ours.pixelPitch_mm);
  const DisplayInfo& panel = d.displayInfo;
  const sim::SimBench& bench = imager->bench();
  const DisplayInfo* other = bench.hasDisplay() ? &bench.description().display->info : nullptr;
  if (!other || other->panelWidth_px != panel.panelWidth_px || other->panelHeight_px != panel.panelHeight_px ||
      other->pixelPitch_mm != panel.pixelPitch_mm || other->subpixels != panel.subpixels)
    fail(Errc::Config,
         "part '{}': its [display] panel is not the bench's ({} x {} pixels of {} mm); a part's scene "
         "is the bench's with another part in place",
         scene.string(), panel.panelWidth_px, panel.panelHeight_px, panel.pixelPitch_mm);
  {
    std::lock_guard lock(d.displayMutex);
    d.replay(imager->bench());
    std::lock_guard swap(d.partMutex);
    d.imager = std::move(imager);
    d.part = scene;
  }
  {
    std::lock_guard counting(d.countersMutex);
    ++d.counters.partChanges;
  }
  return fireLine();
}

bool ServedBench::fireLine() {
  std::lock_guard lock(impl_->devicesMutex);
  return impl_->camera && impl_->camera->fireLine();
}

fs::path ServedBench::part() const {
  std::lock_guard lock(impl_->partMutex);
  return impl_->part;
}

void ServedBench::stopCamera() {
  std::lock_guard lock(impl_->devicesMutex);
  impl_->camera.reset();
}

void ServedBench::startCamera() {
  std::lock_guard lock(impl_->devicesMutex);
  if (impl_->camera) return;
  impl_->startCamera();
  std::lock_guard counting(impl_->countersMutex);
  ++impl_->counters.cameraRestarts;
}

bool ServedBench::cameraServing() const {
  std::lock_guard lock(impl_->devicesMutex);
  return impl_->camera != nullptr;
}

void ServedBench::setPacketLoss(double ratio) {
  std::lock_guard lock(impl_->devicesMutex);
  if (!(ratio >= 0 && ratio <= 1))
    fail(Errc::InvalidArgument, "simulated bench: packet loss {} is outside 0..1", ratio);
  impl_->packetLoss = ratio;
  if (impl_->camera) impl_->camera->setPacketLoss(ratio);
}

void ServedBench::unplugDisplay() {
  Impl& d = *impl_;
  std::lock_guard lock(d.devicesMutex);
  if (!d.display->state().plugged) return;
  d.display->unplug();
  std::lock_guard dark(d.displayMutex);  // (a display without power shows nothing)
  d.lit = false;
  d.bench().blankPanel();
}

void ServedBench::plugDisplay() {
  Impl& d = *impl_;
  std::lock_guard lock(d.devicesMutex);
  if (d.display->state().plugged) return;
  d.display->plug();
  std::lock_guard counting(d.countersMutex);
  ++d.counters.displayReplugs;
}

bool ServedBench::displayPlugged() const {
  return impl_->display->state().plugged;
}

EmulatedUsbDisplay& ServedBench::display() {
  return *impl_->display;
}

ServedBenchCounters ServedBench::counters() const {
  std::lock_guard lock(impl_->countersMutex);
  return impl_->counters;
}

}  // namespace lfi::emulation
