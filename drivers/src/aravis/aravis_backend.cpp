// SPDX-License-Identifier: Apache-2.0
// The aravis: scheme in the camera registry: aravis:<device-id>[?packetSize=<bytes>].
#include "lfi/core/error.h"
#include "lfi/drivers/aravis/aravis_camera.h"
#include "lfi/drivers/camera_registry.h"

#include <charconv>

namespace lfi {
namespace {

std::unique_ptr<Camera> openAravisFromUri(const DeviceUri& uri) {
  AravisOptions options;
  if (auto it = uri.query.find("packetSize"); it != uri.query.end()) {
    int value = 0;
    const char* end = it->second.data() + it->second.size();
    if (const auto [at, ec] = std::from_chars(it->second.data(), end, value); ec != std::errc() || at != end)
      fail(Errc::Config, "camera URI '{}': packetSize '{}' is not an integer number of bytes", uri.text, it->second);
    if (value < 576 || value > 65'000)
      fail(Errc::Config, "camera URI '{}': packetSize {} is outside 576..65000 bytes", uri.text, value);
    options.packetSize_bytes = value;
  }
  return openAravisCamera(uri.path, options);
}

}  // namespace

void registerAravisBackend() {
  backendRegistry<Camera>().addOnce(CameraBackend{
      .scheme = "aravis",
      .queryKeys = {"packetSize"},
      .description = "aravis:<device-id>[?packetSize=<bytes>]  GenICam camera via Aravis",
      .factory = openAravisFromUri,
  });
}

}  // namespace lfi
