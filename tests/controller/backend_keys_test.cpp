// SPDX-License-Identifier: Apache-2.0
// Every backend's declared query keys, through its registry: a URI of every
// scheme round-trips as a value, and every key refuses a value outside its
// range, a value of the wrong kind and the same quantity in another unit,
// naming the URI, the key and what is accepted, before any device is looked for.

#include "lfi/controller/coded_capture.h"
#include "lfi/drivers/builtin_backends.h"
#include "lfi/drivers/camera_registry.h"
#include "lfi/drivers/capture_registry.h"
#include "lfi/drivers/display_registry.h"
#include "lfi/sim/devices/sim_camera.h"
#include "lfi_test_support.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>

namespace lfi {
namespace {

using testing_support::throwsError;

void registerAll() {
  registerDriverBackends();
  sim::registerSimBackends();
  registerControllerBackends();
}

// A path no device answers to: a refusal can only come from the query.
constexpr const char* kNowhere = "/nonexistent/lfi-backend-keys";

// One value's text, as a user would write it.
std::string numberText(double v) {
  return fmt::format("{:.17g}", v);
}

template <typename Device>
void checkEveryKey(const char* kind) {
  SCOPED_TRACE(kind);
  BackendRegistry<Device>& registry = backendRegistry<Device>();
  for (const std::string& scheme : registry.schemes()) {
    SCOPED_TRACE(scheme);
    const std::vector<UriKey> keys = registry.keys(scheme);
    // Round trip: every key at its lowest value (or a text with delimiters in it), an awkward path.
    DeviceUri uri{.scheme = scheme, .path = std::string(kNowhere) + "/a?b&c d%.toml"};
    for (const UriKey& key : keys)
      uri.query[key.name] = key.value == UriValue::Text ? "x&y=z %.toml" : numberText(key.lo);
    EXPECT_EQ(registry.parse(uri.text()), uri) << uri.text();
    EXPECT_NO_THROW(checkUriQuery(uri, keys, kind)) << uri.text();

    for (const UriKey& key : keys) {
      SCOPED_TRACE(key.name);
      EXPECT_FALSE(key.name.empty());
      if (!key.unit.empty()) {
        EXPECT_TRUE(key.name.ends_with("_" + key.unit));
      }
      const auto refused = [&](const std::string& value, std::initializer_list<std::string> parts) {
        const DeviceUri bad{.scheme = scheme, .path = kNowhere, .query = {{key.name, value}}};
        std::vector<std::string> expected{bad.text()};
        expected.insert(expected.end(), parts.begin(), parts.end());
        return throwsError([&] { registry.open(bad); }, Errc::Config, expected);
      };
      if (key.value == UriValue::Text) {
        EXPECT_TRUE(refused("", {key.name, "empty"}));
        continue;
      }
      EXPECT_FALSE(key.fallback && !(*key.fallback >= key.lo && *key.fallback <= key.hi));
      const std::string range = fmt::format("{} .. {}", key.lo, key.hi);
      // Just outside the range: one for an integer, a relative step for a number.
      const double step = key.value == UriValue::Integer ? 1 : std::max(1e-9, 1e-6 * (std::abs(key.hi) + 1));
      const double below =
          key.value == UriValue::Integer ? key.lo - 1 : key.lo - std::max(step, std::abs(key.lo) * 1e-6);
      const double above =
          key.value == UriValue::Integer ? key.hi + 1 : key.hi + std::max(step, std::abs(key.hi) * 1e-6);
      EXPECT_TRUE(refused(numberText(below), {key.name, range}));
      EXPECT_TRUE(refused(numberText(above), {key.name, range}));
      EXPECT_TRUE(refused("x", {key.name, range}));
      if (key.value == UriValue::Integer && key.hi > key.lo) {
        EXPECT_TRUE(refused(numberText(key.lo + 0.5), {"integer"}));
      }
      // The quantity in another unit: named as the wrong unit, with the key it should be.
      if (!key.unit.empty()) {
        const std::string stem = key.name.substr(0, key.name.size() - key.unit.size() - 1);
        const DeviceUri other{.scheme = scheme, .path = kNowhere, .query = {{stem + "_furlongs", "1"}}};
        EXPECT_TRUE(throwsError([&] { registry.open(other); }, Errc::Config,
                                {other.text(), "not in the unit", key.name, key.unit}));
      }
    }
    const DeviceUri unknown{.scheme = scheme, .path = kNowhere, .query = {{"no_such_key", "1"}}};
    EXPECT_TRUE(throwsError([&] { registry.open(unknown); }, Errc::Config, {"unknown key 'no_such_key'"}));
  }
}

TEST(BackendKeys, EveryCameraKeyIsCheckedByItsRegistry) {
  registerAll();
  checkEveryKey<Camera>("camera");
}

TEST(BackendKeys, EveryDisplayKeyIsCheckedByItsRegistry) {
  registerAll();
  checkEveryKey<Display>("display");
}

TEST(BackendKeys, EveryCaptureKeyIsCheckedByItsRegistry) {
  registerAll();
  checkEveryKey<LightFieldCapture>("light field capture");
}

// Δ is the bench's alone: no capture backend takes it as a key.
TEST(BackendKeys, NoCaptureTakesTheDistance) {
  registerAll();
  for (const std::string& scheme : backendRegistry<LightFieldCapture>().schemes())
    for (const UriKey& key : backendRegistry<LightFieldCapture>().keys(scheme))
      EXPECT_NE(key.name, "distance_mm") << scheme;
}

}  // namespace
}  // namespace lfi
