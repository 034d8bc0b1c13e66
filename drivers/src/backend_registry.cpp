// SPDX-License-Identifier: Apache-2.0
#include "lfi/drivers/backend_registry.h"

#include "lfi/drivers/aravis/aravis_camera.h"
#include "lfi/drivers/camera_registry.h"
#include "lfi/drivers/capture_registry.h"
#include "lfi/drivers/display_registry.h"
#include "lfi/drivers/usb/usb_display.h"

namespace lfi {

bool validDeviceScheme(const std::string& scheme) {
  if (scheme.empty()) return false;
  return std::all_of(scheme.begin(), scheme.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '+' || c == '.' || c == '-';
  });
}

namespace {

// RFC 3986's percent-encoding: "%XX" is the byte 0xXX, so that a path or a
// value can hold the characters that split a URI ('?', '&', '=', '%').
std::string percentDecoded(std::string_view part, std::string_view kind, std::string_view text) {
  auto hex = [](char c) {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
  };
  std::string out;
  for (std::size_t i = 0; i < part.size(); ++i) {
    if (part[i] != '%') {
      out += part[i];
      continue;
    }
    const int h = i + 1 < part.size() ? hex(part[i + 1]) : -1, l = i + 2 < part.size() ? hex(part[i + 2]) : -1;
    if (h < 0 || l < 0 || h + l == 0)
      fail(Errc::Config, "{} URI '{}': '%' must be followed by two hex digits of a byte 01..FF (write %25 for a '%')",
           kind, text);
    out += static_cast<char>(h * 16 + l);
    i += 2;
  }
  return out;
}

}  // namespace

std::string percentEncodeUriPart(std::string_view part, std::string_view alsoEncode) {
  std::string out;
  for (const char c : part) {
    if (c > 0x20 && c < 0x7f && std::string_view("%?&=#").find(c) == std::string_view::npos &&
        alsoEncode.find(c) == std::string_view::npos)
      out += c;
    else
      out += fmt::format("%{:02X}", static_cast<unsigned char>(c));
  }
  return out;
}

DeviceUri parseDeviceUri(std::string_view text, std::string_view kind, std::string_view example) {
  DeviceUri uri;
  uri.text = std::string(text);
  const std::size_t colon = text.find(':');
  if (colon == std::string_view::npos || colon == 0)
    fail(Errc::Config, "{} URI '{}' has no scheme (expected <scheme>:<path>, e.g. {})", kind, text, example);
  uri.scheme = std::string(text.substr(0, colon));
  std::string_view rest = text.substr(colon + 1);
  const std::size_t question = rest.find('?');
  uri.path = percentDecoded(rest.substr(0, question), kind, text);
  if (question == std::string_view::npos) return uri;

  std::string_view query = rest.substr(question + 1);
  if (query.empty()) fail(Errc::Config, "{} URI '{}' ends with '?' (no query after it)", kind, text);
  while (!query.empty()) {
    const std::size_t amp = query.find('&');
    const std::string_view item = query.substr(0, amp);
    const std::size_t eq = item.find('=');
    if (eq == std::string_view::npos || eq == 0)
      fail(Errc::Config, "{} URI '{}': query item '{}' is not <key>=<value>", kind, text, item);
    std::string key = percentDecoded(item.substr(0, eq), kind, text);
    if (uri.query.contains(key)) fail(Errc::Config, "{} URI '{}': key '{}' is given twice", kind, text, key);
    uri.query.emplace(std::move(key), percentDecoded(item.substr(eq + 1), kind, text));
    if (amp == std::string_view::npos) break;
    query = query.substr(amp + 1);
    if (query.empty()) fail(Errc::Config, "{} URI '{}' ends with '&'", kind, text);
  }
  return uri;
}

template <>
BackendRegistry<Camera>& backendRegistry<Camera>() {
  static BackendRegistry<Camera> instance("camera", "aravis:<device-id>", "registerDriverBackends");
  return instance;
}

template <>
BackendRegistry<Display>& backendRegistry<Display>() {
  static BackendRegistry<Display> instance("display", "usb:1209:4c46", "registerDriverBackends");
  return instance;
}

template <>
BackendRegistry<LightFieldCapture>& backendRegistry<LightFieldCapture>() {
  static BackendRegistry<LightFieldCapture> instance("light field capture", "sim:<scene-file>",
                                                     "lfi::sim::registerSimBackends");
  return instance;
}

void registerDriverBackends() {
  registerAravisBackend();
  registerUsbBackend();
}

}  // namespace lfi
