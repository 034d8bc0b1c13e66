// SPDX-License-Identifier: Apache-2.0
// The usb: scheme in the display registry:
// usb:<vid>:<pid>[/<serial>][?timeout_ms=<ms>&calibration=<file>].
#include "lfi/core/error.h"
#include "lfi/drivers/display_registry.h"
#include "lfi/drivers/usb/usb_display.h"

#include <charconv>

namespace lfi {
namespace {

std::unique_ptr<Display> openUsbFromUri(const DeviceUri& uri) {
  const UsbDisplaySelector selector = parseUsbDisplayPath(uri.path, uri.text);
  UsbDisplayOptions options;
  if (auto it = uri.query.find("timeout_ms"); it != uri.query.end()) {
    int value = 0;
    const auto [end, ec] = std::from_chars(it->second.data(), it->second.data() + it->second.size(), value);
    if (ec != std::errc() || end != it->second.data() + it->second.size() || value < 1 || value > 600'000)
      fail(Errc::Config, "display URI '{}': timeout_ms '{}' is not an integer in 1..600000", uri.text, it->second);
    options.controlTimeout = std::chrono::milliseconds(value);
    options.transferTimeout = std::chrono::milliseconds(value);
  }
  if (auto it = uri.query.find("calibration"); it != uri.query.end()) {
    if (it->second.empty())
      fail(Errc::Config, "display URI '{}': calibration= names no file (leave the key out to use the device's)",
           uri.text);
    options.opticsOverride = it->second;
  }
  return openUsbDisplay(selector, options);
}

}  // namespace

void registerUsbBackend() {
  backendRegistry<Display>().addOnce(DisplayBackend{
      .scheme = "usb",
      .queryKeys = {"timeout_ms", "calibration"},
      .description = "usb:<vid>:<pid>[/<serial>][?timeout_ms=<ms>&calibration=<file>]  light field display over USB "
                     "(libusb, lfi vendor protocol); calibration overrides the optics the device reports",
      .factory = openUsbFromUri,
  });
}

}  // namespace lfi
