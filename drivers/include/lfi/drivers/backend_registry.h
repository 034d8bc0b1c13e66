// SPDX-License-Identifier: Apache-2.0
#pragma once
// Device backends by URI scheme: one registry per device type,
// all of the one shape below (BackendRegistry<Device>), reached through
// backendRegistry<Camera>(), backendRegistry<Display>() and
// backendRegistry<LightFieldCapture>() (camera_registry.h, display_registry.h,
// capture_registry.h). A URI is
//
//   <scheme>:<path>[?<key>=<value>[&<key>=<value>...]]
//
// e.g. "aravis:Aravis-Fake-GV01", "usb:1209:4c46/LFI-0001?timeout_ms=500",
// "sim:data/scenes/inspection_bench.toml". The path, keys and values reach the
// backend percent-decoded (parseDeviceUri); each backend declares the query
// keys it accepts and any other key is an error. Backends are registered
// explicitly, so that static linking cannot drop one: registerDriverBackends()
// adds lfi_drivers' own (aravis:, usb:), lfi::sim::registerSimBackends() the
// simulated ones (sim:). A registry is process-wide and thread-safe.

#include "lfi/core/error.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <charconv>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

namespace lfi {

// A device URI, <scheme>:<path>[?<key>=<value>[&...]]. The path, keys and
// values are percent-decoded (RFC 3986: "%XX" is the byte 0xXX), so that they
// can hold the characters that split a URI: a file "a&b.toml" is "a%26b.toml"
// in a query value, a '%' is "%25", a '?' in a path "%3F".
struct DeviceUri {
  std::string text;                          // the whole URI as given, for messages
  std::string scheme;                        // before the first ':'
  std::string path;                          // between the first ':' and '?', decoded
  std::map<std::string, std::string> query;  // key → value, decoded, keys unique
};

// Splits a URI. Throws Errc::Config naming the URI (as a "<kind> URI") for a
// missing scheme (the message shows `example`), an empty key, a key without '=',
// a repeated key, a trailing '&', or a '%' not followed by two hex digits of a
// byte 01..FF.
DeviceUri parseDeviceUri(std::string_view text, std::string_view kind, std::string_view example);

// `part` as it stands in a URI, so that parseDeviceUri gives it back: bytes
// outside printable ASCII, spaces and the delimiters "%?&=#", and the bytes in
// `alsoEncode` (e.g. "/" for a usb: serial), as %XX. For names that are shown
// as URIs: a scene path, an Aravis id, a USB serial.
std::string percentEncodeUriPart(std::string_view part, std::string_view alsoEncode = {});

// Non-empty and only [a-z0-9+.-].
bool validDeviceScheme(const std::string& scheme);

// The number the URI's query gives for `key` (all of the value, in C++'s
// from_chars syntax), or `fallback` without the key. Throws Errc::Config
// "<kind> URI '<uri>': <key> = '<value>' is not a number in <lo> .. <hi>".
template <typename T>
T uriNumber(const DeviceUri& uri, std::string_view kind, const std::string& key, T fallback, T lo, T hi) {
  const auto it = uri.query.find(key);
  if (it == uri.query.end()) return fallback;
  const std::string& text = it->second;
  T value{};
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec != std::errc() || end != text.data() + text.size() || !(value >= lo && value <= hi))
    fail(Errc::Config, "{} URI '{}': {} = '{}' is not a number in {} .. {}", kind, uri.text, key, text, lo, hi);
  return value;
}

template <typename Device>
struct DeviceBackend {
  std::string scheme;
  std::vector<std::string> queryKeys;  // keys the factory understands; others are rejected before it runs
  std::string description;             // one line for help texts
  std::function<std::unique_ptr<Device>(const DeviceUri& uri)> factory;  // returns an Open device
};

template <typename Device>
class BackendRegistry {
 public:
  // kind: "camera", "display", ...; example: a URI for the no-scheme message;
  // builtinCall: the function that registers the built-in backends, named when
  // nothing is registered.
  BackendRegistry(std::string kind, std::string example, std::string builtinCall)
      : kind_(std::move(kind)), example_(std::move(example)), builtinCall_(std::move(builtinCall)) {}

