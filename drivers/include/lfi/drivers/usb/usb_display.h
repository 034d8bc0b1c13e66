// SPDX-License-Identifier: Apache-2.0
#pragma once
// The `usb:` display backend: the host side of the lfi USB display protocol
// (docs/usb-display-protocol.md) over libusb-1.0. libusb is private to lfi_drivers:
// this header names none of its types.
//
// Behaviour:
//   - open() enumerates USB devices, picks the one with the VID:PID (and serial,
//     when given), claims its vendor interface and reads protocol version, device
//     info and the calibration blob that lives on the device. Each open() uses a
//     fresh libusb context, so a display that was unplugged and comes back is found.
//   - show() sends header + payload as bulk OUT transfers of transferSize_bytes,
//     transfersInFlight at a time (asynchronous; each may take transferTimeout once
//     the ones queued before it are through), then a
//     PRESENT control request with the frame's sequence number. A stalled endpoint is
//     cleared (libusb_clear_halt) and the whole frame resent, up to stallRetries
//     times. Device rejection (CRC, size, truncated) and transfer timeouts are
//     PresentResult values; a vanished device throws Errc::Device and leaves the
//     display Closed; control requests that time out throw Errc::Timeout.
//   - Messages name the device as "usb:<vid>:<pid>[/<serial>]" and the request.

#include "lfi/drivers/display.h"

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace lfi {

struct UsbDisplaySelector {
  std::uint16_t vendorId = 0;
  std::uint16_t productId = 0;
  std::string serial;  // empty: any serial (an error if several displays match)
  // "usb:1209:4c46[/serial]", the serial's spaces, delimiters ("%/?&#=") and
  // other bytes outside printable ASCII percent-encoded ("Bench A" → "Bench%20A").
  std::string uri() const;
};

// Parses a usb: URI's decoded path (DeviceUri::path), "<vid>:<pid>[/<serial>]"
// (4 hex digits each; the serial, 1..126 bytes, is all after the first '/').
// Throws Errc::Config naming `uriForMessages`.
UsbDisplaySelector parseUsbDisplayPath(std::string_view path, const std::string& uriForMessages);

struct UsbDisplayOptions {
  std::chrono::milliseconds controlTimeout{1000};   // per control request
  std::chrono::milliseconds transferTimeout{2000};  // per bulk transfer, after those queued before it
  int transfersInFlight = 4;                        // 1..32
  std::size_t transferSize_bytes = 1 << 20;         // 512 B .. 16 MiB, a multiple of 512
  int stallRetries = 1;                             // frame resends after clearing a halt
  // A bench file overriding the optics the device reports (display_calibration_file.h).
  std::filesystem::path opticsOverride;
};

// A USB device with the lfi display protocol's vendor interface (class 0xff,
// subclass 0x4c), whatever its VID:PID, as listUsbDisplays() found it.
struct UsbDisplayInfo {
  UsbDisplaySelector selector;  // selector.uri() opens it ("usb:<vid>:<pid>/<serial>")
  int bus = 0;                  // USB bus number and device address
  int address = 0;
  std::string problem;  // why its serial could not be read (e.g. permission denied), or empty
};

// Lists the displays on the USB buses (a fresh libusb context; opens each one
// only to read its serial). Throws Errc::Device when libusb cannot list devices.
std::vector<UsbDisplayInfo> listUsbDisplays();

// Returns an Open display. Throws Errc::NotFound when no device matches,
// Errc::Config when several match and no serial was given, Errc::Device when the
// device refuses to be claimed or answers nonsense, Errc::Timeout when it does not answer.
std::unique_ptr<Display> openUsbDisplay(const UsbDisplaySelector& selector, const UsbDisplayOptions& options = {});

// Adds the usb: scheme to the display registry (registerDriverBackends() calls it). Idempotent.
void registerUsbBackend();

}  // namespace lfi
