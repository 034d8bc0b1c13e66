// lfi devices: the USB displays and GenICam cameras attached, with their URIs.

#include "commands.h"

#include "lfi/core/error.h"
#include "lfi/drivers/aravis/aravis_camera.h"
#include "lfi/drivers/backend_registry.h"
#include "lfi/drivers/usb/usb_display.h"

#include <fmt/format.h>

#include <string>
#include <vector>

namespace lfi::cli {

namespace {

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
  const std::vector<lfi::AravisDeviceInfo> cameras = lfi::listAravisDevices();
  fmt::print("GenICam cameras: {}\n", cameras.empty() ? "none" : std::to_string(cameras.size()));
  for (const lfi::AravisDeviceInfo& c : cameras)
    fmt::print("  aravis:{}  ({} {}, serial {}, {} at {})\n", lfi::percentEncodeUriPart(c.id), c.vendor, c.model,
               c.serial, c.protocol, c.address);
  return listed ? 0 : 1;
}

}  // namespace

Command addDevicesCommand(CLI::App& app) {
  auto* devices = app.add_subcommand("devices", "List the GenICam cameras and USB displays attached, with their URIs");
  return {devices, [](const GlobalOptions&) { return listDevices(); }};
}

}  // namespace lfi::cli
