// SPDX-License-Identifier: Apache-2.0
#pragma once
// The camera registry: camera backends by URI scheme (backend_registry.h has
// the URI grammar and the rules). Schemes: aravis:<device-id> (lfi_drivers,
// docs/camera.md), sim:<scene-file> (lfi_sim).

#include "lfi/drivers/backend_registry.h"
#include "lfi/drivers/camera.h"
#include "lfi/drivers/driver_trace.h"

#include <memory>
#include <string_view>

namespace lfi {

using CameraBackend = DeviceBackend<Camera>;

template <>
BackendRegistry<Camera>& backendRegistry<Camera>();

// Parses `uri`, checks its query keys against the backend's and runs the
// factory. An unknown scheme throws Errc::Config listing the known schemes; an
// unknown key throws Errc::Config listing the accepted keys. With the driver
// trace on (driver_trace.h) the camera traces its calls.
inline std::unique_ptr<Camera> openCamera(const DeviceUri& uri) {
  return traceCalls(backendRegistry<Camera>().open(uri), uri.text());
}
inline std::unique_ptr<Camera> openCamera(std::string_view uri) {
  return openCamera(backendRegistry<Camera>().parse(uri));
}

}  // namespace lfi
