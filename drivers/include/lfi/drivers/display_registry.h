#pragma once
// Display backends by URI scheme (STYLE.md §2), the counterpart of the camera
// registry (registry.h) with the same rules. A URI is
//
//   <scheme>:<path>[?<key>=<value>[&<key>=<value>...]]
//
// e.g. "usb:1209:4c46", "usb:1209:4c46/LFI-0001?timeout_ms=500",
// "sim:data/scenes/inspection_bench.toml". The path goes to the backend as is; each
// backend declares the query keys it accepts and any other key is an error.
// Backends are registered explicitly: registerBuiltinDisplayBackends() adds the
// ones in lfi_drivers ("usb"); other libraries add theirs with
// registerDisplayBackend(). The registry is process-wide and thread-safe.

#include "lfi/drivers/device_registry.h"
#include "lfi/drivers/display.h"

#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace lfi {

using DisplayUri = DeviceUri;
using DisplayBackend = DeviceBackend<Display>;
using DisplayFactory = decltype(DisplayBackend::factory);

// Splits a URI. Throws Errc::Config naming the URI for a missing scheme, an empty
// key, a key without '=' or a repeated key.
DisplayUri parseDisplayUri(std::string_view uri);

// Throws Errc::InvalidArgument if the scheme is empty, has characters other than
// [a-z0-9+.-], has no factory, or is taken.
void registerDisplayBackend(DisplayBackend backend);
// The same, but a taken scheme is left as it is: returns whether this backend was added.
bool registerDisplayBackendIfAbsent(DisplayBackend backend);

// Registers the display backends built into lfi_drivers ("usb"). Idempotent.
void registerBuiltinDisplayBackends();

// Schemes registered so far, sorted.
std::vector<std::string> displaySchemes();

// Parses `uri`, checks its query keys against the backend's and runs the factory.
// An unknown scheme or key throws Errc::Config listing what is known.
std::unique_ptr<Display> openDisplay(std::string_view uri);

}  // namespace lfi
