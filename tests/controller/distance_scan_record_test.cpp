// SPDX-License-Identifier: Apache-2.0
// The distance scan's record (distance_scan.h): every field from what it was
// given, in the documented names and units, valid JSON whatever the devices call themselves.

#include "lfi/controller/distance_scan.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace lfi {
namespace {

DistanceScanSource source() {
  DistanceScanSource s;
  s.benchFile = "/benches/b.toml";
  s.capture = "sim:/scenes/s.toml (16x16 elements)";
  s.referenceFile = "/out/scan.lightfield.exr";
  s.referenceDistance_mm = 30;
  s.cameraUri = {.scheme = "aravis", .path = "Vendor-Model-7"};
  s.displayUri = {.scheme = "usb", .path = "1209:4c46/LFI-0001", .query = {{"timeout_ms", "500"}}};
  s.camera = {.vendor = "Vendor", .model = "Model", .serial = "7"};
  s.cameraSettings.exposure_us = 2000;
  s.cameraSettings.pixelFormat = PixelFormat::Mono12;
  s.frames = 4;
  s.settle_ms = 20;
  return s;
}

DistanceScanRun run() {
  DistanceScanRun r;
  r.white = 0.75;
  r.scan.candidates_mm = {-1, 0, 1};
  r.scan.brightness = {10, 30, 12};
  r.scan.dark = 2;
  r.scan.noise = 0.5;
  r.scan.darkNoise = 0.25;
  r.scan.level = 20;
  r.scan.estimate_mm = 0.125;
  r.scan.width_mm = 1.5;
  return r;
}

TEST(DistanceScanRecord, HoldsWhatItWasGivenUnderItsDocumentedNames) {
  DistanceScanSource s = source();
  s.roi_px = {1, 2, 3, 4};
  const auto r = nlohmann::json::parse(distanceScanRecord(s, run()));
  EXPECT_EQ(r["format"], "lfi-display-distance-scan");
  EXPECT_EQ(r["version"], 1);
  EXPECT_EQ(r["bench"], "/benches/b.toml");
  EXPECT_EQ(r["reference"]["source"], s.capture);
  EXPECT_EQ(r["reference"]["file"], "/out/scan.lightfield.exr");
  EXPECT_EQ(r["reference"]["distance_mm"], 30);
  EXPECT_EQ(r["camera"]["uri"], "aravis:Vendor-Model-7");
  EXPECT_EQ(r["camera"]["serial"], "7");
  EXPECT_EQ(r["camera"]["exposure_us"], 2000);
  EXPECT_EQ(r["camera"]["pixel_format"], "Mono12");
  EXPECT_EQ(r["camera"]["frames"], 4);
  EXPECT_EQ(r["camera"]["settle_ms"], 20);
  EXPECT_EQ(r["display"]["uri"], "usb:1209:4c46/LFI-0001?timeout_ms=500");
  EXPECT_EQ(r["display"]["white"], 0.75);
  EXPECT_EQ(r["roi_px"], nlohmann::json::array({1, 2, 3, 4}));
  EXPECT_EQ(r["candidates_mm"], nlohmann::json::array({-1, 0, 1}));
  EXPECT_EQ(r["brightness"], nlohmann::json::array({10, 30, 12}));
  EXPECT_EQ(r["dark"], 2);
  EXPECT_EQ(r["noise"], 0.5);
  EXPECT_EQ(r["dark_noise"], 0.25);
  EXPECT_EQ(r["level"], 20);
  EXPECT_EQ(r["estimate_mm"], 0.125);
  EXPECT_EQ(r["peak_width_mm"], 1.5);
}

TEST(DistanceScanRecord, AWholeImageAndNamesThatAreNotUtf8StillMakeJson) {
  DistanceScanSource s = source();
  s.camera.model = "Model \xff\xfe";
  const auto r = nlohmann::json::parse(distanceScanRecord(s, run()));
  EXPECT_TRUE(r["roi_px"].is_null());
  EXPECT_EQ(r["camera"]["model"].get<std::string>().rfind("Model ", 0), 0u);
}

}  // namespace
}  // namespace lfi
