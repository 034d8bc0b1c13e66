// SPDX-License-Identifier: Apache-2.0
#pragma once
// Internal to the emulated USB3 Vision camera: EmulatedU3vCamera::Impl, the
// device side on its usbdevfs node (usbdevfs_node.h). Its methods are split
// over u3v_device.cpp (descriptors, control requests, GenCP and the register
// memory) and u3v_stream.cpp (the stream endpoint and the frame thread).

#include "lfi/emulation/emulated_u3v_camera.h"

#include "../usb/usbdevfs_node.h"

#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <map>
#include <string>
#include <thread>
#include <vector>

namespace lfi::emulation {

using detail::Urb;

// The USB endpoints and interfaces.
namespace u3vusb {
inline constexpr unsigned char kControlOut = 0x01, kControlIn = 0x81, kStreamIn = 0x82;
inline constexpr unsigned kControlInterface = 0, kStreamInterface = 1;
inline constexpr std::uint32_t kLeaderSize = 52, kTrailerSize = 32;  // an image's stream leader and trailer
}  // namespace u3vusb

// The little-endian fields of GenCP packets, stream leaders and trailers, and registers.
inline std::uint16_t getU16(const std::uint8_t* p) {
  return static_cast<std::uint16_t>(p[0] | p[1] << 8);
}
inline std::uint32_t getU32(const std::uint8_t* p) {
  return static_cast<std::uint32_t>(p[0]) | static_cast<std::uint32_t>(p[1]) << 8 |
         static_cast<std::uint32_t>(p[2]) << 16 | static_cast<std::uint32_t>(p[3]) << 24;
}
inline std::uint64_t getU64(const std::uint8_t* p) {
  return getU32(p) | static_cast<std::uint64_t>(getU32(p + 4)) << 32;
}
inline void putU16(std::uint8_t* p, std::uint16_t v) {
  p[0] = static_cast<std::uint8_t>(v), p[1] = static_cast<std::uint8_t>(v >> 8);
}
inline void putU32(std::uint8_t* p, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}
inline void putU64(std::uint8_t* p, std::uint64_t v) {
  putU32(p, static_cast<std::uint32_t>(v)), putU32(p + 4, static_cast<std::uint32_t>(v >> 32));
}

// GenCP status codes the device answers with.
enum class GencpStatus : std::uint16_t {
  Success = 0x0000,
  NotImplemented = 0x8001,
  InvalidParameter = 0x8002,
  InvalidAddress = 0x8003,
  WriteProtect = 0x8004,
  BadAlignment = 0x8005,
};

struct EmulatedU3vCamera::Impl final : detail::UsbdevfsDevice {
  Impl(const EmulatedU3vCameraConfig& c, ServedFrameFiller f);
  ~Impl() override;

  EmulatedU3vCameraConfig config;
  ServedFrameFiller filler;
  std::string guid;

  // ---- under node.mutex() ----
  EmulatedU3vCameraState state;
  std::map<std::uint64_t, std::vector<std::uint8_t>> memory;  // regions by base address
  std::deque<std::vector<std::uint8_t>> acks;                 // for the control IN endpoint
  struct Transfer {                                           // one device transfer on the stream endpoint
    std::vector<std::uint8_t> bytes;
    std::size_t sent = 0;
    bool endsFrame = false;  // the trailer
  };
  std::deque<Transfer> stream;
  int queuedFrames = 0;
  bool streamHalted = false;
  std::uint64_t pendingTriggers = 0;
  std::uint64_t framesLeft = 0;  // SingleFrame / MultiFrame: frames still to make; 0 with Continuous
  bool stopThread = false;
  // faults (emulated_u3v_camera.h)
  bool stallAll = false, corruptTrailerNext = false, silent = false;
  std::size_t shortNext = 0;
  std::uint16_t failNext = 0;
  std::condition_variable wake;  // (with node.mutex()) the frame thread: acquisition, trigger, stop
  detail::UsbdevfsNode node;     // (its handler thread stops before what it calls goes)
  std::thread frameThread;       // (last: joined first)

  // u3v_device.cpp
  std::string record() const;
  void resetRegisters();
  Submitted submit(Urb& u) override;
  int claimInterface(unsigned interface, bool claim) override;
  int clearHalt(unsigned endpoint) override;
  Submitted control(Urb& u);
  void command(const std::uint8_t* bytes, int length);
  GencpStatus read(std::uint64_t address, std::size_t length, std::vector<std::uint8_t>& out) const;
  GencpStatus write(std::uint64_t address, const std::uint8_t* data, std::size_t length);
  std::uint8_t* at(std::uint64_t address, std::size_t length);
  std::uint32_t reg(std::uint64_t address) const;
  void setReg(std::uint64_t address, std::uint32_t value);
  float floatReg(std::uint64_t address) const;
  void updatePayloadSize();
  std::uint64_t payloadSize() const;
  void deliverAcks();

  // u3v_stream.cpp
  void runFrames();
  void queueFrame(const ServedFrameRequest& request, std::uint32_t format, std::vector<std::uint8_t> payload,
                  std::uint64_t timestamp_ns);
  bool fillStream(Urb& u);  // the next bytes of the stream into `u`; false: nothing to send yet
  void deliverStream();
  void startAcquisition();
};

}  // namespace lfi::emulation
