// SPDX-License-Identifier: Apache-2.0
#pragma once
// The light field capture registry: reference capture backends by URI scheme
// (backend_registry.h has the URI grammar and the rules). Schemes:
// sim:<scene-file> (lfi_sim: the simulated lensless light field sensor).

#include "lfi/drivers/backend_registry.h"
#include "lfi/drivers/light_field_capture.h"

#include <memory>
#include <string_view>

namespace lfi {

using LightFieldCaptureBackend = DeviceBackend<LightFieldCapture>;

template <>
BackendRegistry<LightFieldCapture>& backendRegistry<LightFieldCapture>();

// Parses `uri`, checks its query keys against the backend's and runs the
// factory. An unknown scheme or key throws Errc::Config listing what is known.
inline std::unique_ptr<LightFieldCapture> openLightFieldCapture(const DeviceUri& uri) {
  return backendRegistry<LightFieldCapture>().open(uri);
}
inline std::unique_ptr<LightFieldCapture> openLightFieldCapture(std::string_view uri) {
  return backendRegistry<LightFieldCapture>().open(uri);
}

}  // namespace lfi
