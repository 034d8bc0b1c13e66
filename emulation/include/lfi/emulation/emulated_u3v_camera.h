// SPDX-License-Identifier: Apache-2.0
#pragma once
// An emulated USB3 Vision camera for tests, benchmarks and the simulated bench:
// the device side of USB3 Vision behind Linux usbdevfs, on umockdev (as the
// emulated USB display, emulated_usb_display.h). Aravis's own USB3 Vision code
// (arv_camera_new on the device's id, arv-tool-0.8) talks to it through the real
// libusb; only the kernel is replaced.
//
//   USB            a SuperSpeed device of class 0xEF/0x02/0x01 (interface association)
//                  with a control interface (0xEF/0x05/0x00: bulk OUT 0x01, bulk IN
//                  0x81, the USB3 Vision device info descriptor naming the GUID
//                  string) and a streaming interface (0xEF/0x05/0x02: bulk IN 0x82)
//   GenCP          READMEM, WRITEMEM on the control endpoints; acks as one
//                  transfer each; a bad command gets its status (NOT_IMPLEMENTED,
//                  INVALID_ADDRESS, INVALID_PARAMETER, WRITE_PROTECT)
//   registers      ABRM at 0, SBRM, SIRM, the manifest table and the GenICam XML
//                  (src/u3v/u3v_registers.h); the camera's features (SFNC names:
//                  Width, Height, OffsetX/Y, BinningHorizontal/Vertical, PixelFormat
//                  Mono8/Mono12/Mono12p/Mono16, PayloadSize, AcquisitionMode/Start/
//                  Stop, TriggerMode/Source/Software, ExposureTime, Gain,
//                  AcquisitionFrameRate, Line/UserOutput features, Device* strings)
//   stream         per frame a leader (52 bytes), the payload in the transfers the
//                  host wrote into SIRM, a trailer (32 bytes), on bulk IN 0x82
//
// Frames come from a filler (gv_camera_server.h's ServedFrameFiller: the same
// requests as the GigE Vision camera's, gain in dB) on the camera's own frame
// thread: free running at AcquisitionFrameRate, or one a software trigger or
// fireLine(). A host that does not read its frames loses the newest (the
// device holds at most kQueuedFrames) and they are counted.
//
// The process must run with umockdev's preload library, as for the USB display.

#include "lfi/emulation/gv_camera_server.h"

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

namespace lfi::emulation {

struct EmulatedU3vCameraConfig {
  std::uint16_t vendorId = 0x1209;  // pid.codes, whose product ids 0x0001..0x0010 are for tests
  std::uint16_t productId = 0x0001;
  std::string vendor = "lfi";
  std::string model = "SimCamera U3V";
  std::string serial = "LFIU3V01";
  std::string guid;  // the USB3 Vision device GUID string; empty: vendor id and serial hashed, 12 hex digits
  int busNumber = 2;
  int deviceNumber = 2;
  int sensorWidth_px = 512;
  int sensorHeight_px = 512;
  std::uint32_t maxDeviceResponseTime_ms = 200;  // ABRM: how long a host waits for an ack
};

// The device's USB3 Vision GUID (config.guid, or its default) and the id Aravis
// lists the device under, "<vendor>-<guid>-<serial>" (aravis:<id>).
std::string emulatedU3vGuid(const EmulatedU3vCameraConfig& config);
std::string emulatedU3vDeviceId(const EmulatedU3vCameraConfig& config);

// What the device has seen and done.
struct EmulatedU3vCameraState {
  bool plugged = false;
  bool controlClaimed = false, streamClaimed = false;
  bool streamEnabled = false;  // SIRM Control's enable bit
  bool acquiring = false;      // between AcquisitionStart and AcquisitionStop
  std::uint64_t commands = 0;  // GenCP commands received
  std::uint64_t framesSent = 0, framesDropped = 0;
  std::uint64_t lastFrameId = 0;
  bool userOutput = false;  // UserOutputValue of UserOutput0
};

class EmulatedU3vCamera {
 public:
  static constexpr int kQueuedFrames = 4;

  EmulatedU3vCamera(EmulatedU3vCameraConfig config, ServedFrameFiller filler);
  ~EmulatedU3vCamera();
  EmulatedU3vCamera(const EmulatedU3vCamera&) = delete;
  EmulatedU3vCamera& operator=(const EmulatedU3vCamera&) = delete;

  // Adds the device to the testbed (with its registers at their defaults) / takes
  // it out: every pending transfer fails as the device vanishes.
  void plug();
  void unplug();

  // emulatedU3vDeviceId(config()).
  std::string deviceId() const { return emulatedU3vDeviceId(config_); }
  const EmulatedU3vCameraConfig& config() const { return config_; }
  // The device's sysfs record and descriptors in umockdev's text format, as plug()
  // adds them to the testbed (also what udev's rules are tested on: tests/udev/).
  std::string record() const;
  EmulatedU3vCameraState state() const;

  // An edge on input line 0: one frame if TriggerMode is On with TriggerSource
  // Line0 and the acquisition runs. Returns whether it triggered one.
  bool fireLine();

  // Faults, each for the next frame or command only unless said otherwise.
  void stallStream(bool on);                   // every stream transfer fails: the endpoint halted (until off)
  void shortenNextFrame(std::size_t bytes);    // the next frame's payload arrives `bytes` short
  void corruptNextTrailer();                   // the next frame's trailer arrives without its magic
  void failNextCommand(std::uint16_t status);  // the next GenCP command is answered with this status
  void setSilent(bool on);                     // GenCP commands are taken and never answered (until off)

  struct Impl;

 private:
  EmulatedU3vCameraConfig config_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace lfi::emulation
