// SPDX-License-Identifier: Apache-2.0
#pragma once
// The display registry: display backends by URI scheme (backend_registry.h has
// the URI grammar and the rules). Schemes: usb:<vid>:<pid>[/<serial>]
// (lfi_drivers, docs/usb-display-protocol.md), window:<output> (lfi_drivers,
// window/window_display.h), sim:<scene-file> (lfi_sim).

#include "lfi/drivers/backend_registry.h"
#include "lfi/drivers/display.h"
#include "lfi/drivers/driver_trace.h"

#include <memory>
#include <string_view>

namespace lfi {

using DisplayBackend = DeviceBackend<Display>;

template <>
BackendRegistry<Display>& backendRegistry<Display>();

// Parses `uri`, checks its query keys against the backend's and runs the
// factory. An unknown scheme or key throws Errc::Config listing what is known.
// With the driver trace on (driver_trace.h) the display traces its calls.
inline std::unique_ptr<Display> openDisplay(const DeviceUri& uri) {
  return traceCalls(backendRegistry<Display>().open(uri), uri.text());
}
inline std::unique_ptr<Display> openDisplay(std::string_view uri) {
  return openDisplay(backendRegistry<Display>().parse(uri));
}

}  // namespace lfi
