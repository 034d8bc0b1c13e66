// SPDX-License-Identifier: Apache-2.0
// The camera URI grammar and the backend registry (no device needed).

#include "lfi/drivers/camera_registry.h"
#include "lfi_test_support.h"

#include <gtest/gtest.h>

namespace lfi {
namespace {

using testing_support::throwsError;

TEST(DeviceUri, SplitsSchemePathAndQuery) {
  const DeviceUri uri = backendRegistry<Camera>().parse("aravis:192.168.1.20?packetSize=1400&x=y");
  EXPECT_EQ(uri.scheme, "aravis");
  EXPECT_EQ(uri.path, "192.168.1.20");
  ASSERT_EQ(uri.query.size(), 2u);
  EXPECT_EQ(uri.query.at("packetSize"), "1400");
  EXPECT_EQ(uri.query.at("x"), "y");
  EXPECT_EQ(uri.text, "aravis:192.168.1.20?packetSize=1400&x=y");
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
  EXPECT_TRUE(throwsError([] { backendRegistry<Camera>().parse("aravis:x?packetSize"); }, Errc::Config,
                          {"'packetSize'", "<key>=<value>"}));
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
                          {"unknown key 'packetsize'", "packetSize"}));
  EXPECT_TRUE(throwsError([] { openCamera("aravis:x?packetSize=big"); }, Errc::Config, {"packetSize 'big'"}));
  EXPECT_TRUE(throwsError([] { openCamera("aravis:x?packetSize=100"); }, Errc::Config, {"outside"}));
}

TEST(CameraRegistry, OtherLibrariesRegisterTheirSchemes) {
  registerDriverBackends();
  static DeviceUri seen;  // (static: the process-wide registry keeps the factory)
  backendRegistry<Camera>().add({.scheme = "test-registry",
                                 .queryKeys = {"seed"},
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
