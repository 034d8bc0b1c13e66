// SPDX-License-Identifier: Apache-2.0
// The usb: scheme in the display registry:
// usb:<vid>:<pid>[/<serial>][?timeout_ms=<ms>&calibration=<file>].
#include "lfi/drivers/display_registry.h"
#include "lfi/drivers/usb/usb_display.h"

namespace lfi {
namespace {

const UriKey kTimeout{.name = "timeout_ms",
                      .value = UriValue::Integer,
                      .unit = "ms",
                      .lo = 1,
                      .hi = 600'000,
                      .meaning = "every control request's and bulk transfer's timeout (default: 1000 and 2000)"};
const UriKey kCalibration{.name = "calibration",
                          .value = UriValue::Text,
                          .meaning = "a display calibration file that overrides the optics the device reports"};

std::unique_ptr<Display> openUsbFromUri(const DeviceUri& uri) {
  const UsbDisplaySelector selector = parseUsbDisplayPath(uri.path, uri.text());
  UsbDisplayOptions options;
  if (const auto timeout = uriNumber<int>(uri, kTimeout)) {
    options.controlTimeout = std::chrono::milliseconds(*timeout);
    options.transferTimeout = std::chrono::milliseconds(*timeout);
  }
  if (const std::string* file = uri.find(kCalibration.name)) options.opticsOverride = *file;
  return openUsbDisplay(selector, options);
}

}  // namespace

void registerUsbBackend() {
  backendRegistry<Display>().addOnce(DisplayBackend{
      .scheme = "usb",
      .keys = {kTimeout, kCalibration},
      .description = "usb:<vid>:<pid>[/<serial>][?timeout_ms=<ms>&calibration=<file>]  light field display over USB "
                     "(libusb, lfi vendor protocol); calibration overrides the optics the device reports",
      .factory = openUsbFromUri,
  });
}

}  // namespace lfi
