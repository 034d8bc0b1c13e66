// SPDX-License-Identifier: Apache-2.0
// The Aravis backend against `lfi serve-camera` on loopback: the real driver
// code path (GVCP control, GVSP streaming over UDP) receiving ray-traced,
// sensor-modelled frames, compared pixel for pixel with what SimImager renders
// locally for the same frame id.
//
// Every GigE Vision device listens on UDP port 3956 of its address, so the
// fixture holds /tmp/lfi-fake-gv-camera.lock (shared with the aravis_*_test files)
// while its server runs.

#include "aravis_discovery.h"
#include "gige_device_process.h"
#include "host_drops.h"
#include "lfi/drivers/aravis/aravis_camera.h"
#include "lfi/drivers/builtin_backends.h"
#include "lfi/drivers/camera_registry.h"
#include "lfi/sim/devices/sim_camera.h"
#include "lfi_test_support.h"
#include "scene_text.h"
#include "stream_tally.h"
#include "test_folder.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <optional>
#include <string>
#include <thread>
#include <vector>

namespace lfi {
namespace {

using namespace std::chrono_literals;
using testing_support::throwsError;
using Clock = std::chrono::steady_clock;
using lfi::testing_support::cameraSceneText;
using lfi::testing_support::discoverDevice;
using lfi::testing_support::gigeDeviceAnswers;
using lfi::testing_support::GigeDeviceProcess;
using lfi::testing_support::HostDrops;
using lfi::testing_support::kBackLightObject;
using lfi::testing_support::lensObject;
using lfi::testing_support::LoopbackGigeLock;
using lfi::testing_support::StreamLedger;
using lfi::testing_support::TestFolder;
namespace fs = std::filesystem;

double secondsSince(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// A small bench: the reference lens over a Lambertian back light, 96 x 64 px.
const std::string kScene = cameraSceneText({.samplesPerPixel = 2,
                                            .seed = 7,
                                            .pixelPitch_mm = 0.625,
                                            .width_px = 96,
                                            .height_px = 64,
                                            .fullWell_e = 10000,
                                            .readNoise_e = 3,
                                            .bitDepth = 12,
                                            .electronsPerUnitPerUs = 1.0}) +
                           lensObject({.radius_mm = 100, .centreThickness_mm = 7, .diameter_mm = 40, .ior = 1.5}) +
                           kBackLightObject;

bool answersGvcp() {
  return gigeDeviceAnswers();
}

// `lfi serve-camera` as a child process.
class ServedCamera {
 public:
  ServedCamera(fs::path scene, std::string serial) : scene_(std::move(scene)), serial_(std::move(serial)) {}

  std::string id() const { return "lfi-SimCamera-" + serial_; }

  // Starts the server, dropping GVSP packets with probability `packetLoss`, and waits (up to 20 s: it renders
  // first) until it answers GVCP.
  void start(double packetLoss = 0) {
    process_.reset();
    process_ = std::make_unique<GigeDeviceProcess>(
        std::vector<std::string>{LFI_EXECUTABLE, "-q", "serve-camera", scene_.string(), "--interface", "127.0.0.1",
                                 "--serial", serial_, "--packet-loss", std::to_string(packetLoss)},
        20s, /*quietStderr=*/false);
  }

  // Sends `signal` and reaps the process; returns its wait status (-1 if not running).
  int kill(int signal) { return process_ ? process_->signal(signal) : -1; }

 private:
  fs::path scene_;
  std::string serial_;
  std::unique_ptr<GigeDeviceProcess> process_;
};

class ServedCameraTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (::access(LFI_EXECUTABLE, X_OK) != 0) LFI_SKIP_WITHOUT_TOOL(LFI_EXECUTABLE << " is not built");
    scene_ = dir_.write("served.toml", kScene);
    lock_ = std::make_unique<LoopbackGigeLock>();
    registerDriverBackends();
    server_ = std::make_unique<ServedCamera>(scene_, "LFIS" + std::to_string(::getpid() % 100000));
    server_->start();
  }

