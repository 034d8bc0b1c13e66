// SPDX-License-Identifier: Apache-2.0
#pragma once
// Device URIs as values, and the query keys a backend declares.
//
//   <scheme>:<path>[?<key>=<value>[&<key>=<value>...]]
//
// e.g. "aravis:Aravis-Fake-GV01?packet_size_bytes=1500",
// "usb:1209:4c46/LFI-0001?timeout_ms=500", "sim:data/scenes/inspection_bench.toml".
// A DeviceUri holds the parts decoded; text() formats them back, so that
// DeviceUri::parse(u.text()) == u for every URI. Nothing edits URI text: a
// URI is changed as a value (with(), without(), a new path) and formatted.
//
// Query keys are snake_case and end in their unit when they have one
// (`timeout_ms`, `pitch_mm`, `beam_half_angle_rad`, `packet_size_bytes`), as
// the bench file's keys do. A backend declares each key it accepts (UriKey:
// name, kind of value, unit, range, default); its registry
// (backend_registry.h) refuses any other key, a value that is not a number
// of the key's kind or lies outside its range, and a known key with another
// unit suffix, naming the URI, the key and what is accepted.

#include <fmt/format.h>

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace lfi {

// A device URI, its parts percent-decoded (RFC 3986: "%XX" is the byte 0xXX),
// so that they can hold the characters that split a URI: a file "a&b.toml" is
// "a%26b.toml" in a query value, a '%' is "%25", a '?' in a path "%3F".
struct DeviceUri {
  std::string scheme;                        // before the first ':'; [a-z0-9+.-]
  std::string path;                          // between the first ':' and '?', decoded
  std::map<std::string, std::string> query;  // key → value, decoded, keys unique

  // Splits `text`. Throws Errc::Config naming the URI (as a "<kind> URI") for
  // a missing scheme (the message shows `example`), an empty key, a key
  // without '=', a repeated key, a trailing '&', a '%' not followed by two
  // hex digits of a byte 01..FF, or a NUL byte.
  static DeviceUri parse(std::string_view text, std::string_view kind, std::string_view example);

  // The URI as text: the path, keys and values percent-encoded where they hold
  // a delimiter ("%?&=#"), a space or a byte outside printable ASCII; keys in
  // sorted order. parse(text()) gives this URI back.
  std::string text() const;

  // The value of `key`, or nullptr.
  const std::string* find(const std::string& key) const;
  // This URI with `key` set to `value` (added or replaced).
  DeviceUri with(const std::string& key, std::string value) const;
  // This URI without `key` (unchanged when it has none).
  DeviceUri without(const std::string& key) const;

  bool operator==(const DeviceUri&) const = default;
};

// `part` as it stands in a URI, so that DeviceUri::parse gives it back: bytes
// outside printable ASCII, spaces and the delimiters "%?&=#", and the bytes in
// `alsoEncode` (e.g. "/" for a usb: serial), as %XX.
std::string percentEncodeUriPart(std::string_view part, std::string_view alsoEncode = {});

// Non-empty and only [a-z0-9+.-].
bool validDeviceScheme(std::string_view scheme);

// What a query key's value is.
enum class UriValue : std::uint8_t {
  Integer,  // a whole number (C++ from_chars syntax), within [lo, hi]
  Number,   // a real number, within [lo, hi]
  Text,     // any text (a file name, an id); not empty
};

// One query key a backend accepts.
struct UriKey {
  std::string name;  // snake_case; ends in "_<unit>" when unit is set
  UriValue value = UriValue::Number;
  std::string unit;                // "mm", "rad", "ms", "bytes"; empty for counts, ratios, flags, text
  double lo = 0, hi = 0;           // the accepted range of a number, inclusive
  std::optional<double> fallback;  // a number's value without the key; none: the backend's own choice
  std::string meaning;             // one line for help texts

  // "timeout_ms: integer 1 .. 600000 ms (default 5000): <meaning>", for help texts and errors.
  std::string describe() const;
};

// Checks a key declaration: a snake_case name that ends in "_<unit>" when the
// unit is set, lo <= hi, a default within the range. Throws
// Errc::InvalidArgument naming `owner` (a backend) and the key.
void checkUriKeyDeclaration(const UriKey& key, std::string_view owner);

// Checks `uri`'s query against `keys`: every key known, every number of its
// kind and within its range, every text non-empty. A key that is not declared
// but shares a declared key's stem with another unit suffix (timeout_s for
// timeout_ms) is refused as the wrong unit. Throws Errc::Config
// "<kind> URI '<uri>': ..." naming the key and what is accepted.
void checkUriQuery(const DeviceUri& uri, const std::vector<UriKey>& keys, std::string_view kind);

// The number `uri` gives for a number key (checked as checkUriQuery does), or
// the key's default, or none. Throws Errc::Config as checkUriQuery, and
// Errc::InvalidArgument for a text key (read those with DeviceUri::find). A
// backend's factory runs after its registry checked the URI, so it reads its
// keys with the default `kind`.
std::optional<double> uriNumber(const DeviceUri& uri, const UriKey& key, std::string_view kind = "device");

template <typename T>
std::optional<T> uriNumber(const DeviceUri& uri, const UriKey& key, std::string_view kind = "device") {
  const std::optional<double> value = uriNumber(uri, key, kind);
  return value ? std::optional<T>(static_cast<T>(*value)) : std::nullopt;
}

}  // namespace lfi

// fmt::format("{}", uri) writes uri.text().
template <>
struct fmt::formatter<lfi::DeviceUri> : fmt::formatter<std::string_view> {
  template <typename FormatContext>
  auto format(const lfi::DeviceUri& uri, FormatContext& ctx) const {
    return fmt::formatter<std::string_view>::format(uri.text(), ctx);
  }
};
