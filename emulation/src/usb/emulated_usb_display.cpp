// SPDX-License-Identifier: Apache-2.0
// EmulatedUsbDisplay (emulated_usb_display.h): plugging the device in and out, arming
// faults and reading its state from the test thread, and the process-wide umockdev setup.

#include "lfi/emulation/emulated_usb_display.h"

#include "emulated_usb_display_impl.h"

#include "lfi/core/error.h"

#include <fmt/format.h>
#include <umockdev.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <string>
#include <system_error>
#include <thread>
#include <utility>

namespace lfi::emulation {

EmulatedUsbDisplay::EmulatedUsbDisplay(EmulatedDisplayConfig config) : config_(std::move(config)), impl_(new Impl) {
  if (config_.calibration.pixelPitch_mm == 0) {
    config_.calibration.pixelPitch_mm = 25.4 / 338.0;
    config_.calibration.version = usbdisplay::kCalibrationVersion1;  // a device of the horizontal-parallax class
    config_.calibration.optics = usbdisplay::OpticsCode::Lenticular;
    config_.calibration.lensPitch_px = 7.22;
    config_.calibration.slant_rad = 0.1826;
    config_.calibration.offset_px = 0.3;
    config_.calibration.gap_mm = 0.7333;
    config_.calibration.focalLength_mm = 0.7333;
  }
  Impl& d = *impl_;
  d.config = config_;
  d.devnode = fmt::format("/dev/bus/usb/{:03d}/{:03d}", config_.busNumber, config_.deviceNumber);
  d.syspath = fmt::format("/sys/devices/{}-{}", config_.busNumber, config_.deviceNumber);
  d.testbed = sharedTestbed();
  d.context = g_main_context_new();
  d.thread = std::thread([&d] {
    g_main_context_push_thread_default(d.context);
    while (!d.stop.load()) g_main_context_iteration(d.context, TRUE);
    // Let pending completions flush before the context goes away.
    while (g_main_context_iteration(d.context, FALSE)) {
    }
    g_main_context_pop_thread_default(d.context);
  });
}

EmulatedUsbDisplay::~EmulatedUsbDisplay() {
  Impl& d = *impl_;
  try {
    d.runOnHandlerThread([&d] {
      {
        std::lock_guard lock(d.mutex);
        for (Urb& u : d.done) release(u);
        for (Urb& u : d.held) release(u);
        d.done.clear();
        d.held.clear();
      }
      d.detachHandler();
    });
  } catch (...) {
  }
  d.removeFromTestbed();  // (the testbed is shared: the next device must not find this one)
  d.stop = true;
  g_main_context_wakeup(d.context);
  d.thread.join();
  g_main_context_unref(d.context);
}

void EmulatedUsbDisplay::plug() {
  Impl& d = *impl_;
  {
    std::lock_guard lock(d.mutex);
    if (!d.unplugged) return;
  }
  d.runOnHandlerThread([&d] {
    d.detachHandler();
    d.attachHandler();
  });
  {
    std::lock_guard lock(d.mutex);
    d.unplugged = false;
    d.halted = false;
    d.resetFrame();
    d.state.plugged = true;
    d.state.claimed = false;
  }
  GError* error = nullptr;
  if (!umockdev_testbed_add_from_string(d.testbed, d.description().c_str(), &error)) {
    std::string message = error ? error->message : "unknown error";
    g_clear_error(&error);
    fail(Errc::Device, "emulated display: adding the device to the testbed failed: {}", message);
  }
  d.inTestbed = true;
  umockdev_testbed_uevent(d.testbed, d.syspath.c_str(), "add");
}

void EmulatedUsbDisplay::unplug() {
  Impl& d = *impl_;
  {
    std::lock_guard lock(d.mutex);
    d.failAll();
    d.state.plugged = false;
    d.state.claimed = false;
  }
  d.removeFromTestbed();
}

void EmulatedUsbDisplay::loseNode() {
  impl_->removeNode();
}

void EmulatedUsbDisplay::stallNextFrame(int urb) {
  std::lock_guard lock(impl_->mutex);
  impl_->stallNextAt = urb;
}
void EmulatedUsbDisplay::shortenNextFrame(int urb, int bytes) {
  std::lock_guard lock(impl_->mutex);
  impl_->shortNextAt = urb;
  impl_->shortNextBy = bytes;
}
void EmulatedUsbDisplay::unplugAtRequest(usbdisplay::Request request) {
  std::lock_guard lock(impl_->mutex);
  impl_->unplugAtRequest = static_cast<int>(request);
}
void EmulatedUsbDisplay::failClaim(int errnoValue) {
  std::lock_guard lock(impl_->mutex);
  impl_->claimErrno = errnoValue;
}
void EmulatedUsbDisplay::stallAlways(bool on) {
  std::lock_guard lock(impl_->mutex);
  impl_->stallAll = on;
}
void EmulatedUsbDisplay::corruptNextFrame() {
  std::lock_guard lock(impl_->mutex);
  impl_->corruptNext = true;
}
void EmulatedUsbDisplay::truncateNextFrame(std::size_t bytes) {
  std::lock_guard lock(impl_->mutex);
  impl_->truncateNext = bytes;
}
void EmulatedUsbDisplay::unplugDuringNextFrame() {
  std::lock_guard lock(impl_->mutex);
  impl_->unplugNext = true;
}
void EmulatedUsbDisplay::setSilent(bool on) {
  std::lock_guard lock(impl_->mutex);
  impl_->silent = on;
}
void EmulatedUsbDisplay::silentAfterBulkUrbs(int urbs) {
  std::lock_guard lock(impl_->mutex);
  impl_->silentAfterUrbs = urbs;
}
void EmulatedUsbDisplay::unplugAfterBulkUrbs(int urbs) {
  std::lock_guard lock(impl_->mutex);
  impl_->unplugAfterUrbs = urbs;
}
void EmulatedUsbDisplay::silentAtNextPresent() {
  std::lock_guard lock(impl_->mutex);
  impl_->silentAtPresent = true;
}
void EmulatedUsbDisplay::failClearHalt(int errnoValue) {
  std::lock_guard lock(impl_->mutex);
  impl_->clearHaltErrno = errnoValue;
}
void EmulatedUsbDisplay::setAbsurdDeviceInfo(bool on) {
  std::lock_guard lock(impl_->mutex);
  impl_->absurdInfo = on;
}
void EmulatedUsbDisplay::setBadCalibrationCrc(bool on) {
  std::lock_guard lock(impl_->mutex);
  impl_->badCalibrationCrc = on;
}
void EmulatedUsbDisplay::lieInStatus(int brightness, std::int64_t presentedSequence) {
  std::lock_guard lock(impl_->mutex);
  impl_->statusBrightness = brightness;
  impl_->statusPresentedSequence = presentedSequence;
}
void EmulatedUsbDisplay::forgetErrors(bool on) {
  std::lock_guard lock(impl_->mutex);
  impl_->forgetErrors = on;
}

EmulatedDisplayState EmulatedUsbDisplay::state() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->state;
}

cv::Mat EmulatedUsbDisplay::presented() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->presented.clone();
}

void EmulatedUsbDisplay::observePanel(PanelObserver observer) {
  std::lock_guard lock(impl_->mutex);
  impl_->observer = std::move(observer);
}

std::string EmulatedUsbDisplay::syspath() const {
  return impl_->syspath;
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
