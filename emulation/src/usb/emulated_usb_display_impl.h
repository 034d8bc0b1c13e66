// SPDX-License-Identifier: Apache-2.0
#pragma once
// Internal to the emulated USB display: EmulatedUsbDisplay::Impl, whose methods are split
// over emulated_usb_testbed.cpp (umockdev testbed, handler thread, usbdevfs ioctls and URBs)
// and emulated_usb_device.cpp (the device's protocol state machine).

#include "lfi/emulation/emulated_usb_display.h"

#include <umockdev.h>

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <deque>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace lfi::emulation {

namespace proto = usbdisplay;

// One URB the host submitted: the umockdev copies of the struct and its buffer
// (kept referenced until reaped) and its outcome, applied at reap time.
struct Urb {
  UMockdevIoctlClient* client = nullptr;
  UMockdevIoctlData* urb = nullptr;
  UMockdevIoctlData* buffer = nullptr;
  bool bulk = false;
  int status = 0;
  int actualLength = 0;
};

// Drops the umockdev references `u` holds and empties it.
void release(Urb& u);

// The process's one testbed: umockdev's preload library follows the newest
// testbed's directory, so devices emulated at once must share one. Never
// freed (devices come and go in it; usePrivateTmpDir's folder goes at exit).
UMockdevTestbed* sharedTestbed();

struct EmulatedUsbDisplay::Impl {
  EmulatedDisplayConfig config;
  UMockdevTestbed* testbed = nullptr;
  UMockdevIoctlBase* handler = nullptr;
  GMainContext* context = nullptr;
  std::thread thread;
  std::atomic<bool> stop{false};
  std::string devnode;
  std::string syspath;
  bool inTestbed = false;  // its sysfs entry and node are in the testbed (from plug() to unplug())
  bool trace = std::getenv("LFI_USB_EMULATION_TRACE") != nullptr;  // log every ioctl to stderr

  mutable std::mutex mutex;
  EmulatedDisplayState state;
  std::deque<Urb> done;  // completed, waiting to be reaped
  std::deque<Urb> held;  // accepted but never completed (silent device)
  std::uint32_t inFlight = 0;
  bool unplugged = true;
  bool halted = false;
  // faults
  bool stallAll = false, corruptNext = false, unplugNext = false, silent = false;
  int stallNextAt = -1;      // the next frame's bulk URB that halts the endpoint; -1: none
  int shortNextAt = -1;      // the next frame's bulk URB the device takes only part of; -1: none
  int shortNextBy = 0;       // and how many of its bytes it leaves
  int unplugAtRequest = -1;  // the vendor request at which the device vanishes; -1: none
  int claimErrno = 0;        // CLAIMINTERFACE fails with this errno (0: it succeeds)
  bool absurdInfo = false, badCalibrationCrc = false, forgetErrors = false;
  int statusBrightness = -1;                  // GET_STATUS's brightness, -1: the true one
  std::int64_t statusPresentedSequence = -1;  // and its presented sequence
  std::size_t truncateNext = 0;
  int silentAfterUrbs = -1;  // bulk URBs to take before turning silent; -1: never
  int unplugAfterUrbs = -1;  // bulk URBs to take before vanishing at the next; -1: never
  bool silentAtPresent = false;
  int clearHaltErrno = 0;  // CLEAR_HALT fails with this errno (0: it succeeds)
  // frame assembly
  std::vector<std::uint8_t> rx;
  std::size_t expected = 0;  // header + payload once the header is in
  proto::FrameHeader header;
  proto::DeviceError rxError = proto::DeviceError::None;
  bool frameStarted = false;
  bool frameCorrupt = false;
  std::size_t frameTruncate = 0;
  bool frameUnplug = false;
  int frameUrb = 0;  // bulk URBs of this frame so far
  int frameStallAt = -1, frameShortAt = -1, frameShortBy = 0;
  std::uint32_t lastErrorSequence = 0;
  std::string lastErrorText;
  cv::Mat presented;
  EmulatedUsbDisplay::PanelObserver observer;

  // emulated_usb_testbed.cpp: the testbed and the handler thread
  void runOnHandlerThread(const std::function<void()>& f);
  void attachHandler();
  void removeNode() const;
  void removeFromTestbed();
  void detachHandler();
  std::string description() const;

  // ---- device side, on the handler thread, under `mutex` ----
  // emulated_usb_testbed.cpp: usbdevfs ioctls and URBs
  gboolean onIoctl(UMockdevIoctlClient* client);
  gboolean submit(UMockdevIoctlClient* client, UMockdevIoctlData* arg);
  void failAll();

  // emulated_usb_device.cpp: frames, control requests and their answers
  void resetFrame();
  void bulkOut(const std::uint8_t* bytes, int length, Urb& u);
  void reject(proto::DeviceError error, std::uint32_t sequence, std::string text);
  proto::DeviceError present(std::uint16_t sequence16);
  void control(std::uint8_t* bytes, int length, Urb& u);
  std::vector<std::uint8_t> deviceInfo() const;
};

}  // namespace lfi::emulation
