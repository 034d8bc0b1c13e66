// SPDX-License-Identifier: Apache-2.0
#pragma once
// Device backends by URI scheme: one registry per device type,
// all of the one shape below (BackendRegistry<Device>), reached through
// backendRegistry<Camera>(), backendRegistry<Display>() and
// backendRegistry<LightFieldCapture>() (camera_registry.h, display_registry.h,
// capture_registry.h). A device is named by a URI (device_uri.h); each
// backend declares the query keys it accepts, and the registry checks a URI's
// query against them before the backend sees it. Backends are registered
// explicitly, so that static linking cannot drop one (builtin_backends.h). A
// registry is process-wide and thread-safe.

#include "lfi/core/error.h"
#include "lfi/drivers/device_uri.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

namespace lfi {

template <typename Device>
struct DeviceBackend {
  std::string scheme;
  std::vector<UriKey> keys;  // the query keys the factory understands; the registry checks the rest away
  std::string description;   // one line for help texts
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

  // Splits a URI (DeviceUri::parse, with this registry's kind in messages).
  DeviceUri parse(std::string_view text) const { return DeviceUri::parse(text, kind_, example_); }

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

  // The keys the backend of `scheme` declares (empty for an unknown scheme).
  std::vector<UriKey> keys(const std::string& scheme) const {
    std::lock_guard lock(mutex_);
    const auto it = backends_.find(scheme);
    return it == backends_.end() ? std::vector<UriKey>{} : it->second.keys;
  }

  // Parses `text` and opens it as open(const DeviceUri&) does.
  std::unique_ptr<Device> open(std::string_view text) const { return open(parse(text)); }

  // Checks the URI's query against the backend's keys (checkUriQuery) and runs
  // the factory. An unknown scheme, an unknown key or a value out of its key's
  // range throws Errc::Config naming the URI and what is accepted.
  std::unique_ptr<Device> open(const DeviceUri& uri) const {
    DeviceBackend<Device> backend;
    {
      std::lock_guard lock(mutex_);
      auto it = backends_.find(uri.scheme);
      if (it == backends_.end()) {
        std::vector<std::string> known;
        for (const auto& [scheme, b] : backends_) known.push_back(scheme + ":");
        fail(Errc::Config, "{} URI '{}': unknown scheme '{}:' (known: {})", kind_, uri.text(), uri.scheme,
             known.empty() ? fmt::format("none; was {}() called?", builtinCall_)
                           : fmt::format("{}", fmt::join(known, ", ")));
      }
      backend = it->second;  // copy: the factory runs without the lock (opening a device takes time)
    }
    checkUriQuery(uri, backend.keys, kind_);
    return backend.factory(uri);
  }

 private:
  void check(const DeviceBackend<Device>& backend) const {
    if (!validDeviceScheme(backend.scheme))
      fail(Errc::InvalidArgument, "{} backend scheme '{}' must be non-empty and use only [a-z0-9+.-]", kind_,
           backend.scheme);
    if (!backend.factory) fail(Errc::InvalidArgument, "{} backend '{}' has no factory", kind_, backend.scheme);
    for (const UriKey& key : backend.keys) checkUriKeyDeclaration(key, kind_ + " backend '" + backend.scheme + "'");
  }

  std::string kind_, example_, builtinCall_;
  mutable std::mutex mutex_;
  std::map<std::string, DeviceBackend<Device>> backends_;
};

// The process-wide registry of each device type; specialised (and defined
// once, in lfi_drivers) for Camera, Display and LightFieldCapture.
template <typename Device>
BackendRegistry<Device>& backendRegistry();

}  // namespace lfi
