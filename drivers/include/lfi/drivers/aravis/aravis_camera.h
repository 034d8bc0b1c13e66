// SPDX-License-Identifier: Apache-2.0
#pragma once
// The GenICam backend on Aravis 0.8: any GigE Vision or USB3 Vision camera.
// URI: "aravis:<device-id>[?packetSize=<bytes>]" where <device-id> is what
// listAravisDevices() reports (Aravis's "<vendor>-<model>-<serial>" form), a GigE
// camera's IP address, or empty for the first camera found (found at the first
// open() and kept by its id: a reopen after a loss reconnects that camera, and
// info().deviceId names it). packetSize fixes the
// GigE Vision stream packet size instead of negotiating the largest that passes
// (arv_camera_gv_auto_packet_size). Aravis types stay inside the .cpp.
//
// Device loss: when grab times out, the backend asks the device whether it is
// still there (for GigE Vision a GVCP register read with 5 × 200 ms timeouts, not
// Aravis's 5 × 500 ms) and throws Errc::Device if it is not; so grab returns
// within timeout + 1 s. Destroying a camera whose device vanished can take
// Aravis's GVCP timeout (about 2.5 s) while it tries to release control.

#include "lfi/drivers/camera.h"

#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace lfi {

// One device as Aravis's discovery sees it.
struct AravisDeviceInfo {
  std::string id;  // pass to openAravisCamera / "aravis:<id>"
  std::string physicalId;
  std::string address;  // IP address for GigE Vision, bus address for USB3 Vision
  std::string vendor;
  std::string model;
  std::string serial;
  std::string protocol;  // "GigEVision" or "USB3Vision"
};

// Runs discovery (GigE Vision broadcast on every interface, USB enumeration);
// takes up to about a second on a network with GigE Vision devices.
std::vector<AravisDeviceInfo> listAravisDevices();

// How Aravis reads a USB3 Vision stream: one transfer at a time, each as large as a
// MiB (Sync, Aravis's default), or a frame's leader, payload and trailer transfers
// queued ahead at their own sizes (Async: fewer bytes moved, more usbfs memory held;
// docs/camera.md).
enum class AravisUsbMode { Sync, Async };

struct AravisOptions {
  std::optional<int> packetSize_bytes;   // GigE Vision only; unset = negotiate
  std::optional<AravisUsbMode> usbMode;  // USB3 Vision only; unset = Aravis's default (Sync)
};

// Opens the device (state Open). A device id that matches nothing throws
// Errc::NotFound listing the devices found.
std::unique_ptr<Camera> openAravisCamera(const std::string& deviceId, const AravisOptions& options = {});

// Adds the aravis: scheme to the camera registry (registerDriverBackends() calls it). Idempotent.
void registerAravisBackend();

}  // namespace lfi
