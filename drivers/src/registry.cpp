#include "lfi/drivers/registry.h"

#include "lfi/core/error.h"
#include "lfi/drivers/aravis_camera.h"

#include <charconv>
#include <string>

namespace lfi {
namespace {

DeviceRegistry<Camera>& registry() {
  static DeviceRegistry<Camera> instance("camera", "aravis:<device-id>", "registerBuiltinBackends");
  return instance;
}

std::unique_ptr<Camera> openAravisFromUri(const CameraUri& uri) {
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

CameraUri parseCameraUri(std::string_view text) { return registry().parse(text); }

void registerCameraBackend(CameraBackend backend) { registry().add(std::move(backend)); }
bool registerCameraBackendIfAbsent(CameraBackend backend) { return registry().addOnce(std::move(backend)); }

void registerBuiltinBackends() {
  registry().addOnce(CameraBackend{
      .scheme = "aravis",
      .queryKeys = {"packetSize"},
      .description = "aravis:<device-id>[?packetSize=<bytes>]  GenICam camera via Aravis",
      .factory = openAravisFromUri,
  });
}

std::vector<std::string> cameraSchemes() { return registry().schemes(); }

std::unique_ptr<Camera> openCamera(std::string_view text) { return registry().open(text); }

}  // namespace lfi
