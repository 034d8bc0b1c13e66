// SPDX-License-Identifier: Apache-2.0
// Device URIs (drivers/device_uri.h) as every registry reads them, on any text: DeviceUri::parse, then the query
// checked against every registered backend's declared keys (aravis:, usb:, sim:, coded:) with checkUriQuery,
// and each declared key read with uriNumber (or find, for text), as a backend's factory reads it. No device is
// opened. A URI read must format back to itself, and a query checkUriQuery takes must give every number key a
// value of its kind within its range.
#include "fuzz_input.h"

#include "lfi/controller/coded_capture.h"
#include "lfi/drivers/builtin_backends.h"
#include "lfi/drivers/camera_registry.h"
#include "lfi/drivers/capture_registry.h"
#include "lfi/drivers/display_registry.h"
#include "lfi/sim/devices/sim_camera.h"

#include <cmath>
#include <cstdlib>

namespace {

void require(bool holds, const char* what, const lfi::DeviceUri& uri) {
  if (holds) return;
  std::fprintf(stderr, "device_uri: %s: '%s'\n", what, uri.text().c_str());
  std::abort();
}

template <typename Device>
void everyBackend(std::string_view text, const char* kind) {
  const lfi::BackendRegistry<Device>& registry = lfi::backendRegistry<Device>();
  lfi::DeviceUri uri;
  try {
    uri = registry.parse(text);
  } catch (const lfi::Error&) {
    return;
  }
  try {
    require(registry.parse(uri.text()) == uri, "the URI formats to another", uri);
  } catch (const lfi::Error&) {
    require(false, "the URI formats to text that does not parse", uri);
  }
  for (const std::string& scheme : registry.schemes()) {
    const std::vector<lfi::UriKey> keys = registry.keys(scheme);
    bool accepted = true;
    try {
      lfi::checkUriQuery(uri, keys, kind);
    } catch (const lfi::Error&) {
      accepted = false;
    }
    for (const lfi::UriKey& key : keys) {
      const std::string* given = uri.find(key.name);
      if (key.value == lfi::UriValue::Text) {
        require(!accepted || !given || !given->empty(), "an empty text value taken", uri);
        continue;
      }
      try {
        const std::optional<double> value = lfi::uriNumber(uri, key, kind);
        require(!given || value, "a number given reads as none", uri);
        if (value) {
          require(*value >= key.lo && *value <= key.hi, "a number outside its key's range", uri);
          require(key.value != lfi::UriValue::Integer || *value == std::floor(*value), "an integer with a fraction",
                  uri);
        }
      } catch (const lfi::Error&) {
        require(!accepted, "a number checkUriQuery took that uriNumber refuses", uri);
      }
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const bool registered = [] {
    lfi::registerDriverBackends();
    lfi::sim::registerSimBackends();
    lfi::registerControllerBackends();
    return true;
  }();
  (void)registered;
  const std::string_view text = lfi::fuzz::text(data, size);
  everyBackend<lfi::Camera>(text, "camera");
  everyBackend<lfi::Display>(text, "display");
  everyBackend<lfi::LightFieldCapture>(text, "light field capture");
  return 0;
}