  void TearDown() override {
    server_.reset();
    lock_.reset();
  }

  std::unique_ptr<Camera> openServed() { return openCamera("aravis:" + server_->id()); }

  static CameraSettings streamSettings(PixelFormat format) {
    CameraSettings s;
    s.exposure_us = 4000;
    s.gain = 3;  // GainRaw on the served device: dB for the simulated sensor
    s.pixelFormat = format;
    s.roiX_px = 8;
    s.roiY_px = 4;
    s.roiWidth_px = 72;
    s.roiHeight_px = 48;
    s.frameRate_hz = 100;
    return s;
  }

  // Streams `count` frames and compares each with SimImager's frame of the same id.
  void expectFramesEqualLocalRender(PixelFormat format, int count) {
    auto camera = openServed();
    const CameraSettings settings = streamSettings(format);
    camera->configure(settings);
    sim::SimImager local(scene_);
    const CameraSettings resolved = local.resolve(settings, "local");
    camera->start(8);
    // Grab first, compare afterwards: the local render of each frame is slow
    // (much slower under the sanitizers) and must not starve the buffer pool.
    // Every frame lost on the way is accounted for (stream_tally.h).
    StreamLedger ledger(*camera, 8, hostDrops_);
    std::vector<Frame> frames;
    const auto keep = [&](const Frame& f) {
      if (f.status == FrameStatus::Complete) frames.push_back(f);
    };
    while (ledger.wantsMore(count)) {
      Frame grabbed;
      camera->grabInto(grabbed, 2s);
      ASSERT_TRUE(ledger.add(grabbed));
      keep(grabbed);
    }
    ledger.close(keep);  // (its frames are compared too)
    ASSERT_GE(frames.size(), static_cast<size_t>(count));
    cv::Mat expected;
    for (const Frame& f : frames) {
      local.capture(resolved, f.frameId, expected);
      ASSERT_EQ(f.image.type(), expected.type());
      ASSERT_EQ(f.image.size(), expected.size());
      EXPECT_EQ(cv::norm(f.image, expected, cv::NORM_INF), 0) << "frame id " << f.frameId;
    }
    const Frame& frame = frames.back();
    // Frames differ (new noise each), and are not black.
    EXPECT_GT(cv::norm(frames.front().image, frame.image, cv::NORM_INF), 0);
    EXPECT_GT(cv::mean(frame.image)[0], 1.0);
  }

