#pragma once
// Camera backends by URI scheme (STYLE.md §2). A URI is
//
//   <scheme>:<path>[?<key>=<value>[&<key>=<value>...]]
//
// e.g. "aravis:Aravis-Fake-GV01", "aravis:192.168.1.20?packetSize=1400",
// "sim:data/scenes/inspection_bench.toml". The path, keys and values reach the
// backend percent-decoded (parseDeviceUri: "%26" for a literal '&', "%25" for
// '%'); each backend declares the query keys it accepts and any other key is
// an error. Backends are registered explicitly:
// registerBuiltinBackends() adds the ones in lfi_drivers ("aravis"), and other
// libraries add theirs (lfi_sim adds "sim") with registerCameraBackend().
// The registry is process-wide and thread-safe.

#include "lfi/drivers/camera.h"
#include "lfi/drivers/device_registry.h"

#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace lfi {

using CameraUri = DeviceUri;
using CameraBackend = DeviceBackend<Camera>;
using CameraFactory = decltype(CameraBackend::factory);

// Splits a URI. Throws Errc::Config naming the URI for a missing scheme, an
// empty key, a key without '=' or a repeated key.
CameraUri parseCameraUri(std::string_view uri);

// Throws Errc::InvalidArgument if the scheme is empty, has characters other than
// [a-z0-9+.-], has no factory, or is taken.
void registerCameraBackend(CameraBackend backend);
// The same, but a taken scheme is left as it is (idempotent registration, as
// from several threads or libraries): returns whether this backend was added.
bool registerCameraBackendIfAbsent(CameraBackend backend);

// Registers the backends built into lfi_drivers. Idempotent.
void registerBuiltinBackends();

// Schemes registered so far, sorted.
std::vector<std::string> cameraSchemes();

// Parses `uri`, checks its query keys against the backend's and runs the
// factory. An unknown scheme throws Errc::Config listing the known schemes; an
// unknown key throws Errc::Config listing the accepted keys.
std::unique_ptr<Camera> openCamera(std::string_view uri);

}  // namespace lfi
