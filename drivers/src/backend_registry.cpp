// SPDX-License-Identifier: Apache-2.0
#include "lfi/drivers/backend_registry.h"

#include "lfi/drivers/camera_registry.h"
#include "lfi/drivers/capture_registry.h"
#include "lfi/drivers/display_registry.h"

namespace lfi {

template <>
BackendRegistry<Camera>& backendRegistry<Camera>() {
  static BackendRegistry<Camera> instance("camera", "aravis:<device-id>", "registerDriverBackends");
  return instance;
}

template <>
BackendRegistry<Display>& backendRegistry<Display>() {
  static BackendRegistry<Display> instance("display", "usb:1209:4c46", "registerDriverBackends");
  return instance;
}

template <>
BackendRegistry<LightFieldCapture>& backendRegistry<LightFieldCapture>() {
  static BackendRegistry<LightFieldCapture> instance("light field capture", "sim:<scene-file>",
                                                     "lfi::sim::registerSimBackends");
  return instance;
}

}  // namespace lfi
