// SPDX-License-Identifier: Apache-2.0
#pragma once
// The fixture of the Aravis backend's tests (aravis_*_test.cpp): Aravis's own
// simulated GigE Vision camera (arv-fake-gv-camera-0.8, Debian package
// aravis-tools) on loopback: the real driver code path, GVCP control and GVSP
// streaming over UDP.
//
// Every GigE Vision device listens on UDP port 3956, so two fake cameras on
// 127.0.0.1 would answer each other's requests: the fixture holds an exclusive
// lock file while its camera runs, which serialises these tests across the
// processes `ctest -j` starts. Each camera gets a serial unique to the process.

#include "lfi/drivers/aravis/aravis_camera.h"
#include "lfi/drivers/builtin_backends.h"
#include "lfi/drivers/camera_registry.h"

#include "gige_device_process.h"
#include "host_drops.h"
#include "lfi_test_support.h"
#include "stream_tally.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

namespace lfi {

using namespace std::chrono_literals;
using testing_support::throwsError;
using Clock = std::chrono::steady_clock;
using lfi::testing_support::gigeDeviceAnswers;
using lfi::testing_support::GigeDeviceProcess;
using lfi::testing_support::gigeWriteRegister;
using lfi::testing_support::kHeartbeatTimeoutRegister;
using lfi::testing_support::LoopbackGigeLock;

inline constexpr const char* kFakeCameraBinary = "arv-fake-gv-camera-0.8";

inline std::string findInPath(const std::string& name) {
  const char* path = std::getenv("PATH");
  std::string dirs = path != nullptr ? path : "/usr/bin:/bin";
  std::size_t start = 0;
  while (start <= dirs.size()) {
    const std::size_t end = dirs.find(':', start);
    const std::filesystem::path candidate =
        std::filesystem::path(dirs.substr(start, end == std::string::npos ? std::string::npos : end - start)) / name;
    if (::access(candidate.c_str(), X_OK) == 0) return candidate.string();
    if (end == std::string::npos) break;
    start = end + 1;
  }
  return {};
}

inline double secondsSince(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// The frame Aravis's fake camera sends as block id `frameId` in Mono8 at gain 0 and an exposure of 10 ms (its
// diagonal ramp, arv_fake_camera_diagonal_ramp in Aravis 0.8, at a scale of 1 + gain + log10(exposure / 10 ms) = 1):
// pixel (x, y) of the region is (x + y + id) mod 255.
inline cv::Mat fakeCameraFrame(std::uint64_t frameId, int width, int height) {
  std::vector<std::uint8_t> ramp(static_cast<std::size_t>(width) + 255);  // k mod 255: row y starts at (y + id) mod 255
  for (std::size_t k = 0; k < ramp.size(); ++k) ramp[k] = static_cast<std::uint8_t>(k % 255);
  cv::Mat image(height, width, CV_8UC1);
  for (int y = 0; y < height; ++y)
    std::memcpy(image.ptr(y), ramp.data() + (static_cast<std::uint64_t>(y) + frameId) % 255,
                static_cast<std::size_t>(width));
  return image;
}

// One arv-fake-gv-camera-0.8 process serving on 127.0.0.1.
class FakeGvCamera {
 public:
  explicit FakeGvCamera(std::string serial) : serial_(std::move(serial)) {}

  std::string id() const { return "Aravis-Fake-" + serial_; }
  const std::string& serial() const { return serial_; }

  // Starts the process and waits (up to 5 s) until it answers GVCP.
  // genicam: a GenICam description to serve instead of the built-in one (it
  // must address the fake device's registers).
  void start(const std::string& binary, int lostPacketsPerThousand = 0, const std::string& genicam = {},
             const std::string& address = "127.0.0.1") {
    std::vector<std::string> args = {binary, "-i", address, "-s", serial_};
    if (lostPacketsPerThousand > 0) {
      args.push_back("-r");
      args.push_back(std::to_string(lostPacketsPerThousand));
    }
    if (!genicam.empty()) {
      args.push_back("-g");
      args.push_back(genicam);
    }
    process_ = std::make_unique<GigeDeviceProcess>(args, 5s, /*quietStderr=*/true, address);
    address_ = address;
    // The fake device drops a controller that has not sent a heartbeat for 3 s (its default), as a real one does;
    // a client process stalled that long on a loaded CI host would lose its stream. 10 s, as `lfi serve-camera`.
    setHeartbeatTimeout(10s);
  }

  // Sets the device's heartbeat timeout (GigE Vision bootstrap register 0x0938); no controller may hold it.
  void setHeartbeatTimeout(std::chrono::milliseconds timeout) {
    if (!trySetHeartbeatTimeout(timeout))
      throw std::runtime_error("the fake device at " + address_ + " did not take its heartbeat timeout");
  }
  // The same; false while a controller holds the device.
  bool trySetHeartbeatTimeout(std::chrono::milliseconds timeout) {
    return gigeWriteRegister(kHeartbeatTimeoutRegister, static_cast<std::uint32_t>(timeout.count()), address_);
  }

  static bool answersGvcp() { return gigeDeviceAnswers(); }

  // SIGKILL: the device vanishes without a word, like a pulled cable.
  void kill() { process_.reset(); }

  // SIGSTOP: the device stalls; SIGCONT: it comes back.
  void pause() { ::kill(process_->pid(), SIGSTOP); }
  void resume() { ::kill(process_->pid(), SIGCONT); }

 private:
  std::string serial_;
  std::string address_;
  std::unique_ptr<GigeDeviceProcess> process_;
};

class AravisCameraTest : public ::testing::Test {
 protected:
  void SetUp() override {
    binary_ = findInPath(kFakeCameraBinary);
    if (binary_.empty())
      LFI_SKIP_WITHOUT_TOOL(kFakeCameraBinary << " not found in PATH: install Debian's aravis-tools "
                                              << "(scripts/install-deps.sh) to run the GigE Vision loopback tests");
    lock_ = std::make_unique<LoopbackGigeLock>();
    registerDriverBackends();
    fake_ = std::make_unique<FakeGvCamera>("LFI" + std::to_string(::getpid()));
    fake_->start(binary_);
  }

  void TearDown() override {
    fake_.reset();
    lock_.reset();
  }

  std::unique_ptr<Camera> openFake() { return openCamera("aravis:" + fake_->id()); }

  // Replaces the fake device by one serving the GenICam description `xml`
  // (serial `prefix` + pid), and opens it.
  std::unique_ptr<Camera> openFakeWith(const std::string& prefix, const std::filesystem::path& xml) {
    fake_.reset();
    fake_ = std::make_unique<FakeGvCamera>(prefix + std::to_string(::getpid()));
    fake_->start(binary_, 0, xml.string());
    return openFake();
  }

  // A small free-running Mono8 set-up that streams fast on loopback.
  static CameraSettings smallSettings() {
    CameraSettings s;
    s.exposure_us = 1000;
    s.roiWidth_px = 256;
    s.roiHeight_px = 256;
    s.frameRate_hz = 200;
    return s;
  }

  // smallSettings() at the exposure whose frames are fakeCameraFrame().
  static CameraSettings rampSettings() {
    CameraSettings s = smallSettings();
    s.exposure_us = 10000;
    return s;
  }

  // The next complete frame of a free-running stream. A loaded host may make the ones before it come incomplete
  // (tests/support/stream_tally.h); each must then be accounted for: by an underrun, a drop the host's kernel
  // counted or a device pause.
  Frame grabComplete(Camera& camera) {
    testing_support::StreamLedger ledger(camera, 0, hostDrops_);
    Frame frame;
    do frame = camera.grab(2s);
    while (frame.status == FrameStatus::Incomplete && ledger.add(frame) && ledger.wantsMore(1));
    if (frame.status == FrameStatus::Complete) ledger.add(frame);  // (the incomplete ones accounted for at it)
    return frame;
  }

  std::string binary_;
  std::unique_ptr<LoopbackGigeLock> lock_;
  std::unique_ptr<FakeGvCamera> fake_;
  testing_support::HostDrops hostDrops_;  // since before any stream of the test
};

}  // namespace lfi
