// SPDX-License-Identifier: Apache-2.0
// `lfi run` when the camera drops out mid-run, through the real Aravis backend
// against `lfi serve-camera` (the ray-traced camera as a GigE Vision device on
// loopback), killed and started again while the run goes on: the part in hand
// gets an error record, nothing written before is lost, and the run either
// stops with a clear error or, as the bench file asks, waits for the camera
// and goes on.

#include "gige_device_process.h"
#include "lfi_process.h"
#include "lfi_test_support.h"
#include "scene_text.h"
#include "test_folder.h"
#include "text_edit.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <unistd.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <thread>
#include <vector>

namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using lfi::testing_support::GigeDeviceProcess;
using lfi::testing_support::LoopbackGigeLock;
using lfi::testing_support::runLfi;
using lfi::testing_support::shellQuoted;

// The served camera's scene: a lens over a Lambertian back light, 48 x 48 pixels of 0.625 mm
// (magnification 1), 4095 DN over a 10 000 e- well, 3 e- read noise; served as Mono16 (x 16).
const std::string kScene =
    lfi::testing_support::cameraSceneText({.samplesPerPixel = 2,
                                           .seed = 7,
                                           .pixelPitch_mm = 0.625,
                                           .width_px = 48,
                                           .height_px = 48,
                                           .fullWell_e = 10000,
                                           .readNoise_e = 3,
                                           .bitDepth = 12,
                                           .electronsPerUnitPerUs = 1.0}) +
    lfi::testing_support::lensObject({.radius_mm = 100, .centreThickness_mm = 7, .diameter_mm = 40, .ior = 1.5}) +
    lfi::testing_support::kBackLightObject;

std::vector<nlohmann::json> readRecords(const fs::path& file) {
  std::vector<nlohmann::json> records;
  std::ifstream in(file);
  for (std::string line; std::getline(in, line);) {
    auto j = nlohmann::json::parse(line, nullptr, false);
    EXPECT_FALSE(j.is_discarded()) << "a torn record: " << line;
    if (!j.is_discarded()) records.push_back(j);
  }
  return records;
}

class RunFaults : public testing::Test {
 protected:
  void SetUp() override {
    if (::access(LFI_EXECUTABLE, X_OK) != 0) LFI_SKIP_WITHOUT_TOOL(LFI_EXECUTABLE << " is not built");
    scene_ = folder_.write("served.toml", kScene);
    lock_ = std::make_unique<LoopbackGigeLock>();
    startCamera();
  }
  void TearDown() override {
    camera_.reset();
    lock_.reset();
  }

  void startCamera() {
    camera_ = std::make_unique<GigeDeviceProcess>(
        std::vector<std::string>{LFI_EXECUTABLE, "-q", "serve-camera", scene_.string(), "--interface", "127.0.0.1",
                                 "--serial", serial_},
        20s, /*quietStderr=*/false);
  }

  // A bench with the served camera, and the simulated display and capture of the inspection bench's scene.
  fs::path bench(const std::string& onDeviceLoss) {
    const fs::path scenes = fs::path(LFI_SOURCE_DIR) / "data" / "scenes";
    return folder_.write("bench-" + onDeviceLoss + ".toml", fmt::format(R"(format = "lfi-inspection-bench"
version = 1
[camera]
uri = "aravis:lfi-SimCamera-{0}"
exposure_us = 4000
pixel_format = "Mono16"
object_pixel_mm = 0.625
dn_per_electron = 6.6
read_noise_dn = 20
grab_timeout_ms = 1000
retries = 0
[display]
uri = "sim:{1}/inspection_bench.toml"
[capture]
uri = "sim:{1}/inspection_bench.toml?spatial=16&angular=8&spp=8"
[geometry]
distance_mm = 30
[reference]
folder = "reference"
frames = 4
[inspection]
relative = 6
[output]
folder = "out"
save_images = "none"
[run]
on_device_loss = "{2}"
wait_limit_s = 60
)",
                                                                        serial_, scenes.string(), onDeviceLoss));
  }

  // Waits (up to a minute) until the run's records file has `count` lines; with `status`, until its last line
  // is a record of that status.
  static bool waitForRecords(const fs::path& file, size_t count, const std::string& status = {}) {
    const auto deadline = std::chrono::steady_clock::now() + 60s;
    while (std::chrono::steady_clock::now() < deadline) {
      std::ifstream in(file);
      size_t lines = 0;
      std::string line, last;
      for (; std::getline(in, line); ++lines) last = line;
      if (lines >= count &&
          (status.empty() || nlohmann::json::parse(last, nullptr, false).value("status", "") == status))
        return true;
      std::this_thread::sleep_for(20ms);
    }
    return false;
  }

  lfi::testing_support::TestFolder folder_{"lfi-run-faults"};
  std::string serial_ = "LFIR" + std::to_string(::getpid() % 100000);
  fs::path scene_;
  std::unique_ptr<LoopbackGigeLock> lock_;
  std::unique_ptr<GigeDeviceProcess> camera_;
};

