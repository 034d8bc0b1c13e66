// SPDX-License-Identifier: Apache-2.0
// The aravis: scheme in the camera registry: aravis:<device-id>[?packet_size_bytes=<bytes>].
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

std::unique_ptr<Camera> openAravisFromUri(const DeviceUri& uri) {
  AravisOptions options;
  if (const auto size = uriNumber<int>(uri, kPacketSize)) options.packetSize_bytes = *size;
  return openAravisCamera(uri.path, options);
}

}  // namespace

void registerAravisBackend() {
  backendRegistry<Camera>().addOnce(CameraBackend{
      .scheme = "aravis",
      .keys = {kPacketSize},
      .description = "aravis:<device-id>[?packet_size_bytes=<bytes>]  GenICam camera via Aravis",
      .factory = openAravisFromUri,
  });
}

}  // namespace lfi
