// SPDX-License-Identifier: Apache-2.0
// Finding the usb: display on the buses: usb: URIs (UsbDisplaySelector), listUsbDisplays(),
// and UsbDisplay::openDevice(), which picks the device a selector names and claims its interface.

#include "usb_display_impl.h"

#include "lfi/core/error.h"
#include "lfi/drivers/backend_registry.h"
#include "lfi/drivers/driver_trace.h"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <libusb.h>

#include <charconv>
#include <cstdint>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace lfi {
namespace detail {

std::string serialOf(libusb_device_handle* handle, const libusb_device_descriptor& desc, int& error) {
  error = 0;
  if (desc.iSerialNumber == 0) return {};
  unsigned char text[256] = {};
  const int n = libusb_get_string_descriptor_ascii(handle, desc.iSerialNumber, text, sizeof(text) - 1);
  if (n < 0) error = n;
  return n > 0 ? std::string(reinterpret_cast<char*>(text), static_cast<std::size_t>(n)) : std::string();
}

std::string serialInUri(std::string_view serial) {
  return percentEncodeUriPart(serial, "/");
}

void UsbDisplay::openDevice() {
  libusb_device** list = nullptr;
  const ssize_t count = libusb_get_device_list(ctx_, &list);
  if (count < 0) fail(Errc::Device, "{}: cannot list USB devices: {}", name_, libusb_error_name(int(count)));
  std::vector<std::string> seen;
  std::vector<std::pair<libusb_device_handle*, std::string>> matches;
  int lastOpenError = 0, lastSerialError = 0, unopened = 0;
  for (ssize_t i = 0; i < count; ++i) {
    libusb_device_descriptor desc{};
    if (libusb_get_device_descriptor(list[i], &desc) != 0) continue;
    seen.push_back(fmt::format("{:04x}:{:04x}", desc.idVendor, desc.idProduct));
    if (desc.idVendor != selector_.vendorId || desc.idProduct != selector_.productId) continue;
    libusb_device_handle* handle = nullptr;
    if (const int rc = libusb_open(list[i], &handle); rc != 0) {
      lastOpenError = rc;
      ++unopened;
      continue;
    }
    int unreadable = 0;
    const std::string serial = serialOf(handle, desc, unreadable);
    if (!selector_.serial.empty() && serial != selector_.serial) {
      if (unreadable != 0) lastSerialError = unreadable;
      seen.back() += unreadable != 0 ? "/(serial unreadable)" : "/" + serialInUri(serial);  // as the URI names it
      libusb_close(handle);
      continue;
    }
    matches.emplace_back(handle, serial);
  }
  libusb_free_device_list(list, 1);
  if (matches.empty()) {
    if (lastOpenError == LIBUSB_ERROR_ACCESS)
      fail(Errc::NotFound, "{}: the device is present but cannot be opened: permission denied (udev rules?)", name_);
    if (lastOpenError != 0)
      fail(Errc::NotFound, "{}: the device is present but cannot be opened: {}", name_,
           libusb_error_name(lastOpenError));
    if (lastSerialError != 0)
      fail(Errc::NotFound, "{}: a device {:04x}:{:04x} is present but its serial cannot be read: {}", name_,
           selector_.vendorId, selector_.productId, libusb_error_name(lastSerialError));
    fail(Errc::NotFound, "{}: no such USB device (present: {})", name_,
         seen.empty() ? std::string("none") : fmt::format("{}", fmt::join(seen, ", ")));
  }
  // Without a serial, a second display that cannot be opened still makes the choice ambiguous: opening the
  // other one silently could drive the wrong panel.
  if (matches.size() == 1 && unopened > 0 && selector_.serial.empty()) {
    libusb_close(matches.front().first);
    fail(Errc::Config,
         "{}: {} displays match, {} of them cannot be opened ({}); name one by serial "
         "(usb:{:04x}:{:04x}/<serial>; this one's: {})",
         name_, unopened + 1, unopened, libusb_error_name(lastOpenError), selector_.vendorId, selector_.productId,
         serialInUri(matches.front().second));
  }
  if (matches.size() > 1) {
    std::vector<std::string> serials;
    for (auto& [h, s] : matches) {
      serials.push_back(serialInUri(s));
      libusb_close(h);
    }
    fail(Errc::Config, "{}: {} displays match; name one by serial (usb:{:04x}:{:04x}/<serial>, serials: {})", name_,
         matches.size(), selector_.vendorId, selector_.productId, fmt::join(serials, ", "));
  }
  handle_ = matches.front().first;
  serial_ = matches.front().second;

  libusb_config_descriptor* config = nullptr;
  if (const int rc = libusb_get_active_config_descriptor(libusb_get_device(handle_), &config); rc != 0)
    fail(Errc::Device, "{}: cannot read the configuration descriptor: {}", name_, libusb_error_name(rc));
  bool found = false;
  int altSetting = 0;
  for (int i = 0; i < config->bNumInterfaces && !found; ++i) {
    for (int a = 0; a < config->interface[i].num_altsetting && !found; ++a) {
      const libusb_interface_descriptor& alt = config->interface[i].altsetting[a];
      if (alt.bInterfaceClass != proto::kInterfaceClass || alt.bInterfaceSubClass != proto::kInterfaceSubclass)
        continue;
      for (int e = 0; e < alt.bNumEndpoints; ++e) {
        const libusb_endpoint_descriptor& ep = alt.endpoint[e];
        if ((ep.bmAttributes & 0x3) == LIBUSB_TRANSFER_TYPE_BULK && (ep.bEndpointAddress & 0x80) == 0) {
          interface_ = alt.bInterfaceNumber;
          altSetting = alt.bAlternateSetting;
          endpoint_ = ep.bEndpointAddress;
          found = true;
          break;
        }
      }
    }
  }
  libusb_free_config_descriptor(config);
  if (!found)
    fail(Errc::Device, "{}: no vendor interface (class 0x{:02x}, subclass 0x{:02x}) with a bulk OUT endpoint", name_,
         proto::kInterfaceClass, proto::kInterfaceSubclass);
  const int claim = libusb_claim_interface(handle_, interface_);
  traceDriverCall("usb", name_, "CLAIM_INTERFACE", claim < 0 ? libusb_error_name(claim) : "ok");
  if (const int rc = claim; rc != 0) {
    if (rc == LIBUSB_ERROR_NO_DEVICE) vanished("CLAIM_INTERFACE");
    fail(Errc::Device, "{}: cannot claim interface {}: {}{}", name_, interface_, libusb_error_name(rc),
         rc != LIBUSB_ERROR_BUSY ? ""
         : wedged_ ? " (this process still holds it: transfers of an earlier frame never completed nor were "
                     "cancelled; restart the process)"
                   : " (another program, or another display object of this process, has it)");
  }
  claimed_ = true;
  if (altSetting != 0)  // the endpoint is in an alternate setting: select it
    if (const int rc = libusb_set_interface_alt_setting(handle_, interface_, altSetting); rc != 0) {
      if (rc == LIBUSB_ERROR_NO_DEVICE) vanished("SET_INTERFACE");
      fail(Errc::Device, "{}: cannot select alternate setting {} of interface {}: {}", name_, altSetting, interface_,
           libusb_error_name(rc));
    }
}

}  // namespace detail