  BackendRegistry(const BackendRegistry&) = delete;
  BackendRegistry& operator=(const BackendRegistry&) = delete;

  // Splits a URI (parseDeviceUri, with this registry's kind in messages).
  DeviceUri parse(std::string_view text) const { return parseDeviceUri(text, kind_, example_); }

  // Throws Errc::InvalidArgument for a bad scheme, a missing factory or a taken scheme.
  void add(DeviceBackend<Device> backend) {
    std::lock_guard lock(mutex_);
    check(backend);
    if (backends_.contains(backend.scheme))
      fail(Errc::InvalidArgument, "{} backend scheme '{}' is already registered", kind_, backend.scheme);
    std::string scheme = backend.scheme;
    backends_.emplace(std::move(scheme), std::move(backend));
  }

  // Adds the backend unless its scheme is taken (idempotent registration);
  // returns whether it was added. Throws as add() for a bad scheme or factory.
  bool addOnce(DeviceBackend<Device> backend) {
    std::lock_guard lock(mutex_);
    check(backend);
    std::string scheme = backend.scheme;
    return backends_.try_emplace(std::move(scheme), std::move(backend)).second;
  }

  // Schemes registered so far, sorted.
  std::vector<std::string> schemes() const {
    std::lock_guard lock(mutex_);
    std::vector<std::string> out;
    for (const auto& [scheme, backend] : backends_) out.push_back(scheme);
    return out;
  }

  // Parses `text`, checks its query keys against the backend's and runs the
  // factory. An unknown scheme or key throws Errc::Config listing what is known.
  std::unique_ptr<Device> open(std::string_view text) const {
    const DeviceUri uri = parse(text);
    DeviceBackend<Device> backend;
    {
      std::lock_guard lock(mutex_);
      auto it = backends_.find(uri.scheme);
      if (it == backends_.end()) {
        std::vector<std::string> known;
        for (const auto& [scheme, b] : backends_) known.push_back(scheme + ":");
        fail(Errc::Config, "{} URI '{}': unknown scheme '{}:' (known: {})", kind_, uri.text, uri.scheme,
             known.empty() ? fmt::format("none; was {}() called?", builtinCall_)
                           : fmt::format("{}", fmt::join(known, ", ")));
      }
      backend = it->second;  // copy: the factory runs without the lock (opening a device takes time)
    }
    for (const auto& [key, value] : uri.query)
      if (std::find(backend.queryKeys.begin(), backend.queryKeys.end(), key) == backend.queryKeys.end())
        fail(Errc::Config, "{} URI '{}': unknown key '{}' for scheme '{}:' (accepted: {})", kind_, uri.text, key,
             uri.scheme,
             backend.queryKeys.empty() ? std::string("none") : fmt::format("{}", fmt::join(backend.queryKeys, ", ")));
    return backend.factory(uri);
  }

 private:
  void check(const DeviceBackend<Device>& backend) const {
    if (!validDeviceScheme(backend.scheme))
      fail(Errc::InvalidArgument, "{} backend scheme '{}' must be non-empty and use only [a-z0-9+.-]", kind_,
           backend.scheme);
    if (!backend.factory) fail(Errc::InvalidArgument, "{} backend '{}' has no factory", kind_, backend.scheme);
  }

  std::string kind_, example_, builtinCall_;
  mutable std::mutex mutex_;
  std::map<std::string, DeviceBackend<Device>> backends_;
};

// The process-wide registry of each device type; specialised (and defined
// once, in lfi_drivers) for Camera, Display and LightFieldCapture.
template <typename Device>
BackendRegistry<Device>& backendRegistry();

// Registers the backends built into lfi_drivers: aravis: (cameras) and usb:
// (displays). Idempotent.
void registerDriverBackends();

}  // namespace lfi