TEST_F(RunFaults, ACameraGoneMidRunStopsItWithEveryRecordBeforeKept) {
  const fs::path file = bench("stop");
  const auto capture = runLfi("-q capture " + shellQuoted(file.string()));
  ASSERT_EQ(capture.status, 0) << capture.output;
  const fs::path run = folder_ / "run";
  lfi::testing_support::LfiResult result;
  std::thread runner(
      [&] { result = runLfi("-q run " + shellQuoted(file.string()) + " --out " + shellQuoted(run.string())); });
  const bool started = waitForRecords(run / "records.jsonl", 3);
  camera_->signal(SIGKILL);
  runner.join();
  ASSERT_TRUE(started) << result.output;
  EXPECT_EQ(result.status, 1) << result.output;
  EXPECT_NE(result.output.find("could not be inspected"), std::string::npos) << result.output;
  EXPECT_NE(result.output.find("records.jsonl"), std::string::npos) << result.output;
  const auto records = readRecords(run / "records.jsonl");
  ASSERT_GE(records.size(), 4u);
  for (size_t i = 0; i < records.size(); ++i) {
    EXPECT_EQ(records[i]["part"], i + 1);
    EXPECT_EQ(records[i]["status"], i + 1 < records.size() ? "inspected" : "error") << records[i].dump();
  }
  EXPECT_FALSE(records.back()["error"].get<std::string>().empty());
  EXPECT_TRUE(fs::exists(run / "summary.html"));
}

// The camera comes back once the run has recorded the part it lost, and the run is stopped (SIGINT) once it
// has inspected a part after that: what happens follows the records, whatever the host's speed.
TEST_F(RunFaults, ACameraBackWithinTheWaitLimitLetsTheRunGoOn) {
  const fs::path file = bench("wait");
  const auto capture = runLfi("-q capture " + shellQuoted(file.string()));
  ASSERT_EQ(capture.status, 0) << capture.output;
  const fs::path run = folder_ / "run", records = run / "records.jsonl", pid = folder_ / "run.pid";
  lfi::testing_support::LfiResult result;
  std::thread runner([&] {
    result = runLfi("-q run " + shellQuoted(file.string()) + " --out " + shellQuoted(run.string()), true,
                    "echo $$ > " + shellQuoted(pid.string()) + "; exec ");
  });
  const bool started = waitForRecords(records, 3);
  camera_->signal(SIGKILL);
  const size_t before = readRecords(records).size();
  const bool lost = waitForRecords(records, before, "error");
  startCamera();
  const bool back = lost && waitForRecords(records, readRecords(records).size() + 1, "inspected");
  ::kill(std::stoi(lfi::testing_support::readText(pid)), SIGINT);
  runner.join();
  ASSERT_TRUE(started) << result.output;
  ASSERT_TRUE(lost) << "no error record for the part in hand when the camera went\n" << result.output;
  ASSERT_TRUE(back) << "no part inspected after the camera came back\n" << result.output;
  EXPECT_EQ(result.status, 0) << result.output;
  const auto all = readRecords(records);
  size_t errors = 0;
  for (size_t i = 0; i < all.size(); ++i) {
    EXPECT_EQ(all[i]["part"], i + 1);
    errors += all[i]["status"] == "error";
  }
  EXPECT_GE(errors, 1u);
  EXPECT_EQ(all.back()["status"], "inspected");
}

}  // namespace
