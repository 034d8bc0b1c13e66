// SPDX-License-Identifier: Apache-2.0
#pragma once
// An emulated lfi USB display for tests, benchmarks and the simulated bench:
// the device side of docs/usb-display-protocol.md behind Linux usbdevfs, built
// on umockdev. A UMockdevTestbed holds the device's sysfs attributes and
// descriptors; an ioctl handler (UMockdevIoctlBase, "handle-ioctl") answers
// what libusb sends to /dev/bus/usb/BBB/DDD: SUBMITURB (control and bulk),
// REAPURB(NDELAY), DISCARDURB, CLAIMINTERFACE/RELEASEINTERFACE, CLEAR_HALT,
// GET_CAPABILITIES. The real `usb:` backend talks to it through the real
// libusb; only the kernel is replaced.
//
// The process must run with umockdev's preload library (umockdev-wrapper or
// LD_PRELOAD=libumockdev-preload.so.0), or libusb does not see the testbed.
//
// The handler runs on its own GLib main context thread; the test thread reads the
// device's state (last presented panel, counters) under a mutex and arms faults.
// Several devices may be emulated at once (distinct busNumber/deviceNumber):
// they share the process's one testbed.
// Frames are validated like firmware would: header magic/version/CRC, sizes against
// the panel, payload CRC, exact byte count; the last valid presented frame is kept.

#include "lfi/drivers/usb/usb_display_protocol.h"

#include <opencv2/core.hpp>

#include <cstdint>
#include <functional>
#include <memory>
#include <string>

namespace lfi::emulation {

struct EmulatedDisplayConfig {
  std::uint16_t vendorId = usbdisplay::kDefaultVendorId;
  std::uint16_t productId = usbdisplay::kDefaultProductId;
  std::string vendor = "lfi";
  std::string model = "emulated lenticular";
  std::string serial = "LFI-EMU-0001";
  bool serialDescriptor = true;  // false: no USB serial string (iSerialNumber 0); the info block still has `serial`
  int busNumber = 1;
  int deviceNumber = 2;
  int panelWidth_px = 640;
  int panelHeight_px = 400;
  usbdisplay::SubpixelCode subpixels = usbdisplay::SubpixelCode::RgbStripe;
  int brightnessMax = 255;
  int viewCount = 45;
  usbdisplay::CalibrationBlock calibration;  // defaults filled by the constructor when pixelPitch_mm is 0
};

// Counters and state as the device sees them.
struct EmulatedDisplayState {
  bool plugged = false;
  bool claimed = false;
  bool showing = false;
  int brightness = 0;
  std::uint32_t presentedSequence = 0;
  std::uint32_t framesPresented = 0;
  std::uint32_t framesRejected = 0;
  std::uint32_t clearHalts = 0;
  std::uint32_t bulkUrbs = 0;
  std::uint32_t maxUrbsInFlight = 0;  // most bulk URBs submitted and not yet reaped at once
  std::uint32_t controlRequests = 0;
  usbdisplay::DeviceError lastError = usbdisplay::DeviceError::None;
};

class EmulatedUsbDisplay {
 public:
  explicit EmulatedUsbDisplay(EmulatedDisplayConfig config = {});
  ~EmulatedUsbDisplay();
  EmulatedUsbDisplay(const EmulatedUsbDisplay&) = delete;
  EmulatedUsbDisplay& operator=(const EmulatedUsbDisplay&) = delete;

  // Adds the device to the testbed (ioctl handler first, then sysfs + node).
  void plug();
  // Fails every pending URB with -ESHUTDOWN, answers ENODEV from then on, and
  // removes the device from the testbed (with a "remove" uevent).
  void unplug();
  // The device stays listed (sysfs) but its /dev node is gone, so that
  // libusb_open fails: a node udev has not made yet, or one a program cannot open.
  void loseNode();

  // Faults, each for the next frame only unless said otherwise.
  void stallNextFrame(int urb = 0);           // bulk URB `urb` (0: the first) of the next frame halts the endpoint
  void shortenNextFrame(int urb, int bytes);  // bulk URB `urb` of the next frame completes with `bytes` fewer taken
  void stallAlways(bool on);                  // every bulk URB halts the endpoint (clear halt does not help)
  void corruptNextFrame();                    // a payload byte flips on arrival → payload CRC mismatch
  void truncateNextFrame(std::size_t bytes);  // the device loses the last `bytes` of the next frame
  void unplugDuringNextFrame();               // the device vanishes after the first bulk URB of the next frame
  void unplugAfterBulkUrbs(int urbs);  // take `urbs` more bulk URBs, then vanish at the next (as unplugAtRequest)
  void setSilent(bool on);             // accept URBs but never complete them (a hung device)
  void silentAfterBulkUrbs(int urbs);  // take `urbs` more bulk URBs, then be silent (hangs mid-frame)
  void silentAtNextPresent();          // be silent from the next PRESENT request on (the frame stays held)
  void failClearHalt(int errnoValue);  // CLEAR_HALT fails with this errno until set to 0 (the frame stays held)
  void setAbsurdDeviceInfo(bool on);   // GET_DEVICE_INFO announces a 4 GiB calibration blob
  void setBadCalibrationCrc(bool on);  // the calibration blob's CRC does not match
  void lieInStatus(int brightness, std::int64_t presentedSequence);  // GET_STATUS says these (-1: the truth)
  void forgetErrors(bool on);                                        // GET_LAST_ERROR says "no error" whatever happened
  // The device vanishes when vendor request `request` arrives: it and every
  // pending URB fail with -ESHUTDOWN, all else with ENODEV, as after an unplug
  // (unplug() then removes its node).
  void unplugAtRequest(usbdisplay::Request request);
  void failClaim(int errnoValue);  // CLAIMINTERFACE fails with this errno until set to 0 (EBUSY: held elsewhere)

  const EmulatedDisplayConfig& config() const { return config_; }
  EmulatedDisplayState state() const;
  // The last presented panel (CV_8UC1 or CV_8UC3), empty if none.
  cv::Mat presented() const;
  // What the device does to its panel, as a simulated bench's renderer follows
  // it: each frame it presents (valid, as presented() then returns it) with its
  // sequence, each brightness it is set to, each blank. Called on the handler
  // thread with the device's lock held, before the request is answered: a
  // handler must not call this device, and should copy what it keeps and
  // return. Empty functions are not called; observePanel({}) stops observing.
  struct PanelObserver {
    std::function<void(const cv::Mat& panel, std::uint32_t sequence)> presented;
    std::function<void(int level)> brightness;
    std::function<void()> blanked;
  };
  void observePanel(PanelObserver observer);
  std::string syspath() const;

  struct Impl;

 private:
  EmulatedDisplayConfig config_;
  std::unique_ptr<Impl> impl_;
};

// Creates a private TMPDIR for this process (umockdev's testbed lives there) and
// removes it at exit; call before the first testbed.
void usePrivateTmpDir();

// True when umockdev's preload library is active in this process.
bool umockdevPreloadActive();

}  // namespace lfi::emulation
