// SPDX-License-Identifier: Apache-2.0
// ServedBench (served_bench.h): a SimImager behind a GvCameraServer or an
// EmulatedU3vCamera, and an EmulatedUsbDisplay or an X server (XvfbScreen)
// whose panel drives the imager's SimBench.

#include "lfi/emulation/served_bench.h"

#include "lfi/core/error.h"
#include "lfi/drivers/driver_trace.h"
#include "lfi/drivers/usb/usb_display_protocol.h"
#include "lfi/sim/devices/sim_camera.h"

#include <fmt/format.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

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

// The scene's display; Errc::Config for a scene without one.
const DisplayInfo& sceneDisplay(const sim::SimBench& bench) {
  if (!bench.hasDisplay())
    fail(Errc::Config, "simulated bench: the scene file '{}' has no [display] table (docs/scene-files.md)",
         bench.sceneFile().string());
  return bench.description().display->info;
}

// The USB device that is the scene's display: its panel, optics and brightness range, the identity given.
EmulatedDisplayConfig displayConfig(const sim::SimBench& bench, EmulatedDisplayConfig config) {
  const DisplayInfo& info = sceneDisplay(bench);
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

// The window: layout that shows the panel on an output of its own size.
const char* windowLayout(SubpixelLayout layout) {
  switch (layout) {
    case SubpixelLayout::RgbStripe:
      return "rgb";
    case SubpixelLayout::BgrStripe:
      return "bgr";
    case SubpixelLayout::Mono:
      break;
  }
  return "mono";
}

// The panel image an X server's screen (RGB) holds in that layout.
cv::Mat panelOnScreen(const cv::Mat& rgb, SubpixelLayout layout) {
  cv::Mat panel;
  switch (layout) {
    case SubpixelLayout::RgbStripe:
      return rgb;
    case SubpixelLayout::BgrStripe:
      cv::cvtColor(rgb, panel, cv::COLOR_RGB2BGR);
      return panel;
    case SubpixelLayout::Mono:
      break;
  }
  cv::extractChannel(rgb, panel, 0);  // (the window: display's mono layout puts the level in all three)
  return panel;
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

  mutable std::mutex devicesMutex;              // the servers' lifetimes
  std::unique_ptr<GvCameraServer> camera;       // the camera served over GigE Vision, or
  std::unique_ptr<EmulatedU3vCamera> u3v;       // over USB3 Vision
  std::unique_ptr<EmulatedUsbDisplay> display;  // the display served over USB, or
  mutable std::mutex monitorMutex;              // (taken after devicesMutex, before displayMutex)
  std::unique_ptr<XvfbScreen> monitor;          // the display served as a monitor
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

  // What the monitor's X server shows now goes to the bench when it changed: the panel of each frame the
  // window: display presented before the frame was asked for.
  void watchMonitor() {
    std::lock_guard watching(monitorMutex);
    if (!monitor->running()) return;
    const cv::Mat shown = panelOnScreen(monitor->screen(), displayInfo.subpixels);
    std::lock_guard lock(displayMutex);
    if (lit && cv::norm(shown, panel, cv::NORM_INF) == 0) return;
    panel = shown.clone();
    lit = true;
    bench().showPanel(panel);
    std::lock_guard counting(countersMutex);
    ++counters.panelsPresented;
  }

  const std::string& cameraSerial() const {
    return options.cameraKind == ServedCamera::U3v ? options.u3v.serial : options.camera.serial;
  }

  void fill(const ServedFrameRequest& request, cv::Mat& image) {
    const auto start = std::chrono::steady_clock::now();
    if (monitor) watchMonitor();
    {
      std::lock_guard lock(partMutex);
      imager->capture(imager->resolve(request.settings(), "served camera '" + cameraSerial() + "'"), request.frameId,
                      frame);
      writeServedFrame(frame, image);
    }
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    traceDriverCall("served", cameraSerial(), "frame", fmt::format("{} in {:.3f} ms", request.frameId, 1e3 * seconds));
    std::lock_guard lock(countersMutex);
    ++counters.framesServed;
    counters.frameSeconds += seconds;
  }

  void startCamera() {
    auto filler = [this](const ServedFrameRequest& r, cv::Mat& image) { fill(r, image); };
    if (options.cameraKind == ServedCamera::U3v) {
      EmulatedU3vCameraConfig c = options.u3v;
      c.sensorWidth_px = camera0.width;
      c.sensorHeight_px = camera0.height;
      u3v = std::make_unique<EmulatedU3vCamera>(c, filler);
      u3v->plug();
      return;
    }
    GvCameraServerOptions o = options.camera;
    o.sensorWidth_px = camera0.width;
    o.sensorHeight_px = camera0.height;
    camera = std::make_unique<GvCameraServer>(o, filler);
    if (packetLoss > 0) camera->setPacketLoss(packetLoss);
  }

  // The camera leaves: a GigE Vision device stops answering, a USB3 Vision one is unplugged (what the host
  // has pending fails as the device goes).
  void stopCamera() {
    camera.reset();
    if (u3v) u3v->unplug();
    u3v.reset();
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
  d.displayInfo = sceneDisplay(d.imager->bench());
  const bool usb = d.options.displayKind == ServedDisplay::Usb;
  if (usb) d.options.display = displayConfig(d.imager->bench(), d.options.display);
  d.backlight = d.imager->bench().backlight();
  d.replay(d.imager->bench());
  if (!usb) d.monitor = std::make_unique<XvfbScreen>(d.displayInfo.panelWidth_px, d.displayInfo.panelHeight_px);
  d.startCamera();
  if (usb) {
    d.display = std::make_unique<EmulatedUsbDisplay>(d.options.display);
    d.display->observePanel(d.observer());
    d.display->plug();
  }
}

ServedBench::~ServedBench() {
  // The devices first: their threads call into the part.
  impl_->display.reset();
  impl_->camera.reset();
  impl_->u3v.reset();
  impl_->monitor.reset();
}

DeviceUri ServedBench::cameraUri() const {
  const ServedBenchOptions& o = impl_->options;
  if (o.cameraKind == ServedCamera::U3v) return {.scheme = "aravis", .path = emulatedU3vDeviceId(o.u3v)};
  return {.scheme = "aravis", .path = fmt::format("{}-{}-{}", o.camera.vendor, o.camera.model, o.camera.serial)};
}

DeviceUri ServedBench::displayUri() const {
  const Impl& d = *impl_;
  if (d.monitor) {
    const DisplayInfo& p = d.displayInfo;
    return {.scheme = "window",
            .path = "0",
            .query = {{"pitch_mm", fmt::format("{}", p.pixelPitch_mm)},
                      {"mode", fmt::format("{}x{}", p.panelWidth_px, p.panelHeight_px)},
                      {"layout", windowLayout(p.subpixels)}}};
  }
  const EmulatedDisplayConfig& c = d.options.display;
  return {.scheme = "usb", .path = fmt::format("{:04x}:{:04x}/{}", c.vendorId, c.productId, c.serial)};
}

std::string ServedBench::xDisplay() const {
  return impl_->monitor ? impl_->monitor->display() : std::string();
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
  if (impl_->u3v) return impl_->u3v->fireLine();
  return impl_->camera && impl_->camera->fireLine();
}

namespace {
const GvCameraServer& gigeCamera(const ServedBench::Impl& impl) {
  if (impl.u3v) fail(Errc::InvalidArgument, "served bench: its camera is USB3 Vision, whose outputs are not served");
  if (!impl.camera) fail(Errc::Device, "served bench: the camera is off");
  return *impl.camera;
}
}  // namespace

bool ServedBench::cameraUserOutput(int index) const {
  std::lock_guard lock(impl_->devicesMutex);
  return gigeCamera(*impl_).userOutput(index);
}

std::string ServedBench::cameraLineSource(int line) const {
  std::lock_guard lock(impl_->devicesMutex);
  return gigeCamera(*impl_).lineSource(line);
}

fs::path ServedBench::part() const {
  std::lock_guard lock(impl_->partMutex);
  return impl_->part;
}

void ServedBench::stopCamera() {
  std::lock_guard lock(impl_->devicesMutex);
  impl_->stopCamera();
}

void ServedBench::startCamera() {
  std::lock_guard lock(impl_->devicesMutex);
  if (impl_->camera || impl_->u3v) return;
  impl_->startCamera();
  std::lock_guard counting(impl_->countersMutex);
  ++impl_->counters.cameraRestarts;
}

bool ServedBench::cameraServing() const {
  std::lock_guard lock(impl_->devicesMutex);
  return impl_->camera != nullptr || impl_->u3v != nullptr;
}

void ServedBench::setPacketLoss(double ratio) {
  std::lock_guard lock(impl_->devicesMutex);
  if (impl_->options.cameraKind == ServedCamera::U3v)
    fail(Errc::InvalidArgument,
         "simulated bench: packet loss is GigE Vision's; its camera is served over USB3 Vision ({})",
         cameraUri().text());
  if (!(ratio >= 0 && ratio <= 1))
    fail(Errc::InvalidArgument, "simulated bench: packet loss {} is outside 0..1", ratio);
  impl_->packetLoss = ratio;
  if (impl_->camera) impl_->camera->setPacketLoss(ratio);
}

void ServedBench::unplugDisplay() {
  Impl& d = *impl_;
  std::lock_guard lock(d.devicesMutex);
  if (!displayPlugged()) return;
  if (d.monitor) {
    std::lock_guard watching(d.monitorMutex);
    d.monitor->stop(/*kill=*/true);  // (the server gone at once, as a pulled cable or a crash)
  } else {
    d.display->unplug();
  }
  std::lock_guard dark(d.displayMutex);  // (a display without power shows nothing)
  d.lit = false;
  d.bench().blankPanel();
}

void ServedBench::plugDisplay() {
  Impl& d = *impl_;
  std::lock_guard lock(d.devicesMutex);
  if (displayPlugged()) return;
  if (d.monitor) {
    std::lock_guard watching(d.monitorMutex);
    d.monitor->start();
  } else {
    d.display->plug();
  }
  std::lock_guard counting(d.countersMutex);
  ++d.counters.displayReplugs;
}

bool ServedBench::displayPlugged() const {
  if (impl_->monitor) {
    std::lock_guard watching(impl_->monitorMutex);
    return impl_->monitor->running();
  }
  return impl_->display->state().plugged;
}

EmulatedUsbDisplay& ServedBench::display() {
  if (!impl_->display)
    fail(Errc::InvalidArgument,
         "simulated bench: its display is served as a monitor ({}); the USB display's faults "
         "do not apply to it",
         displayUri().text());
  return *impl_->display;
}

ServedBenchCounters ServedBench::counters() const {
  std::lock_guard lock(impl_->countersMutex);
  return impl_->counters;
}

}  // namespace lfi::emulation
