#include "lfi/drivers/display_registry.h"

#include "lfi/core/error.h"
#include "lfi/drivers/usb_display.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <charconv>
#include <mutex>

namespace lfi {
namespace {

struct Registry {
  std::mutex mutex;
  std::map<std::string, DisplayBackend> backends;
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

std::unique_ptr<Display> openUsbFromUri(const DisplayUri& uri) {
  const UsbDisplaySelector selector = parseUsbDisplayPath(uri.path, uri.text);
  UsbDisplayOptions options;
  if (auto it = uri.query.find("timeout_ms"); it != uri.query.end()) {
    int value = 0;
    const auto [end, ec] = std::from_chars(it->second.data(), it->second.data() + it->second.size(), value);
    if (ec != std::errc() || end != it->second.data() + it->second.size() || value < 1 || value > 600'000)
      fail(Errc::Config, "display URI '{}': timeout_ms '{}' is not an integer in 1..600000", uri.text, it->second);
    options.controlTimeout = std::chrono::milliseconds(value);
    options.transferTimeout = std::chrono::milliseconds(value);
  }
  return openUsbDisplay(selector, options);
}

}  // namespace

DisplayUri parseDisplayUri(std::string_view text) {
  DisplayUri uri;
  uri.text = std::string(text);
  const std::size_t colon = text.find(':');
  if (colon == std::string_view::npos || colon == 0)
    fail(Errc::Config, "display URI '{}' has no scheme (expected <scheme>:<path>, e.g. usb:1209:4c46)", text);
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
      fail(Errc::Config, "display URI '{}': query item '{}' is not <key>=<value>", text, item);
    std::string key(item.substr(0, eq));
    if (uri.query.contains(key)) fail(Errc::Config, "display URI '{}': key '{}' is given twice", text, key);
    uri.query.emplace(std::move(key), std::string(item.substr(eq + 1)));
    if (amp == std::string_view::npos) break;
    query = query.substr(amp + 1);
    if (query.empty()) fail(Errc::Config, "display URI '{}' ends with '&'", text);
  }
  return uri;
}

void registerDisplayBackend(DisplayBackend backend) {
  if (!validScheme(backend.scheme))
    fail(Errc::InvalidArgument, "display backend scheme '{}' must be non-empty and use only [a-z0-9+.-]",
         backend.scheme);
  if (!backend.factory) fail(Errc::InvalidArgument, "display backend '{}' has no factory", backend.scheme);
  Registry& reg = registry();
  std::lock_guard lock(reg.mutex);
  if (reg.backends.contains(backend.scheme))
    fail(Errc::InvalidArgument, "display backend scheme '{}' is already registered", backend.scheme);
  std::string scheme = backend.scheme;
  reg.backends.emplace(std::move(scheme), std::move(backend));
}

void registerBuiltinDisplayBackends() {
  Registry& reg = registry();
  std::lock_guard lock(reg.mutex);
  if (reg.backends.contains("usb")) return;
  reg.backends.emplace("usb", DisplayBackend{
                                  .scheme = "usb",
                                  .queryKeys = {"timeout_ms"},
                                  .description = "usb:<vid>:<pid>[/<serial>][?timeout_ms=<ms>]  light field "
                                                 "display over USB (libusb, lfi vendor protocol)",
                                  .factory = openUsbFromUri,
                              });
}

std::vector<std::string> displaySchemes() {
  Registry& reg = registry();
  std::lock_guard lock(reg.mutex);
  std::vector<std::string> schemes;
  for (const auto& [scheme, backend] : reg.backends) schemes.push_back(scheme);
  return schemes;
}

std::unique_ptr<Display> openDisplay(std::string_view text) {
  const DisplayUri uri = parseDisplayUri(text);
  DisplayBackend backend;
  {
    Registry& reg = registry();
    std::lock_guard lock(reg.mutex);
    auto it = reg.backends.find(uri.scheme);
    if (it == reg.backends.end()) {
      std::vector<std::string> known;
      for (const auto& [scheme, b] : reg.backends) known.push_back(scheme + ":");
      fail(Errc::Config, "display URI '{}': unknown scheme '{}:' (known: {})", uri.text, uri.scheme,
           known.empty() ? std::string("none; was registerBuiltinDisplayBackends() called?")
                         : fmt::format("{}", fmt::join(known, ", ")));
    }
    backend = it->second;  // copy: the factory runs without the lock
  }
  for (const auto& [key, value] : uri.query) {
    if (std::find(backend.queryKeys.begin(), backend.queryKeys.end(), key) == backend.queryKeys.end())
      fail(Errc::Config, "display URI '{}': unknown key '{}' for scheme '{}:' (accepted: {})", uri.text, key,
           uri.scheme,
           backend.queryKeys.empty() ? std::string("none") : fmt::format("{}", fmt::join(backend.queryKeys, ", ")));
  }
  return backend.factory(uri);
}

}  // namespace lfi
