// SPDX-License-Identifier: Apache-2.0
// The USB display's replies as the host decodes them (drivers/usb/usb_display_protocol.h): the first byte picks
// the reply (device info, calibration, status, last error), the rest is the reply's bytes.
#include "fuzz_input.h"

#include "lfi/drivers/usb/usb_display_protocol.h"

#include <span>

namespace proto = lfi::usbdisplay;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const std::span<const std::uint8_t> reply(data + 1, size - 1);
  const std::string device = "usb:1209:4c46/FUZZ";
  lfi::fuzz::expectCleanRefusal([&] {
    switch (data[0] % 4) {
      case 0:
        proto::decodeDeviceInfo(reply, device);
        break;
      case 1:
        proto::toOpticsParams(proto::decodeCalibration(reply, device));
        break;
      case 2:
        proto::decodeStatus(reply, device);
        break;
      case 3:
        proto::decodeLastError(reply, device);
        break;
    }
  });
  return 0;
}
