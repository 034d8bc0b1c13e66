// SPDX-License-Identifier: Apache-2.0
// lfi devices [BENCH]: what a bench file names, whether each device is there
// and in what state; then the USB displays and GenICam cameras attached, with
// their URIs.

#include "commands.h"

#include "lfi/controller/bench_devices.h"
#include "lfi/controller/bench_file.h"
#include "lfi/controller/reference_package.h"

#include "lfi/core/error.h"
#include "lfi/drivers/aravis/aravis_camera.h"
#include "lfi/drivers/backend_registry.h"
#include "lfi/drivers/usb/usb_display.h"
#include "lfi/drivers/window/window_display.h"

#include <fmt/format.h>

#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace lfi::cli {

namespace {

// One line per device the bench names: present (and what it says it is) or why not. False if one is missing.
bool checkBench(const fs::path& file) {
  const lfi::BenchFile bench = lfi::readBenchFile(file);
  fmt::print("Bench {} (reference hash {}):\n", file.string(), bench.referenceHash());
  bool all = true;
  const auto check = [&](const char* role, const std::string& uri, const std::function<std::string()>& open) {
    try {
      fmt::print("  {:<9} {}  present: {}\n", role, uri, open());
      return true;
    } catch (const lfi::Error& e) {
      fmt::print("  {:<9} {}  NOT AVAILABLE: {}\n", role, uri, e.what());
      all = false;
      return false;
    }
  };
  const bool cameraPresent = check("camera", bench.cameraUri.text(), [&] {
    auto camera = lfi::openBenchCamera(bench);  // (configured: the bench's settings are accepted)
    return fmt::format("{}, {}", lfi::describeCamera(*camera, bench.cameraUri), lfi::toString(camera->state()));
  });
  const bool displayPresent = check("display", bench.displayUri.text(), [&] {
    auto display = lfi::openBenchDisplay(bench);
    const lfi::DisplayInfo info = display->info();
    return fmt::format("{}, {} x {} panel, {}", info.deviceId, info.panelWidth_px, info.panelHeight_px,
                       lfi::toString(display->state()));
  });
  check("capture", bench.captureUri ? bench.captureUri->text() : bench.lightFieldFile.string(), [&] {
    auto capture = lfi::openBenchCapture(bench);
    if (capture->measuresThroughBench() && !(cameraPresent && displayPresent))
      lfi::fail(lfi::Errc::NotFound, "it measures through the bench's display and camera, {}",
                cameraPresent    ? "and the display is not available"
                : displayPresent ? "and the camera is not available"
                                 : "neither of which is available");
    return capture->description();
  });
  check("reference", bench.referenceFolder.string(), [&] {
    const lfi::ReferencePackage p = lfi::readReferencePackage(bench.referenceFolder, &bench);
    return fmt::format("taken {}, {} images trained", p.info.created_utc, p.trainer.count());
  });
  return all;
}

int listDevices() {
  // Displays first: their listing is instant, the cameras' discovery waits about 1 s for answers.
  bool listed = true;  // (exit status 1 when the displays could not be listed, after the cameras)
  try {                // a machine without USB still has cameras to list
    const std::vector<lfi::UsbDisplayInfo> displays = lfi::listUsbDisplays();
    fmt::print("USB displays: {}\n", displays.empty() ? "none" : std::to_string(displays.size()));
    for (const lfi::UsbDisplayInfo& d : displays)
      fmt::print("  {}  (bus {:03d} device {:03d}){}\n", d.selector.uri(), d.bus, d.address,
                 d.problem.empty() ? "" : ": " + d.problem);
  } catch (const lfi::Error& e) {
    fmt::print("USB displays: cannot be listed ({})\n", e.what());
    listed = false;
  }
  try {  // a bench computer with no display server and no KMS/DRM device has no outputs: not an error
    const std::vector<lfi::WindowOutput> outputs = lfi::listWindowOutputs();
    fmt::print("Monitor outputs: {}\n", outputs.empty() ? "none" : std::to_string(outputs.size()));
    for (const lfi::WindowOutput& o : outputs)
      fmt::print("  {}  ('{}' {}x{} at {:g} Hz, {} at ({}, {}))\n", o.uri(), o.name, o.width_px, o.height_px,
                 o.refresh_hz, o.driver, o.x, o.y);
  } catch (const lfi::Error& e) {
    fmt::print("Monitor outputs: none ({})\n", e.what());
  }
  const std::vector<lfi::AravisDeviceInfo> cameras = lfi::listAravisDevices();
  fmt::print("GenICam cameras: {}\n", cameras.empty() ? "none" : std::to_string(cameras.size()));
  for (const lfi::AravisDeviceInfo& c : cameras)
    fmt::print("  {}  ({} {}, serial {}, {} at {})\n", lfi::DeviceUri{.scheme = "aravis", .path = c.id}, c.vendor,
               c.model, c.serial, c.protocol, c.address);
  return listed ? 0 : 1;
}

}  // namespace

Command addDevicesCommand(CLI::App& app) {
  auto* devices = app.add_subcommand(
      "devices",
      "Check a bench file's devices; list the GenICam cameras, USB displays and monitor outputs, with their URIs");
  auto bench = std::make_shared<fs::path>();
  devices->add_option("bench", *bench, "Bench file whose devices to check")->check(CLI::ExistingFile);
  return {devices, [bench](const GlobalOptions&) {
            const bool present = bench->empty() || checkBench(*bench);
            const int listed = listDevices();
            return present ? listed : 1;
          }};
}

}  // namespace lfi::cli