namespace {

namespace proto = usbdisplay;
using detail::serialInUri;
using detail::serialOf;

std::uint16_t parseHex16(std::string_view text, const char* what, const std::string& uri) {
  unsigned value = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value, 16);
  if (text.size() != 4 || ec != std::errc() || end != text.data() + text.size())
    fail(Errc::Config, "display URI '{}': {} '{}' is not 4 hex digits (expected usb:<vid>:<pid>[/<serial>])", uri, what,
         text);
  return static_cast<std::uint16_t>(value);
}

}  // namespace

std::string UsbDisplaySelector::uri() const {
  return serial.empty() ? fmt::format("usb:{:04x}:{:04x}", vendorId, productId)
                        : fmt::format("usb:{:04x}:{:04x}/{}", vendorId, productId, serialInUri(serial));
}

UsbDisplaySelector parseUsbDisplayPath(std::string_view path, const std::string& uri) {
  UsbDisplaySelector s;
  const std::size_t slash = path.find('/');
  const std::string_view ids = path.substr(0, slash);
  const std::size_t colon = ids.find(':');
  if (colon == std::string_view::npos)
    fail(Errc::Config, "display URI '{}': expected usb:<vid>:<pid>[/<serial>] with 4 hex digits each", uri);
  s.vendorId = parseHex16(ids.substr(0, colon), "vendor id", uri);
  s.productId = parseHex16(ids.substr(colon + 1), "product id", uri);
  if (slash != std::string_view::npos) {
    s.serial = std::string(path.substr(slash + 1));  // (decoded with the rest of the URI: it may hold a '/')
    if (s.serial.empty() || s.serial.size() > 126)
      fail(Errc::Config,
           "display URI '{}': the serial must be 1..126 bytes, not {} (write a space, '/', '%', '?', "
           "'&', '#', '=' or a non-ASCII byte as %XX)",
           uri, s.serial.size());
  }
  return s;
}

std::vector<UsbDisplayInfo> listUsbDisplays() {
  libusb_context* ctx = nullptr;
  if (const int rc = libusb_init(&ctx); rc != 0)
    fail(Errc::Device, "USB displays: libusb_init failed: {}", libusb_error_name(rc));
  libusb_device** list = nullptr;
  const ssize_t count = libusb_get_device_list(ctx, &list);
  if (count < 0) {
    libusb_exit(ctx);
    fail(Errc::Device, "USB displays: cannot list USB devices: {}", libusb_error_name(int(count)));
  }
  std::vector<UsbDisplayInfo> displays;
  for (ssize_t i = 0; i < count; ++i) {
    libusb_device_descriptor desc{};
    libusb_config_descriptor* config = nullptr;
    if (libusb_get_device_descriptor(list[i], &desc) != 0 || libusb_get_active_config_descriptor(list[i], &config) != 0)
      continue;
    bool display = false;
    for (int k = 0; k < config->bNumInterfaces && !display; ++k)
      for (int a = 0; a < config->interface[k].num_altsetting && !display; ++a)
        display = config->interface[k].altsetting[a].bInterfaceClass == proto::kInterfaceClass &&
                  config->interface[k].altsetting[a].bInterfaceSubClass == proto::kInterfaceSubclass;
    libusb_free_config_descriptor(config);
    if (!display) continue;
    UsbDisplayInfo info;
    info.selector.vendorId = desc.idVendor;
    info.selector.productId = desc.idProduct;
    info.bus = libusb_get_bus_number(list[i]);
    info.address = libusb_get_device_address(list[i]);
    libusb_device_handle* handle = nullptr;
    if (const int rc = libusb_open(list[i], &handle); rc != 0) {
      info.problem = rc == LIBUSB_ERROR_ACCESS ? "permission denied (udev rules?)" : libusb_error_name(rc);
    } else {
      int unreadable = 0;
      info.selector.serial = serialOf(handle, desc, unreadable);
      if (unreadable != 0) info.problem = fmt::format("its serial cannot be read: {}", libusb_error_name(unreadable));
      libusb_close(handle);
    }
    displays.push_back(std::move(info));
  }
  libusb_free_device_list(list, 1);
  libusb_exit(ctx);
  return displays;
}

}  // namespace lfi
