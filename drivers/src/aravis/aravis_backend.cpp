// SPDX-License-Identifier: Apache-2.0
// The aravis: scheme in the camera registry: aravis:<device-id>[?packet_size_bytes=<bytes>&usb_mode=sync|async].
#include "lfi/drivers/aravis/aravis_camera.h"
#include "lfi/drivers/camera_registry.h"

namespace lfi {
namespace {

const UriKey kPacketSize{.name = "packet_size_bytes",
                         .value = UriValue::Integer,
                         .unit = "bytes",
                         .lo = 576,
                         .hi = 65'000,
                         .meaning = "fixed GigE Vision stream packet size (default: negotiated at start)"};

const UriKey kUsbMode{.name = "usb_mode",
                      .value = UriValue::Text,
                      .meaning =
                          "USB3 Vision stream reads: sync (one transfer at a time, Aravis's default) or async "
                          "(a frame's transfers queued ahead)"};

std::unique_ptr<Camera> openAravisFromUri(const DeviceUri& uri) {
  AravisOptions options;
  if (const auto size = uriNumber<int>(uri, kPacketSize)) options.packetSize_bytes = *size;
  if (const std::string* mode = uri.find(kUsbMode.name)) {
    if (*mode != "sync" && *mode != "async")
      fail(Errc::Config, "camera URI '{}': usb_mode is '{}', not sync or async", uri.text(), *mode);
    options.usbMode = *mode == "sync" ? AravisUsbMode::Sync : AravisUsbMode::Async;
  }
  return openAravisCamera(uri.path, options);
}

}  // namespace

void registerAravisBackend() {
  backendRegistry<Camera>().addOnce(CameraBackend{
      .scheme = "aravis",
      .keys = {kPacketSize, kUsbMode},
      .description = "aravis:<device-id>[?packet_size_bytes=<bytes>&usb_mode=sync|async]  GenICam camera via Aravis",
      .factory = openAravisFromUri,
  });
}

}  // namespace lfi
