// SPDX-License-Identifier: Apache-2.0
// EmulatedUsbDisplay (emulated_usb_display.h): the device's record, what it does with the
// URBs, claims and clear-halts its usbdevfs node hands it (the protocol itself:
// emulated_usb_device.cpp), plugging it in and out, arming faults and reading its
// state from the test thread, and the process-wide umockdev setup.

#include "lfi/emulation/emulated_usb_display.h"

#include "emulated_usb_display_impl.h"

#include "lfi/core/error.h"

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

namespace lfi::emulation {

namespace {

EmulatedDisplayConfig withDefaults(EmulatedDisplayConfig config) {
  if (config.calibration.pixelPitch_mm == 0) {
    config.calibration.pixelPitch_mm = 25.4 / 338.0;
    config.calibration.version = usbdisplay::kCalibrationVersion1;  // a device of the horizontal-parallax class
    config.calibration.optics = usbdisplay::OpticsCode::Lenticular;
    config.calibration.lensPitch_px = 7.22;
    config.calibration.slant_rad = 0.1826;
    config.calibration.offset_px = 0.3;
    config.calibration.gap_mm = 0.7333;
    config.calibration.focalLength_mm = 0.7333;
  }
  return config;
}

}  // namespace

EmulatedUsbDisplay::Impl::Impl(const EmulatedDisplayConfig& c)
    : config(c), node(c.busNumber, c.deviceNumber, "emulated display", *this) {}

std::string EmulatedUsbDisplay::Impl::record() const {
  std::vector<std::uint8_t> d;
  auto u16 = [&](int v) {
    d.push_back(static_cast<std::uint8_t>(v));
    d.push_back(static_cast<std::uint8_t>(v >> 8));
  };
  detail::appendDeviceDescriptor(d, {.vendorId = config.vendorId,
                                     .productId = config.productId,
                                     .serialString = static_cast<std::uint8_t>(config.serialDescriptor ? 3 : 0)});
  // configuration, interface, bulk OUT endpoint (512 byte packets, high speed)
  d.insert(d.end(), {9, 2});
  u16(9 + 9 + 7);
  d.insert(d.end(), {1, 1, 0, 0x80, 50});
  d.insert(d.end(), {9, 4, 0, 0, 1, proto::kInterfaceClass, proto::kInterfaceSubclass, proto::kInterfaceProtocol, 0});
  d.insert(d.end(), {7, 5, proto::kFrameEndpoint, 2});
  u16(512);
  d.push_back(0);
  return detail::recordText(node, {.vendorId = config.vendorId,
                                   .productId = config.productId,
                                   .manufacturer = config.vendor,
                                   .product = config.model,
                                   .serial = config.serial,
                                   .descriptors = std::move(d)});
}

// ---- the device side of its node, on the handler thread under node.mutex() ----

detail::UsbdevfsDevice::Submitted EmulatedUsbDisplay::Impl::submit(Urb& u) {
  std::uint8_t* bytes = u.bytes();
  const int length = u.length();
  if (!u.bulk) {
    ++state.controlRequests;
    if (silentAtPresent && bytes[1] == static_cast<std::uint8_t>(proto::Request::Present))
      silent = true, silentAtPresent = false;
    const bool vendor = bytes[0] == proto::kRequestTypeIn || bytes[0] == proto::kRequestTypeOut;
    if (vendor && bytes[1] == unplugAtRequest) {  // the request and everything pending fail as the device goes
      unplugAtRequest = -1;
      u.status = -ESHUTDOWN;
      vanish();
      return Submitted::Complete;
    }
    if (silent) return Submitted::Hold;
    control(bytes, length, u);
    return Submitted::Complete;
  }
  if (u.endpoint != proto::kFrameEndpoint) return Submitted::Refuse;
  if (silentAfterUrbs >= 0 && silentAfterUrbs-- == 0) silent = true;
  ++state.bulkUrbs;
  state.maxUrbsInFlight = std::max(state.maxUrbsInFlight, node.bulkInFlight());
  if (unplugAfterUrbs >= 0 && unplugAfterUrbs-- == 0) {  // this URB and everything pending fail as it goes
    u.status = -ESHUTDOWN;
    vanish();
    return Submitted::Complete;
  }
  if (silent) return Submitted::Hold;
  bulkOut(bytes, length, u);
  if (frameUnplug) vanish();
  return Submitted::Complete;
}

int EmulatedUsbDisplay::Impl::claimInterface(unsigned interface, bool claim) {
  if (interface != 0) return EINVAL;
  if (claim && claimErrno != 0) return claimErrno;
  state.claimed = claim;
  return 0;
}

int EmulatedUsbDisplay::Impl::clearHalt(unsigned) {
  if (clearHaltErrno != 0) return clearHaltErrno;
  halted = false;
  ++state.clearHalts;
  resetFrame();  // the firmware drops a partly received frame when its endpoint is reset
  return 0;
}

void EmulatedUsbDisplay::Impl::vanish() {
  node.vanish();
  frameUnplug = false;
  state.plugged = state.claimed = false;
}

// ---- the test thread ----

EmulatedUsbDisplay::EmulatedUsbDisplay(EmulatedDisplayConfig config)
    : config_(withDefaults(std::move(config))), impl_(new Impl(config_)) {}

EmulatedUsbDisplay::~EmulatedUsbDisplay() = default;

void EmulatedUsbDisplay::plug() {
  Impl& d = *impl_;
  {
    std::lock_guard lock(d.node.mutex());
    if (!d.node.vanished()) return;
    d.halted = false;
    d.resetFrame();
    d.state.plugged = true;
    d.state.claimed = false;
  }
  d.node.plug(d.record());
}

void EmulatedUsbDisplay::unplug() {
  Impl& d = *impl_;
  {
    std::lock_guard lock(d.node.mutex());
    d.state.plugged = false;
    d.state.claimed = false;
  }
  d.node.unplug();
}

void EmulatedUsbDisplay::loseNode() {
  impl_->node.removeNode();
}

void EmulatedUsbDisplay::stallNextFrame(int urb) {
  std::lock_guard lock(impl_->node.mutex());
  impl_->stallNextAt = urb;
}
void EmulatedUsbDisplay::shortenNextFrame(int urb, int bytes) {
  std::lock_guard lock(impl_->node.mutex());
  impl_->shortNextAt = urb;
  impl_->shortNextBy = bytes;
}
void EmulatedUsbDisplay::unplugAtRequest(usbdisplay::Request request) {
  std::lock_guard lock(impl_->node.mutex());
  impl_->unplugAtRequest = static_cast<int>(request);
}
void EmulatedUsbDisplay::failClaim(int errnoValue) {
  std::lock_guard lock(impl_->node.mutex());
  impl_->claimErrno = errnoValue;
}
void EmulatedUsbDisplay::stallAlways(bool on) {
  std::lock_guard lock(impl_->node.mutex());
  impl_->stallAll = on;
}
void EmulatedUsbDisplay::corruptNextFrame() {
  std::lock_guard lock(impl_->node.mutex());
  impl_->corruptNext = true;
}
void EmulatedUsbDisplay::truncateNextFrame(std::size_t bytes) {
  std::lock_guard lock(impl_->node.mutex());
  impl_->truncateNext = bytes;
}
void EmulatedUsbDisplay::unplugDuringNextFrame() {
  std::lock_guard lock(impl_->node.mutex());
  impl_->unplugNext = true;
}
void EmulatedUsbDisplay::setSilent(bool on) {
  std::lock_guard lock(impl_->node.mutex());
  impl_->silent = on;
}
void EmulatedUsbDisplay::silentAfterBulkUrbs(int urbs) {
  std::lock_guard lock(impl_->node.mutex());
  impl_->silentAfterUrbs = urbs;
}
void EmulatedUsbDisplay::unplugAfterBulkUrbs(int urbs) {
  std::lock_guard lock(impl_->node.mutex());
  impl_->unplugAfterUrbs = urbs;
}
void EmulatedUsbDisplay::silentAtNextPresent() {
  std::lock_guard lock(impl_->node.mutex());
  impl_->silentAtPresent = true;
}
void EmulatedUsbDisplay::failClearHalt(int errnoValue) {
  std::lock_guard lock(impl_->node.mutex());
  impl_->clearHaltErrno = errnoValue;
}
void EmulatedUsbDisplay::setAbsurdDeviceInfo(bool on) {
  std::lock_guard lock(impl_->node.mutex());
  impl_->absurdInfo = on;
}
void EmulatedUsbDisplay::setBadCalibrationCrc(bool on) {
  std::lock_guard lock(impl_->node.mutex());
  impl_->badCalibrationCrc = on;
}
void EmulatedUsbDisplay::lieInStatus(int brightness, std::int64_t presentedSequence) {
  std::lock_guard lock(impl_->node.mutex());
  impl_->statusBrightness = brightness;
  impl_->statusPresentedSequence = presentedSequence;
}
void EmulatedUsbDisplay::forgetErrors(bool on) {
  std::lock_guard lock(impl_->node.mutex());
  impl_->forgetErrors = on;
}

EmulatedDisplayState EmulatedUsbDisplay::state() const {
  std::lock_guard lock(impl_->node.mutex());
  return impl_->state;
}

cv::Mat EmulatedUsbDisplay::presented() const {
  std::lock_guard lock(impl_->node.mutex());
  return impl_->presented.clone();
}

void EmulatedUsbDisplay::observePanel(PanelObserver observer) {
  std::lock_guard lock(impl_->node.mutex());
  impl_->observer = std::move(observer);
}

std::string EmulatedUsbDisplay::syspath() const {
  return impl_->node.syspath();
}

void usePrivateTmpDir() {
  // Never destroyed: the atexit handler below runs after static destructors.
  static const std::string* dir = [] {
    std::string pattern = (std::filesystem::temp_directory_path() / "lfi-usb-test.XXXXXX").string();
    if (!mkdtemp(pattern.data())) fail(Errc::Io, "cannot create a private TMPDIR from '{}'", pattern);
    setenv("TMPDIR", pattern.c_str(), 1);
    auto* path = new std::string(pattern);
    std::atexit([] {
      std::error_code ec;
      std::filesystem::remove_all(*dir, ec);
    });
    return path;
  }();
}

bool umockdevPreloadActive() {
  const char* preload = std::getenv("LD_PRELOAD");
  return preload && std::strstr(preload, "libumockdev-preload") != nullptr;
}

}  // namespace lfi::emulation
