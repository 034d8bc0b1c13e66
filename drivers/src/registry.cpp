#include "lfi/drivers/registry.h"

#include "lfi/core/error.h"
#include "lfi/drivers/aravis_camera.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <mutex>
#include <string>

namespace lfi {
namespace {

struct Registry {
  std::mutex mutex;
  std::map<std::string, CameraBackend> backends;
};

Registry& registry() {
  static Registry instance;
  return instance;
}

bool validScheme(const std::string& scheme) {
  if (scheme.empty()) return false;
  return std::all_of(scheme.begin(), scheme.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '+' || c == '.' || c == '-';
  });
}

std::unique_ptr<Camera> openAravisFromUri(const CameraUri& uri) {
  AravisOptions options;
  if (auto it = uri.query.find("packetSize"); it != uri.query.end()) {
    int value = 0;
    try {
      std::size_t used = 0;
      value = std::stoi(it->second, &used);
      if (used != it->second.size()) throw std::invalid_argument("trailing characters");
    } catch (const std::exception&) {
      fail(Errc::Config, "camera URI '{}': packetSize '{}' is not an integer number of bytes", uri.text, it->second);
    }
    if (value < 576 || value > 65'000)
      fail(Errc::Config, "camera URI '{}': packetSize {} is outside 576..65000 bytes", uri.text, value);
    options.packetSize_bytes = value;
  }
  return openAravisCamera(uri.path, options);
}

}  // namespace

CameraUri parseCameraUri(std::string_view text) {
  CameraUri uri;
  uri.text = std::string(text);
  const std::size_t colon = text.find(':');
  if (colon == std::string_view::npos || colon == 0)
    fail(Errc::Config, "camera URI '{}' has no scheme (expected <scheme>:<path>, e.g. aravis:<device-id>)", text);
  uri.scheme = std::string(text.substr(0, colon));
  std::string_view rest = text.substr(colon + 1);
  const std::size_t question = rest.find('?');
  uri.path = std::string(rest.substr(0, question));
  if (question == std::string_view::npos) return uri;

  std::string_view query = rest.substr(question + 1);
  while (!query.empty()) {
    const std::size_t amp = query.find('&');
    const std::string_view item = query.substr(0, amp);
    const std::size_t eq = item.find('=');
    if (eq == std::string_view::npos || eq == 0)
      fail(Errc::Config, "camera URI '{}': query item '{}' is not <key>=<value>", text, item);
    std::string key(item.substr(0, eq));
    if (uri.query.contains(key)) fail(Errc::Config, "camera URI '{}': key '{}' is given twice", text, key);
    uri.query.emplace(std::move(key), std::string(item.substr(eq + 1)));
    if (amp == std::string_view::npos) break;
    query = query.substr(amp + 1);
    if (query.empty()) fail(Errc::Config, "camera URI '{}' ends with '&'", text);
  }
  return uri;
}

void registerCameraBackend(CameraBackend backend) {
  if (!validScheme(backend.scheme))
    fail(Errc::InvalidArgument, "camera backend scheme '{}' must be non-empty and use only [a-z0-9+.-]",
         backend.scheme);
  if (!backend.factory) fail(Errc::InvalidArgument, "camera backend '{}' has no factory", backend.scheme);
  Registry& reg = registry();
  std::lock_guard lock(reg.mutex);
  if (reg.backends.contains(backend.scheme))
    fail(Errc::InvalidArgument, "camera backend scheme '{}' is already registered", backend.scheme);
  std::string scheme = backend.scheme;
  reg.backends.emplace(std::move(scheme), std::move(backend));
}

void registerBuiltinBackends() {
  Registry& reg = registry();
  std::lock_guard lock(reg.mutex);
  if (reg.backends.contains("aravis")) return;
  reg.backends.emplace("aravis",
                       CameraBackend{
                           .scheme = "aravis",
                           .queryKeys = {"packetSize"},
                           .description = "aravis:<device-id>[?packetSize=<bytes>]  GenICam camera via Aravis",
                           .factory = openAravisFromUri,
                       });
}

std::vector<std::string> cameraSchemes() {
  Registry& reg = registry();
  std::lock_guard lock(reg.mutex);
  std::vector<std::string> schemes;
  for (const auto& [scheme, backend] : reg.backends) schemes.push_back(scheme);
  return schemes;
}

std::unique_ptr<Camera> openCamera(std::string_view text) {
  const CameraUri uri = parseCameraUri(text);
  CameraBackend backend;
  {
    Registry& reg = registry();
    std::lock_guard lock(reg.mutex);
    auto it = reg.backends.find(uri.scheme);
    if (it == reg.backends.end()) {
      std::vector<std::string> known;
      for (const auto& [scheme, b] : reg.backends) known.push_back(scheme + ":");
      fail(Errc::Config, "camera URI '{}': unknown scheme '{}:' (known: {})", uri.text, uri.scheme,
           known.empty() ? std::string("none; was registerBuiltinBackends() called?")
                         : fmt::format("{}", fmt::join(known, ", ")));
    }
    backend = it->second;  // copy: the factory runs without the lock (opening a device takes time)
  }
  for (const auto& [key, value] : uri.query) {
    if (std::find(backend.queryKeys.begin(), backend.queryKeys.end(), key) == backend.queryKeys.end())
      fail(Errc::Config, "camera URI '{}': unknown key '{}' for scheme '{}:' (accepted: {})", uri.text, key, uri.scheme,
           backend.queryKeys.empty() ? std::string("none") : fmt::format("{}", fmt::join(backend.queryKeys, ", ")));
  }
  return backend.factory(uri);
}

}  // namespace lfi
