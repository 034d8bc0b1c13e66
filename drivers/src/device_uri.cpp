// SPDX-License-Identifier: Apache-2.0
#include "lfi/drivers/device_uri.h"

#include "lfi/core/error.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <charconv>
#include <cmath>

namespace lfi {
namespace {

// RFC 3986's percent-decoding: "%XX" is the byte 0xXX.
std::string percentDecoded(std::string_view part, std::string_view kind, std::string_view text) {
  auto hex = [](char c) {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
  };
  std::string out;
  for (std::size_t i = 0; i < part.size(); ++i) {
    // (NUL, which %00 cannot give either: text() writes it as %00, and a C string would end there)
    if (part[i] == '\0')
      fail(Errc::Config, "{} URI '{}': a NUL byte cannot stand in a URI", kind, shown(text, text.size()));
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

// The name without its unit suffix: "timeout_ms" → "timeout" (for telling a
// wrong unit from an unknown key).
std::string_view stem(std::string_view name) {
  const std::size_t underscore = name.rfind('_');
  return underscore == std::string_view::npos ? name : name.substr(0, underscore);
}

const char* valueName(UriValue v) {
  switch (v) {
    case UriValue::Integer:
      return "integer";
    case UriValue::Number:
      return "number";
    case UriValue::Text:
      return "text";
  }
  return "?";
}

bool snakeCase(std::string_view name) {
  return !name.empty() && name.front() >= 'a' && name.front() <= 'z' && name.back() != '_' &&
         name.find("__") == std::string_view::npos && std::all_of(name.begin(), name.end(), [](char c) {
           return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_';
         });
}

}  // namespace

bool validDeviceScheme(std::string_view scheme) {
  if (scheme.empty()) return false;
  return std::all_of(scheme.begin(), scheme.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '+' || c == '.' || c == '-';
  });
}

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

DeviceUri DeviceUri::parse(std::string_view text, std::string_view kind, std::string_view example) {
  DeviceUri uri;
  const std::size_t colon = text.find(':');
  if (colon == std::string_view::npos || colon == 0)
    fail(Errc::Config, "{} URI '{}' has no scheme (expected <scheme>:<path>, e.g. {})", kind, text, example);
  uri.scheme = std::string(text.substr(0, colon));
  if (!validDeviceScheme(uri.scheme))
    fail(Errc::Config, "{} URI '{}': the scheme '{}' must use only [a-z0-9+.-] (e.g. {})", kind, text, uri.scheme,
         example);
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

std::string DeviceUri::text() const {
  std::string out = scheme + ":" + percentEncodeUriPart(path);
  char separator = '?';
  for (const auto& [key, value] : query) {
    out += separator;
    out += percentEncodeUriPart(key) + "=" + percentEncodeUriPart(value);
    separator = '&';
  }
  return out;
}

const std::string* DeviceUri::find(const std::string& key) const {
  const auto it = query.find(key);
  return it == query.end() ? nullptr : &it->second;
}

DeviceUri DeviceUri::with(const std::string& key, std::string value) const {
  DeviceUri out = *this;
  out.query[key] = std::move(value);
  return out;
}

DeviceUri DeviceUri::without(const std::string& key) const {
  DeviceUri out = *this;
  out.query.erase(key);
  return out;
}

std::string UriKey::describe() const {
  std::string out = name + ": " + valueName(value);
  if (value != UriValue::Text) out += fmt::format(" {} .. {}", lo, hi);
  if (!unit.empty()) out += " " + unit;
  if (fallback) out += fmt::format(" (default {})", *fallback);
  if (!meaning.empty()) out += ": " + meaning;
  return out;
}

void checkUriKeyDeclaration(const UriKey& key, std::string_view owner) {
  if (!snakeCase(key.name))
    fail(Errc::InvalidArgument, "{}: query key '{}' must be snake_case ([a-z0-9_], starting with a letter)", owner,
         key.name);
  if (!key.unit.empty() && !key.name.ends_with("_" + key.unit))
    fail(Errc::InvalidArgument, "{}: query key '{}' has the unit {} and must end in '_{}'", owner, key.name, key.unit,
         key.unit);
  if (key.value != UriValue::Text && (!std::isfinite(key.lo) || !std::isfinite(key.hi) || key.lo > key.hi ||
                                      (key.fallback && !(*key.fallback >= key.lo && *key.fallback <= key.hi))))
    fail(Errc::InvalidArgument, "{}: query key '{}' declares the range {} .. {} and the default {}", owner, key.name,
         key.lo, key.hi, key.fallback ? fmt::format("{}", *key.fallback) : "none");
  if (key.value == UriValue::Text && key.fallback)
    fail(Errc::InvalidArgument, "{}: text query key '{}' cannot have a number as its default", owner, key.name);
}

void checkUriQuery(const DeviceUri& uri, const std::vector<UriKey>& keys, std::string_view kind) {
  for (const auto& entry : uri.query) {
    const std::string& name = entry.first;  // (not a structured binding: clang 14 cannot capture one)
    const auto key = std::find_if(keys.begin(), keys.end(), [&](const UriKey& k) { return k.name == name; });
    if (key != keys.end()) {
      if (key->value != UriValue::Text)
        uriNumber(uri, *key, kind);
      else if (entry.second.empty())
        fail(Errc::Config, "{} URI '{}': {} is empty", kind, uri.text(), name);
      continue;
    }
    std::vector<std::string> accepted;
    for (const UriKey& k : keys) accepted.push_back(k.describe());
    const std::string list = accepted.empty() ? std::string("none") : fmt::format("{}", fmt::join(accepted, "; "));
    const auto sameStem = std::find_if(keys.begin(), keys.end(), [&](const UriKey& k) {
      return !k.unit.empty() && (name == stem(k.name) || stem(name) == stem(k.name));
    });
    if (sameStem != keys.end())
      fail(Errc::Config, "{} URI '{}': key '{}' is not in the unit the scheme '{}:' takes: write {}", kind, uri.text(),
           name, uri.scheme, sameStem->describe());
    fail(Errc::Config, "{} URI '{}': unknown key '{}' for scheme '{}:' (accepted: {})", kind, uri.text(), name,
         uri.scheme, list);
  }
}

std::optional<double> uriNumber(const DeviceUri& uri, const UriKey& key, std::string_view kind) {
  const std::string* text = uri.find(key.name);
  if (!text) return key.fallback;
  if (key.value == UriValue::Text)
    fail(Errc::InvalidArgument, "{} URI '{}': {} is a text key, not a number", kind, uri.text(), key.name);
  double value = 0;
  bool parsed = false;
  const char* end = text->data() + text->size();
  if (key.value == UriValue::Integer) {
    long long whole = 0;
    const auto [at, ec] = std::from_chars(text->data(), end, whole);
    parsed = ec == std::errc() && at == end;
    value = static_cast<double>(whole);
  } else {
    const auto [at, ec] = std::from_chars(text->data(), end, value);
    parsed = ec == std::errc() && at == end && std::isfinite(value);
  }
  if (!parsed || !(value >= key.lo && value <= key.hi))
    fail(Errc::Config, "{} URI '{}': {} = '{}' is not {} in {} .. {}{}", kind, uri.text(), key.name, *text,
         key.value == UriValue::Integer ? "an integer" : "a number", key.lo, key.hi,
         key.unit.empty() ? "" : " " + key.unit);
  return value;
}

}  // namespace lfi
