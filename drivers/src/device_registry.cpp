#include "lfi/drivers/device_registry.h"

namespace lfi {

bool validDeviceScheme(const std::string& scheme) {
  if (scheme.empty()) return false;
  return std::all_of(scheme.begin(), scheme.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '+' || c == '.' || c == '-';
  });
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
  uri.path = std::string(rest.substr(0, question));
  if (question == std::string_view::npos) return uri;

  std::string_view query = rest.substr(question + 1);
  if (query.empty()) fail(Errc::Config, "{} URI '{}' ends with '?' (no query after it)", kind, text);
  while (!query.empty()) {
    const std::size_t amp = query.find('&');
    const std::string_view item = query.substr(0, amp);
    const std::size_t eq = item.find('=');
    if (eq == std::string_view::npos || eq == 0)
      fail(Errc::Config, "{} URI '{}': query item '{}' is not <key>=<value>", kind, text, item);
    std::string key(item.substr(0, eq));
    if (uri.query.contains(key)) fail(Errc::Config, "{} URI '{}': key '{}' is given twice", kind, text, key);
    uri.query.emplace(std::move(key), std::string(item.substr(eq + 1)));
    if (amp == std::string_view::npos) break;
    query = query.substr(amp + 1);
    if (query.empty()) fail(Errc::Config, "{} URI '{}' ends with '&'", kind, text);
  }
  return uri;
}

}  // namespace lfi
