#include "lfi/drivers/light_field_capture.h"

namespace lfi {
namespace {

DeviceRegistry<LightFieldCapture>& registry() {
  static DeviceRegistry<LightFieldCapture> instance("light field capture", "sim:<scene-file>", "registerSimBackends");
  return instance;
}

}  // namespace

void registerLightFieldCaptureBackend(LightFieldCaptureBackend backend) { registry().add(std::move(backend)); }
bool registerLightFieldCaptureBackendIfAbsent(LightFieldCaptureBackend backend) {
  return registry().addOnce(std::move(backend));
}

std::vector<std::string> lightFieldCaptureSchemes() { return registry().schemes(); }

std::unique_ptr<LightFieldCapture> openLightFieldCapture(std::string_view uri) { return registry().open(uri); }

}  // namespace lfi
