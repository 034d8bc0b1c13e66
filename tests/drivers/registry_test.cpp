// SPDX-License-Identifier: Apache-2.0
// The device URI grammar, URIs as values and the backend registry (no device needed).

#include "lfi/drivers/builtin_backends.h"
#include "lfi/drivers/camera_registry.h"
#include "lfi_test_support.h"

#include <gtest/gtest.h>

namespace lfi {
namespace {

using testing_support::throwsError;

TEST(DeviceUri, SplitsSchemePathAndQuery) {
  const DeviceUri uri = backendRegistry<Camera>().parse("aravis:192.168.1.20?packet_size_bytes=1400&x=y");
  EXPECT_EQ(uri.scheme, "aravis");
  EXPECT_EQ(uri.path, "192.168.1.20");
  ASSERT_EQ(uri.query.size(), 2u);
  EXPECT_EQ(uri.query.at("packet_size_bytes"), "1400");
  EXPECT_EQ(uri.query.at("x"), "y");
  EXPECT_EQ(uri.text(), "aravis:192.168.1.20?packet_size_bytes=1400&x=y");
}

// text() writes what parse() reads back to the same value: the delimiters and
// bytes outside printable ASCII encoded, keys in order whatever order they came in.
TEST(DeviceUri, FormatsWhatItParsesBackToTheSameValue) {
  const DeviceUri built{.scheme = "sim",
                        .path = "/benches/a?b c/100%#1.toml",
                        .query = {{"file", "x&y=z.toml"}, {"k=1", "\xC3\xA9 /"}, {"spp", "64"}}};
  const std::string text = built.text();
  EXPECT_EQ(text, "sim:/benches/a%3Fb%20c/100%25%231.toml?file=x%26y%3Dz.toml&k%3D1=%C3%A9%20/&spp=64");
  EXPECT_EQ(DeviceUri::parse(text, "device", "sim:x"), built);
  const DeviceUri reordered = DeviceUri::parse("usb:1209:4c46/A%2FB?timeout_ms=5&calibration=c.toml", "d", "usb:x");
  EXPECT_EQ(reordered.text(), "usb:1209:4c46/A/B?calibration=c.toml&timeout_ms=5");
  EXPECT_EQ(DeviceUri::parse(reordered.text(), "d", "usb:x"), reordered);
  EXPECT_EQ(fmt::format("{}", reordered), reordered.text());
}

TEST(DeviceUri, IsChangedAsAValue) {
  const DeviceUri uri = DeviceUri::parse("coded:?rounds=3", "capture", "coded:");
  EXPECT_EQ(uri.with("iterations", "2").text(), "coded:?iterations=2&rounds=3");
  EXPECT_EQ(uri.with("rounds", "4").text(), "coded:?rounds=4");
  EXPECT_EQ(uri.without("rounds").text(), "coded:");
  EXPECT_EQ(uri.without("absent"), uri);
  ASSERT_NE(uri.find("rounds"), nullptr);
  EXPECT_EQ(*uri.find("rounds"), "3");
  EXPECT_EQ(uri.find("iterations"), nullptr);
}

TEST(DeviceUri, PathKeepsColonsAndMayBeEmpty) {
  EXPECT_EQ(backendRegistry<Camera>().parse("sim:data/benches/a:b.toml").path, "data/benches/a:b.toml");
  const DeviceUri empty = backendRegistry<Camera>().parse("aravis:");
  EXPECT_EQ(empty.scheme, "aravis");
  EXPECT_TRUE(empty.path.empty());
  EXPECT_TRUE(empty.query.empty());
}

// The characters that split a URI, percent-encoded, reach the backend as
// themselves: in the path, a key and a value (e.g. a calibration file "a&b.toml").
TEST(DeviceUri, PathKeysAndValuesArePercentDecoded) {
  const DeviceUri uri =
      backendRegistry<Camera>().parse("sim:/benches/a%3Fb/100%25.toml?file=x%26y%3Dz.toml&k%3D1=%2f%2F");
  EXPECT_EQ(uri.path, "/benches/a?b/100%.toml");
  ASSERT_EQ(uri.query.size(), 2u);
  EXPECT_EQ(uri.query.at("file"), "x&y=z.toml");
  EXPECT_EQ(uri.query.at("k=1"), "//");
  EXPECT_EQ(backendRegistry<Camera>().parse("aravis:%C3%A9").path, "\xC3\xA9");  // any byte but NUL
  for (const char* bad : {"sim:100%.toml", "sim:a%2", "sim:a%zz", "sim:a%00b", "aravis:x?a=%", "aravis:x?%g1=2"})
    EXPECT_TRUE(
        throwsError([&] { backendRegistry<Camera>().parse(bad); }, Errc::Config, {bad, "two hex digits", "%25"}))
        << bad;
}

// NUL, which no part of a URI can hold as %00, is refused as a byte of its own too: the URI it would be in
// formats to %00 (found by fuzzing, fuzz/corpus/device_uri/regression-nul-in-a-key).
TEST(DeviceUri, ARawNulByteIsRefusedAsItsEncodingIs) {
  using namespace std::string_literals;
  for (const std::string& bad : {"sim:a\0b.toml"s, "aravis:x?packet_size_by\0=1500"s, "aravis:x?a=1\0"s})
    EXPECT_TRUE(throwsError([&] { backendRegistry<Camera>().parse(bad); }, Errc::Config, {"NUL byte", "\\x00"}))
        << shown(bad);
}

// Every byte but NUL survives the way through a URI, in the path and in a value.
TEST(DeviceUri, PercentEncodingRoundTrips) {
  std::string all;
  for (int c = 1; c < 256; ++c) all += static_cast<char>(c);
  const std::string encoded = percentEncodeUriPart(all);
  EXPECT_EQ(encoded.find_first_of("?&=# \x7f"), std::string::npos);
  EXPECT_EQ(backendRegistry<Camera>().parse("sim:" + encoded).path, all);
  EXPECT_EQ(backendRegistry<Camera>().parse("sim:x?file=" + encoded).query.at("file"), all);
  EXPECT_EQ(percentEncodeUriPart("a/b", "/"), "a%2Fb");
  EXPECT_EQ(percentEncodeUriPart("data/benches/a:b.toml"), "data/benches/a:b.toml");  // as it was
}

TEST(DeviceUri, MalformedUrisAreConfigErrors) {
  EXPECT_TRUE(throwsError([] { backendRegistry<Camera>().parse("Aravis-Fake-GV01"); }, Errc::Config,
                          {"Aravis-Fake-GV01", "no scheme"}));
  EXPECT_TRUE(throwsError([] { backendRegistry<Camera>().parse(":x"); }, Errc::Config, {"no scheme"}));
  EXPECT_TRUE(throwsError([] { backendRegistry<Camera>().parse("aravis:x?packet_size_bytes"); }, Errc::Config,
                          {"'packet_size_bytes'", "<key>=<value>"}));
  EXPECT_TRUE(
      throwsError([] { backendRegistry<Camera>().parse("Aravis:x"); }, Errc::Config, {"'Aravis'", "[a-z0-9+.-]"}));
  EXPECT_TRUE(throwsError([] { backendRegistry<Camera>().parse("aravis:x?=3"); }, Errc::Config, {"<key>=<value>"}));
  EXPECT_TRUE(throwsError([] { backendRegistry<Camera>().parse("aravis:x?a=1&a=2"); }, Errc::Config, {"'a'", "twice"}));
  EXPECT_TRUE(throwsError([] { backendRegistry<Camera>().parse("aravis:x?a=1&"); }, Errc::Config, {"ends with '&'"}));
  EXPECT_TRUE(
      throwsError([] { backendRegistry<Camera>().parse("aravis:x?"); }, Errc::Config, {"aravis:x?", "ends with '?'"}));
}

TEST(CameraRegistry, UnknownSchemeListsKnownSchemes) {
  registerDriverBackends();
  registerDriverBackends();  // idempotent
  EXPECT_TRUE(throwsError([] { openCamera("gige:cam1"); }, Errc::Config, {"gige:cam1", "unknown scheme", "aravis:"}));
}

TEST(CameraRegistry, UnknownQueryKeyListsAcceptedKeys) {
  registerDriverBackends();
  // Rejected before any device is looked for.
  EXPECT_TRUE(throwsError([] { openCamera("aravis:x?packetsize=1400"); }, Errc::Config,
                          {"unknown key 'packetsize'", "packet_size_bytes: integer 576 .. 65000 bytes"}));
  EXPECT_TRUE(throwsError([] { openCamera("aravis:x?packet_size_bytes=big"); }, Errc::Config,
                          {"packet_size_bytes = 'big'", "not an integer in 576 .. 65000 bytes"}));
  EXPECT_TRUE(throwsError([] { openCamera("aravis:x?packet_size_bytes=1500.5"); }, Errc::Config, {"not an integer"}));
  EXPECT_TRUE(throwsError([] { openCamera("aravis:x?packet_size_bytes=100"); }, Errc::Config, {"576 .. 65000"}));
  // The same quantity in another unit, or without one, is named as such.
  EXPECT_TRUE(throwsError([] { openCamera("aravis:x?packet_size_kib=1"); }, Errc::Config,
                          {"'packet_size_kib'", "not in the unit", "packet_size_bytes"}));
  EXPECT_TRUE(throwsError([] { openCamera("aravis:x?packet_size=1400"); }, Errc::Config,
                          {"'packet_size'", "not in the unit", "packet_size_bytes"}));
}

// A backend's keys are declared in the one style, with a range their default lies in.
TEST(CameraRegistry, KeyDeclarationsAreChecked) {
  const auto add = [](UriKey key) {
    backendRegistry<Camera>().add(
        {.scheme = "test-keys", .keys = {key}, .factory = [](const DeviceUri&) { return std::unique_ptr<Camera>(); }});
  };
  EXPECT_TRUE(throwsError([&] { add({.name = "packetSize"}); }, Errc::InvalidArgument, {"'packetSize'", "snake_case"}));
  EXPECT_TRUE(throwsError([&] { add({.name = "timeout", .unit = "ms", .lo = 1, .hi = 2}); }, Errc::InvalidArgument,
                          {"'timeout'", "must end in '_ms'"}));
  EXPECT_TRUE(throwsError([&] { add({.name = "gain", .lo = 2, .hi = 1}); }, Errc::InvalidArgument, {"'gain'"}));
  EXPECT_TRUE(throwsError([&] { add({.name = "gain", .lo = 0, .hi = 1, .fallback = 2}); }, Errc::InvalidArgument,
                          {"'gain'", "default 2"}));
  EXPECT_TRUE(throwsError([&] { add({.name = "file", .value = UriValue::Text, .fallback = 1}); }, Errc::InvalidArgument,
                          {"'file'"}));
  EXPECT_EQ(backendRegistry<Camera>().keys("test-keys").size(), 0u);  // none of them was added
}

TEST(CameraRegistry, OtherLibrariesRegisterTheirSchemes) {
  registerDriverBackends();
  static DeviceUri seen;  // (static: the process-wide registry keeps the factory)
  backendRegistry<Camera>().add({.scheme = "test-registry",
                                 .keys = {{.name = "seed", .value = UriValue::Integer, .lo = 0, .hi = 9}},
                                 .description = "test-registry:<anything>",
                                 .factory = [](const DeviceUri& uri) -> std::unique_ptr<Camera> {
                                   seen = uri;
                                   return nullptr;
                                 }});
  const std::vector<std::string> schemes = backendRegistry<Camera>().schemes();
  EXPECT_NE(std::find(schemes.begin(), schemes.end(), "test-registry"), schemes.end());
  EXPECT_NE(std::find(schemes.begin(), schemes.end(), "aravis"), schemes.end());
  EXPECT_EQ(openCamera("test-registry:bench.toml?seed=7"), nullptr);
  EXPECT_EQ(seen.path, "bench.toml");
  EXPECT_EQ(seen.query.at("seed"), "7");
  EXPECT_TRUE(throwsError([] { openCamera("test-registry:b?noise=0"); }, Errc::Config, {"'noise'", "seed"}));
  EXPECT_TRUE(throwsError([] { openCamera("test-registry:b?seed=10"); }, Errc::Config, {"seed = '10'", "0 .. 9"}));
  EXPECT_TRUE(throwsError(
      [] {
        backendRegistry<Camera>().add(
            {.scheme = "test-registry", .factory = [](const DeviceUri&) { return std::unique_ptr<Camera>(); }});
      },
      Errc::InvalidArgument, {"already registered"}));
  EXPECT_TRUE(throwsError(
      [] {
        backendRegistry<Camera>().add(
            {.scheme = "Bad Scheme", .factory = [](const DeviceUri&) { return std::unique_ptr<Camera>(); }});
      },
      Errc::InvalidArgument, {"'Bad Scheme'"}));
  // Registering unless the scheme is taken: the first backend stays, and a bad one is still refused.
  static int opened = 0;
  auto counting = [](int by) {
    return [by](const DeviceUri&) {
      opened += by;
      return std::unique_ptr<Camera>();
    };
  };
  EXPECT_TRUE(backendRegistry<Camera>().addOnce({.scheme = "test-if-absent", .factory = counting(1)}));
  EXPECT_FALSE(backendRegistry<Camera>().addOnce({.scheme = "test-if-absent", .factory = counting(10)}));
  EXPECT_FALSE(backendRegistry<Camera>().addOnce({.scheme = "test-registry", .factory = counting(100)}));
  openCamera("test-if-absent:x");
  openCamera("test-registry:x");
  EXPECT_EQ(opened, 1);
  EXPECT_TRUE(throwsError([&] { backendRegistry<Camera>().addOnce({.scheme = "test-no-factory"}); },
                          Errc::InvalidArgument, {"no factory"}));
}

TEST(CameraState, WrongStateErrorNamesMethodStateAndAllowedStates) {
  EXPECT_NO_THROW(
      requireCameraState(Camera::State::Open, {Camera::State::Open, Camera::State::Configured}, "info", "cam"));
  EXPECT_TRUE(
      throwsError([] { requireCameraState(Camera::State::Configured, {Camera::State::Streaming}, "grab", "cam-7"); },
                  Errc::InvalidArgument, {"cam-7", "grab()", "state Configured", "Streaming"}));
}

}  // namespace
}  // namespace lfi
