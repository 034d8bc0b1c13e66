// The camera, display and reference light field that `lfi calibrate-distance`
// drives, given on its command line: their options and their opening.

#include "device_options.h"

#include "cli_util.h"

#include "lfi/core/error.h"
#include "lfi/core/exr_io.h"
#include "lfi/controller/bench_devices.h"
#include "lfi/drivers/camera_registry.h"
#include "lfi/drivers/capture_registry.h"
#include "lfi/drivers/display_registry.h"

#include <functional>
#include <utility>

namespace fs = std::filesystem;

namespace lfi::cli {

namespace {

constexpr long long kMostFrames = 100000;

}  // namespace

void addDeviceOptions(CLI::App& command, DeviceOptions& o) {
  command.add_option("--camera", o.camera, "Camera URI (aravis:<id>, sim:<scene-file>)")->required();
  command.add_option("--display", o.display, "Display URI (usb:<vid>:<pid>[/<serial>], sim:<scene-file>)")
      ->required();
  auto* capture = command.add_option("--capture", o.capture, "Light field capture URI (sim:<scene-file>[?...])");
  command.add_option("--light-field", o.lightField, "Use this reference light field (EXR) instead of capturing")
      ->check(CLI::ExistingFile)
      ->excludes(capture);
  command.add_option("--frames", o.frames, "Frames averaged per image")->transform(wholeNumberIn(1LL, kMostFrames))
      ->capture_default_str();
  command.add_option("--exposure-us", o.exposure_us, "Exposure time (µs)")->capture_default_str();
  command.add_option("--gain", o.gain, "Gain (device unit, dB for SFNC cameras)")->capture_default_str();
  command.add_option("--pixel-format", o.pixelFormat, "Mono8 | Mono12 | Mono16")
      ->check(CLI::IsMember({"Mono8", "Mono12", "Mono16"}))
      ->capture_default_str();
  command.add_option("--settle-ms", o.settle_ms, "Wait after the display shows a light field before exposing (ms)")
      ->transform(wholeNumberIn(0LL, 24LL * 3600 * 1000))
      ->capture_default_str();
}

OpenDevices openDevices(const DeviceOptions& o, const char* command) {
  if (o.capture.empty() && o.lightField.empty())
    lfi::fail(lfi::Errc::Config, "{}: give --capture <uri> or --light-field <file>", command);
  OpenDevices bench;
  bench.camera = lfi::openCamera(o.camera);
  lfi::CameraSettings settings;
  settings.exposure_us = o.exposure_us;
  settings.gain = o.gain;
  settings.pixelFormat = o.pixelFormat == "Mono8"    ? lfi::PixelFormat::Mono8
                         : o.pixelFormat == "Mono16" ? lfi::PixelFormat::Mono16
                                                     : lfi::PixelFormat::Mono12;
  bench.camera->configure(settings);
  bench.display = lfi::openDisplay(o.display);
  bench.captured = !o.capture.empty();
  bench.capture = bench.captured ? lfi::openLightFieldCapture(o.capture)
                                 : std::make_unique<lfi::StoredLightField>(lfi::readLightFieldExr(o.lightField),
                                                                           "file " + o.lightField.string());
  return bench;
}

}  // namespace lfi::cli