  TestFolder dir_{"lfi-served-camera"};
  HostDrops hostDrops_;  // since before any stream of the test
  fs::path scene_;
  std::unique_ptr<LoopbackGigeLock> lock_;
  std::unique_ptr<ServedCamera> server_;
};

TEST_F(ServedCameraTest, DiscoveryFindsTheServedCamera) {
  int rounds = 0;
  const std::optional<AravisDeviceInfo> d = discoverDevice(server_->id(), 3, rounds);
  ASSERT_TRUE(d) << server_->id() << " not discovered in " << rounds << " rounds";
  EXPECT_EQ(d->vendor, "lfi");
  EXPECT_EQ(d->model, "SimCamera");
  EXPECT_EQ(d->address, "127.0.0.1");
  EXPECT_EQ(d->protocol, "GigEVision");
  if (rounds > 1) std::printf("[ info     ] discovered in round %d\n", rounds);
  auto camera = openServed();
  const CameraInfo info = camera->info();
  EXPECT_EQ(info.vendor, "lfi");
  EXPECT_EQ(info.model, "SimCamera");
  EXPECT_EQ(info.sensorWidth_px, 96);
  EXPECT_EQ(info.sensorHeight_px, 64);
}

TEST_F(ServedCameraTest, Mono8FramesEqualTheLocalRender) {
  expectFramesEqualLocalRender(PixelFormat::Mono8, 20);
}

TEST_F(ServedCameraTest, Mono16FramesEqualTheLocalRender) {
  expectFramesEqualLocalRender(PixelFormat::Mono16, 20);
}

TEST_F(ServedCameraTest, BinnedFramesEqualTheLocalRender) {
  auto camera = openServed();
  CameraSettings s = streamSettings(PixelFormat::Mono16);
  s.binning = 2;
  s.roiX_px = 0;
  s.roiY_px = 0;
  // "To the end": the binned sensor, 48 x 32, although the served device's Width and Height bounds do not shrink
  // with binning (asking for them gave black frames marked complete).
  s.roiWidth_px = 0;
  s.roiHeight_px = 0;
  camera->configure(s);
  EXPECT_EQ(camera->settings().roiWidth_px, 48);
  EXPECT_EQ(camera->settings().roiHeight_px, 32);
  sim::SimImager local(scene_);
  const CameraSettings resolved = local.resolve(s, "local");
  camera->start(4);
  cv::Mat expected;
  for (int i = 0; i < 3; ++i) {
    // Every binning's radiance is rendered before the device appears: a frame takes milliseconds. The stream
    // statistics say what happened should this ever time out again (it did twice, when the device's 3 s heartbeat
    // timeout expired on a stalled host and the stream stopped; the served device now allows 10 s).
    const Frame frame = camera->grab(5s);
    const StreamStatistics st = camera->statistics();  // what the stream saw, should this ever time out again
    ASSERT_EQ(frame.status, FrameStatus::Complete)
        << "frame " << i << ": " << toString(frame.status) << "; stream: " << st.completed << " completed, "
        << st.failed << " failed, " << st.underruns << " underruns, " << st.missingPackets << " packets missing";
    local.capture(resolved, frame.frameId, expected);
    EXPECT_EQ(cv::norm(frame.image, expected, cv::NORM_INF), 0) << "frame id " << frame.frameId;
  }
}

// GigE Vision block ids are 16 bits (Aravis's fake camera starts near 65000; 65535 is followed by 1): the
// frames stay equal to the local render across the wrap.
TEST_F(ServedCameraTest, FramesStayEqualAcrossTheBlockIdWrap) {
  auto camera = openServed();
  CameraSettings s = streamSettings(PixelFormat::Mono16);
  s.roiWidth_px = 16;
  s.roiHeight_px = 16;
  s.frameRate_hz = 1000;
  camera->configure(s);
  sim::SimImager local(scene_);
  const CameraSettings resolved = local.resolve(s, "local");
  camera->start(64);
  StreamLedger ledger(*camera, 64, hostDrops_);
  Frame frame;
  cv::Mat expected;
  const auto expectRendered = [&](const Frame& f) {
    if (f.status != FrameStatus::Complete) return;
    local.capture(resolved, f.frameId, expected);
    ASSERT_EQ(cv::norm(f.image, expected, cv::NORM_INF), 0) << "frame id " << f.frameId;
  };
  std::optional<std::uint64_t> previous;  // the last complete frame's id
  int afterWrap = 0;
  for (int i = 0; i < 3000 && afterWrap < 20; ++i) {
    camera->grabInto(frame, 2s);
    ASSERT_TRUE(ledger.add(frame));
    if (frame.status != FrameStatus::Complete) continue;
    // 16-bit block ids: 65535 is followed by 1 (0 is never used).
    if (afterWrap > 0 || (previous && frame.frameId < *previous)) ++afterWrap;
    previous = frame.frameId;
    expectRendered(frame);
  }
  EXPECT_EQ(afterWrap, 20) << "the block id did not wrap within 3000 frames";
  ledger.close(expectRendered);
}

TEST_F(ServedCameraTest, SoftwareTriggerDeliversOneFramePerTrigger) {
  auto camera = openServed();
  CameraSettings s = streamSettings(PixelFormat::Mono8);
  s.trigger = TriggerMode::Software;
  camera->configure(s);
  sim::SimImager local(scene_);
  const CameraSettings resolved = local.resolve(s, "local");
  camera->start(4);
  EXPECT_EQ(camera->grab(300ms).status, FrameStatus::Timeout) << "no trigger, no frame";
  std::uint64_t previous = 0;
  cv::Mat expected;
  for (int i = 0; i < 5; ++i) {
    camera->softwareTrigger();
    const Frame frame = camera->grab(2s);
    ASSERT_EQ(frame.status, FrameStatus::Complete) << "trigger " << i;
    if (i > 0) {
      EXPECT_EQ(frame.frameId, previous + 1);
    }
    previous = frame.frameId;
    local.capture(resolved, frame.frameId, expected);
    EXPECT_EQ(cv::norm(frame.image, expected, cv::NORM_INF), 0);
    EXPECT_EQ(camera->grab(150ms).status, FrameStatus::Timeout) << "exactly one frame per trigger";
  }
}

TEST_F(ServedCameraTest, ServerKilledMidStreamIsAClearErrorWithinTheTimeout) {
  auto camera = openServed();
  camera->configure(streamSettings(PixelFormat::Mono8));
  camera->start(4);
  for (int i = 0; i < 3; ++i) ASSERT_EQ(camera->grab(2s).status, FrameStatus::Complete);
  server_->kill(SIGKILL);
  const auto t0 = Clock::now();
  bool thrown = false;
  try {
    // Frames already in flight may still arrive; the first grab that times out finds the device gone and throws.
    for (int i = 0; i < 50; ++i)
      ASSERT_NE(camera->grab(200ms).status, FrameStatus::Timeout) << "grab " << i << " timed out without a word";
  } catch (const Error& e) {
    thrown = true;
    EXPECT_EQ(e.code(), Errc::Device);
    EXPECT_NE(std::string(e.what()).find(server_->id()), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("device lost"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(thrown);
  std::printf("[ info     ] server loss reported after %.3f s (one 200 ms grab timeout and the probe)\n",
              secondsSince(t0));
  EXPECT_EQ(camera->state(), Camera::State::Closed);
}

// The server killed 20 times mid-stream: each time a Device error naming it ("device lost") ends the grabs
// before any of them times out without a word, the camera is closed, and once a new server is up the same
// Camera object opens again and streams. (A hang would be the test's timeout.)
TEST_F(ServedCameraTest, AServerKilledTwentyTimesMidStreamIsTwentyClearErrorsAndReopens) {
  auto camera = openServed();
  double slowest_s = 0;
  int errors = 0;
  for (int kill = 0; kill < 20; ++kill) {
    SCOPED_TRACE(kill);
    if (kill > 0) {
      server_->start();
      camera->open();
    }
    camera->configure(streamSettings(PixelFormat::Mono8));
    camera->start(4);
    ASSERT_EQ(camera->grab(2s).status, FrameStatus::Complete);
    server_->kill(SIGKILL);
    const auto t0 = Clock::now();
    try {
      for (int i = 0; i < 50; ++i)
        ASSERT_NE(camera->grab(200ms).status, FrameStatus::Timeout) << "grab " << i << " timed out without a word";
    } catch (const Error& e) {
      ++errors;
      EXPECT_EQ(e.code(), Errc::Device);
      EXPECT_NE(std::string(e.what()).find(server_->id()), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("device lost"), std::string::npos) << e.what();
    }
    slowest_s = std::max(slowest_s, secondsSince(t0));
    EXPECT_EQ(camera->state(), Camera::State::Closed);
  }
  EXPECT_EQ(errors, 20);
  std::printf("[ info     ] 20 kills, 20 errors; the slowest reported %.3f s after the kill\n", slowest_s);
}

// GVSP packets lost at 1 % and at 5 %, 1000 frames each: every frame the backend delivers as complete is the
// frame the server rendered for its id, pixel for pixel; the others come marked incomplete. A frame is at least
// three packets (leader, payload, trailer), so at 1 % fewer than 0.99³ of the frames arrive whole, and 1000
// frames without an incomplete one would happen with odds under 10⁻¹³: the loss was applied. (Aravis's device
// does not answer resend requests: nothing lost is recovered; a physical camera resends.)
TEST_F(ServedCameraTest, LostPacketsNeverMakeAWrongFrame) {
  for (const double loss : {0.01, 0.05}) {
    SCOPED_TRACE(loss);
    server_->start(loss);
    auto camera = openServed();
    CameraSettings s = streamSettings(PixelFormat::Mono16);
    s.frameRate_hz = 500;
    camera->configure(s);
    sim::SimImager local(scene_);
    const CameraSettings resolved = local.resolve(s, "local");
    camera->start(64);
    std::vector<Frame> frames(1000);
    for (Frame& f : frames) camera->grabInto(f, 2s);
    const StreamStatistics st = camera->statistics();
    camera->stop();
    int complete = 0, incomplete = 0, timeouts = 0;
    cv::Mat expected;
    for (const Frame& f : frames) {
      if (f.status == FrameStatus::Timeout) {
        ++timeouts;
      } else if (f.status == FrameStatus::Incomplete) {
        ++incomplete;
      } else {
        ++complete;
        local.capture(resolved, f.frameId, expected);
        ASSERT_EQ(f.image.size(), expected.size());
        ASSERT_EQ(cv::norm(f.image, expected, cv::NORM_INF), 0)
            << "frame id " << f.frameId << " delivered complete is not the frame rendered";
      }
    }
    EXPECT_EQ(timeouts, 0);
    EXPECT_GT(incomplete, 0) << "no frame came incomplete: was the loss applied?";
    EXPECT_GT(complete, 0);
    std::printf(
        "[ info     ] loss %.0f %%: %d complete and identical, %d incomplete; packets resent %llu, missing "
        "%llu; %llu underruns\n",
        100 * loss, complete, incomplete, static_cast<unsigned long long>(st.resentPackets),
        static_cast<unsigned long long>(st.missingPackets), static_cast<unsigned long long>(st.underruns));
  }
}

TEST_F(ServedCameraTest, WrongIdIsNotFoundAndListsTheServedCamera) {
  EXPECT_TRUE(throwsError([] { openCamera("aravis:lfi-SimCamera-NOSUCH"); }, Errc::NotFound,
                          {"lfi-SimCamera-NOSUCH", "devices found", server_->id(), "127.0.0.1"}));
}

// `lfi devices` names the served camera by the URI that opens it.
TEST_F(ServedCameraTest, TheDevicesCommandListsTheServedCamera) {
  const std::string listed = "aravis:" + server_->id() + "  (lfi SimCamera";
  std::string out;
  for (int round = 1; round <= 3 && out.find(listed) == std::string::npos; ++round) {  // (as DiscoveryFinds...)
    FILE* pipe = ::popen((std::string(LFI_EXECUTABLE) + " -q devices").c_str(), "r");
    ASSERT_NE(pipe, nullptr);
    out.clear();
    char buffer[4096];
    for (std::size_t n; (n = std::fread(buffer, 1, sizeof buffer, pipe)) > 0;) out.append(buffer, n);
    const int status = ::pclose(pipe);
    // 0, or 1 on a host whose USB cannot be listed (said so), after the cameras.
    const int expected = out.find("USB displays: cannot be listed") == std::string::npos ? 0 : 1;
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == expected) << out;
  }
  EXPECT_NE(out.find("USB displays:"), std::string::npos) << out;
  EXPECT_NE(out.find(listed), std::string::npos) << out;
  EXPECT_NE(out.find("GigEVision at 127.0.0.1"), std::string::npos) << out;
  auto camera = openCamera("aravis:" + server_->id());  // the listed URI opens it
  EXPECT_EQ(camera->info().deviceId, server_->id());
}

TEST_F(ServedCameraTest, SigtermStopsTheServerCleanly) {
  {
    auto camera = openServed();
    camera->configure(streamSettings(PixelFormat::Mono8));
    camera->start(4);
    ASSERT_EQ(camera->grab(2s).status, FrameStatus::Complete);
    camera->stop();
  }
  const auto t0 = Clock::now();
  const int status = server_->kill(SIGTERM);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "wait status " << status;
  std::printf("[ info     ] the server exited %.3f s after SIGTERM\n", secondsSince(t0));
  EXPECT_FALSE(answersGvcp());
}

}  // namespace
}  // namespace lfi
