// SPDX-License-Identifier: Apache-2.0
#pragma once
// Internal to the emulated USB display: EmulatedUsbDisplay::Impl, the device side on
// its usbdevfs node (usbdevfs_node.h), whose methods are split over
// emulated_usb_display.cpp (its record, URBs, claims, faults) and
// emulated_usb_device.cpp (the protocol's state machine).

#include "lfi/emulation/emulated_usb_display.h"

#include "usbdevfs_node.h"

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace lfi::emulation {

namespace proto = usbdisplay;
using detail::Urb;

// The display's device side on its usbdevfs node. Everything but the
// constructor runs under node.mutex(): on the node's handler thread, or on the
// test thread arming faults and reading state.
struct EmulatedUsbDisplay::Impl final : detail::UsbdevfsDevice {
  explicit Impl(const EmulatedDisplayConfig& c);

  EmulatedDisplayConfig config;
  EmulatedDisplayState state;
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
  detail::UsbdevfsNode node;  // (last: its handler thread stops before the rest goes)

  // The device's sysfs record and descriptors (one bulk OUT endpoint, high speed).
  std::string record() const;

  // detail::UsbdevfsDevice: the host's URBs, claims and clear-halts
  Submitted submit(Urb& u) override;
  int claimInterface(unsigned interface, bool claim) override;
  int clearHalt(unsigned endpoint) override;
  void vanish();  // the device goes mid-transfer (a fault)

  // emulated_usb_device.cpp: frames, control requests and their answers
  void resetFrame();
  void bulkOut(const std::uint8_t* bytes, int length, Urb& u);
  void reject(proto::DeviceError error, std::uint32_t sequence, std::string text);
  proto::DeviceError present(std::uint16_t sequence16);
  void control(std::uint8_t* bytes, int length, Urb& u);
  std::vector<std::uint8_t> deviceInfo() const;
};

}  // namespace lfi::emulation
