// SPDX-License-Identifier: Apache-2.0
#pragma once
// The served camera without its network (internal to lfi_emulation): Aravis's
// register model of a camera (ArvFakeCamera, the memory that GVCP's READREG,
// WRITEREG, READMEM and WRITEMEM commands read and write; Aravis's device
// thread answers them) set up as GvCameraServer serves it, and the frame fill
// that reads what a client left in the registers. GvCameraServer runs one on
// the camera of its ArvGvFakeCamera; the fuzz target gvcp_registers on one
// with no sockets.

#include "lfi/emulation/gv_camera_server.h"

#include <arv.h>

#include <atomic>
#include <string>

namespace lfi::emulation::detail {

class ServedCameraDevice {
 public:
  // Sets `camera` up: identity, sensor size, heartbeat timeout, trigger check
  // rate, and this object's frame fill. `camera` is not owned; it must not
  // fill a frame after this object is gone.
  ServedCameraDevice(ArvFakeCamera* camera, const GvCameraServerOptions& options, ServedFrameFiller filler);
  ServedCameraDevice(const ServedCameraDevice&) = delete;
  ServedCameraDevice& operator=(const ServedCameraDevice&) = delete;

  ArvFakeCamera* camera() const { return camera_; }

 private:
  // Aravis's fill-pattern callback, on its device thread.
  static void fill(ArvBuffer* buffer, void* data, guint32 exposure_us, guint32 gain, ArvPixelFormat format);
  void warnOnce(const std::string& what);

  GvCameraServerOptions options_;
  ServedFrameFiller filler_;
  ArvFakeCamera* camera_;
  std::string lastWarning_;  // (Aravis's device thread only)
  // Released last in the constructor, acquired first in fill: Aravis hands
  // this object to its device thread under a GMutex (a futex) that
  // ThreadSanitizer does not see; this is the hand-over it sees.
  std::atomic<bool> published_{false};
};

// The digital outputs' registers (SFNC's DigitalIOControl), in the device's
// own register space above GigE Vision's bootstrap registers (0x0000 to
// 0x9FFF), where Aravis's fake camera keeps nothing. LineMode and LineSource
// are one register per line, UserOutputValue one per user output, 4 bytes apart.
constexpr guint32 kLineSelectorRegister = 0xA000;
constexpr guint32 kLineModeRegister = 0xA010;
constexpr guint32 kLineSourceRegister = 0xA020;
constexpr guint32 kUserOutputSelectorRegister = 0xA030;
constexpr guint32 kUserOutputValueRegister = 0xA040;

// The served camera's GenICam description: `fakeCameraXml` (Aravis's fake
// camera's) with the category DigitalIOControl added (LineSelector, LineMode,
// LineSource, UserOutputSelector, UserOutputValue on the registers above).
std::string servedGenicamXml(const std::string& fakeCameraXml);

// "<vendor>-<model>-<serial>", what Aravis's discovery reports.
std::string servedDeviceId(const GvCameraServerOptions& options);

}  // namespace lfi::emulation::detail
