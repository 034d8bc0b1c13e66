// SPDX-License-Identifier: Apache-2.0
// The ray-traced camera backend ("sim:<scene-file>"): the sensor model's
// response and noise against the analytic model, the state machine, the frame
// clock and reproducibility per frame id.

#include "lfi/sim/devices/sim_camera.h"
#include "lfi/drivers/camera_registry.h"
#include "lfi_test_support.h"
#include "scene_text.h"
#include "test_folder.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>

namespace lfi::sim {
namespace {

using namespace std::chrono_literals;
using testing_support::cameraSceneText;
using testing_support::kBackLightObject;
using testing_support::TestFolder;
using testing_support::throwsError;
namespace fs = std::filesystem;

// The camera looks straight at a Lambertian back light of radiance 1 that fills
// its field: every pixel's radiance is exactly 1.
const std::string kUniformScene = cameraSceneText({.samplesPerPixel = 1,
                                                   .seed = 3,
                                                   .pixelPitch_mm = 0.5,
                                                   .width_px = 64,
                                                   .height_px = 64,
                                                   .fullWell_e = 20000,
                                                   .readNoise_e = 5,
                                                   .bitDepth = 12,
                                                   .electronsPerUnitPerUs = 2.0}) +
                                  kBackLightObject;

class SimCameraTest : public ::testing::Test {
 protected:
  void SetUp() override { scene_ = dir_.write("uniform.toml", kUniformScene); }

  static CameraSettings mono16(double exposure_us, double gain_dB = 0) {
    CameraSettings s;
    s.exposure_us = exposure_us;
    s.gain = gain_dB;
    s.pixelFormat = PixelFormat::Mono16;
    return s;
  }

  // The scene's camera free-running in Mono16 at `rate_hz` with `buffers` buffers.
  std::unique_ptr<Camera> freeRunning(double exposure_us, double rate_hz, int buffers) const {
    auto camera = openSimCamera(scene_);
    CameraSettings s = mono16(exposure_us);
    s.frameRate_hz = rate_hz;
    camera->configure(s);
    camera->start(buffers);
    return camera;
  }

  // Mean and standard deviation of one frame, in ADC units (12 bits).
  static std::pair<double, double> stats(const cv::Mat& frame16, int bitDepth) {
    cv::Mat adc;
    frame16.convertTo(adc, CV_64F, 1.0 / (1 << (16 - bitDepth)));
    cv::Scalar mean, stddev;
    cv::meanStdDev(adc, mean, stddev);
    return {mean[0], stddev[0]};
  }

  TestFolder dir_{"lfi-sim-camera"};
  fs::path scene_;
};

TEST_F(SimCameraTest, TheSceneIsUniform) {
  SimImager imager(scene_);
  double lo = 0, hi = 0;
  cv::minMaxLoc(imager.radiance(1), &lo, &hi);
  EXPECT_NEAR(lo, 1.0, 1e-6);
  EXPECT_NEAR(hi, 1.0, 1e-6);
}

TEST_F(SimCameraTest, ExposureAndGainAreLinearUntilSaturation) {
  SimImager imager(scene_);
  const double maxDn = 4095, fullWell = 20000, electronsPerUs = 2.0;
  cv::Mat frame;
  // Expected ADC mean: 10^(g/20) * electronsPerUs * t / fullWell * maxDn (radiance 1).
  for (const double exposure : {500.0, 1000.0, 2000.0, 4000.0}) {
    for (const double gain : {0.0, 6.0}) {
      imager.capture(imager.resolve(mono16(exposure, gain), "test"), 1, frame);
      const double expected = std::pow(10, gain / 20) * electronsPerUs * exposure / fullWell * maxDn;
      const auto [mean, sigma] = stats(frame, 12);
      // 4096 pixels: the mean is good to sigma / 64; allow 4 of those plus rounding.
      EXPECT_NEAR(mean, expected, 4 * sigma / 64 + 0.5) << "exposure " << exposure << " us, gain " << gain << " dB";
    }
  }
  // Beyond the full well (t = 10 ms: 20 000 e-, the well is 20 000 e-) every pixel saturates at full scale,
  // and gain cannot push past it.
  for (const double exposure : {12'000.0, 50'000.0}) {
    imager.capture(imager.resolve(mono16(exposure, 6), "test"), 2, frame);
    const auto [mean, sigma] = stats(frame, 12);
    EXPECT_NEAR(mean, maxDn, 0.01);
    EXPECT_NEAR(sigma, 0, 0.01);
  }
  // Without gain, saturation sits at the full well: the read noise remains, the level is full scale.
  imager.capture(imager.resolve(mono16(15'000), "test"), 3, frame);
  EXPECT_NEAR(stats(frame, 12).first, maxDn, 2.0);
}

TEST_F(SimCameraTest, NoiseStatisticsMatchTheModel) {
  SimImager imager(scene_);
  cv::Mat frame;
  for (const double exposure : {100.0, 1000.0, 5000.0}) {
    const CameraSettings s = imager.resolve(mono16(exposure), "test");
    imager.capture(s, 11, frame);
    const auto [mean, sigma] = stats(frame, 12);
    // From the scene file's numbers, not the imager's model: 2 e-/us of
    // signal (its shot noise's variance is the count), 5 e- of read noise, 4095 DN for the 20 000 e- well, and the
    // quantisation's 1/12 DN^2. (At 100 us the read noise is 11 % of the
    // variance: a model that dropped it would be 5.7 % low.)
    const double dnPerElectron = 4095.0 / 20000;
    const double expected = std::sqrt((2.0 * exposure + 5.0 * 5.0) * dnPerElectron * dnPerElectron + 1.0 / 12);
    EXPECT_NEAR(imager.sensorModel(s).noiseDn(mean), expected, 0.01 * expected) << "exposure " << exposure << " us";
    // The sample std of 4096 pixels is good to about 1/sqrt(2 * 4096) = 1.1 %.
    EXPECT_NEAR(sigma, expected, 0.035 * expected) << "exposure " << exposure << " us";
  }
  // Binning 2 sums the charge of 4 pixels into a 4x deeper well: same level, half the shot noise.
  CameraSettings binned = mono16(4000);
  binned.binning = 2;
  binned = imager.resolve(binned, "test");
  imager.capture(binned, 11, frame);
  EXPECT_EQ(frame.cols, 32);
  const auto [meanBinned, sigmaBinned] = stats(frame, 12);
  imager.capture(imager.resolve(mono16(4000), "test"), 11, frame);
  const auto [meanFull, sigmaFull] = stats(frame, 12);
  EXPECT_NEAR(meanBinned, meanFull, 2.0);
  EXPECT_NEAR(sigmaBinned, imager.sensorModel(binned).noiseDn(meanBinned), 0.1 * sigmaBinned);
  EXPECT_NEAR(sigmaBinned / sigmaFull, 0.5, 0.06);
}

TEST_F(SimCameraTest, PixelFormatsKeepTheAdcsMostSignificantBits) {
  SimImager imager(scene_);
  CameraSettings s = imager.resolve(mono16(3000), "test");
  cv::Mat m16, m12, m8;
  imager.capture(s, 5, m16);
  s.pixelFormat = PixelFormat::Mono12;
  imager.capture(s, 5, m12);
  s.pixelFormat = PixelFormat::Mono8;
  imager.capture(s, 5, m8);
  ASSERT_EQ(m16.type(), CV_16UC1);
  ASSERT_EQ(m12.type(), CV_16UC1);
  ASSERT_EQ(m8.type(), CV_8UC1);
  for (int i = 0; i < 64; ++i) {
    const std::uint16_t adc = m12.at<std::uint16_t>(i, i);
    EXPECT_LE(adc, 4095);
    EXPECT_EQ(m16.at<std::uint16_t>(i, i), adc << 4);
    EXPECT_EQ(m8.at<std::uint8_t>(i, i), adc >> 4);
  }
}

TEST_F(SimCameraTest, StateMachine) {
  registerSimBackends();
  registerSimBackends();  // idempotent
  auto camera = openCamera("sim:" + scene_.string());
  using S = Camera::State;
  EXPECT_EQ(camera->state(), S::Open);
  EXPECT_EQ(camera->info().vendor, "lfi");
  EXPECT_EQ(camera->info().sensorWidth_px, 64);
  EXPECT_NEAR(*camera->info().pixelSize_um, 500, 1e-9);
  EXPECT_TRUE(throwsError([&] { camera->grab(10ms); }, Errc::InvalidArgument, {"grab()", "state Open", "Streaming"}));
  EXPECT_TRUE(throwsError([&] { camera->start(2); }, Errc::InvalidArgument, {"start()", "state Open"}));
  EXPECT_TRUE(throwsError([&] { camera->settings(); }, Errc::InvalidArgument, {"settings()", "state Open"}));
  EXPECT_TRUE(throwsError([&] { camera->open(); }, Errc::InvalidArgument, {"open()", "state Open"}));

  CameraSettings s = mono16(1000);
  s.frameRate_hz = 200;
  camera->configure(s);
  EXPECT_EQ(camera->state(), S::Configured);
  EXPECT_EQ(camera->settings().roiWidth_px, 64);
  EXPECT_TRUE(throwsError([&] { camera->softwareTrigger(); }, Errc::InvalidArgument, {"softwareTrigger()"}));
  camera->start(2);
  EXPECT_EQ(camera->state(), S::Streaming);
  EXPECT_TRUE(throwsError([&] { camera->configure(s); }, Errc::InvalidArgument, {"configure()", "Streaming"}));
  EXPECT_TRUE(throwsError([&] { camera->softwareTrigger(); }, Errc::InvalidArgument, {"FreeRun"}));
  EXPECT_EQ(camera->grab(1s).status, FrameStatus::Complete);
  camera->stop();
  EXPECT_EQ(camera->state(), S::Configured);
  camera->close();
  EXPECT_EQ(camera->state(), S::Closed);
  EXPECT_TRUE(throwsError([&] { camera->info(); }, Errc::InvalidArgument, {"info()", "Closed"}));
  camera->close();
  camera->open();
  EXPECT_EQ(camera->state(), S::Open);

  // Refused settings name the field and the limits, and leave the camera Open.
  CameraSettings bad = s;
  bad.roiWidth_px = 65;
  EXPECT_TRUE(throwsError([&] { camera->configure(bad); }, Errc::InvalidArgument, {"ROI", "64 x 64"}));
  EXPECT_EQ(camera->state(), S::Open);
  bad = s;
  bad.trigger = TriggerMode::Line;
  bad.triggerLine = "Line1";
  EXPECT_TRUE(throwsError([&] { camera->configure(bad); }, Errc::InvalidArgument, {"Line", "no trigger lines"}));
  bad = s;
  bad.gain = 30;
  EXPECT_TRUE(throwsError([&] { camera->configure(bad); }, Errc::InvalidArgument, {"gain 30", "0..24 dB"}));
  // A free-running clock of a frame per 10^12 s would overflow its nanoseconds (and its loop would never
  // end); a rate that is no rate is refused whatever the trigger, as the Aravis backend refuses it.
  bad = s;
  bad.trigger = TriggerMode::FreeRun;
  bad.frameRate_hz = 1e-12;
  EXPECT_TRUE(
      throwsError([&] { camera->configure(bad); }, Errc::InvalidArgument, {"frameRate_hz 1e-12", "0.001..1000 Hz"}));
  for (const double rate : {-1.0, std::numeric_limits<double>::quiet_NaN()}) {
    bad = s;
    bad.trigger = TriggerMode::Software;
    bad.frameRate_hz = rate;
    EXPECT_TRUE(throwsError([&] { camera->configure(bad); }, Errc::InvalidArgument, {"frameRate_hz", ">= 0"}));
  }
  EXPECT_EQ(camera->state(), S::Open);

  // Features.
  camera->configure(s);
  EXPECT_EQ(camera->getIntegerFeature("Width"), 64);
  camera->setFloatFeature("ExposureTime", 2000);
  EXPECT_DOUBLE_EQ(camera->settings().exposure_us, 2000);
  EXPECT_TRUE(throwsError([&] { camera->getFeature("NoSuchFeature"); }, Errc::NotFound, {"NoSuchFeature"}));
  EXPECT_TRUE(throwsError([&] { camera->setIntegerFeature("Width", 8); }, Errc::InvalidArgument, {"read-only"}));
  // The name first, then the value (camera.h: an unknown feature is NotFound, whatever the value).
  EXPECT_TRUE(throwsError([&] { camera->setFeature("NoSuchFeature", "abc"); }, Errc::NotFound, {"NoSuchFeature"}));
  EXPECT_TRUE(throwsError([&] { camera->setFeature("PixelFormat", "Mono8"); }, Errc::InvalidArgument, {"read-only"}));

  EXPECT_TRUE(
      throwsError([&] { openCamera("sim:" + (dir_ / "missing.toml").string()); }, Errc::NotFound, {"missing.toml"}));
  EXPECT_TRUE(
      throwsError([&] { openCamera("sim:" + scene_.string() + "?spp=4"); }, Errc::Config, {"unknown key 'spp'"}));
}

TEST_F(SimCameraTest, FramesAreReproduciblePerFrameId) {
  auto a = openSimCamera(scene_);
  auto b = openSimCamera(scene_);
  CameraSettings s = mono16(2000);
  s.roiX_px = 5;
  s.roiY_px = 7;
  s.roiWidth_px = 40;
  s.roiHeight_px = 30;
  s.trigger = TriggerMode::Software;
  a->configure(s);
  b->configure(s);
  a->start(4);
  b->start(4);
  for (int i = 0; i < 3; ++i) a->softwareTrigger();
  b->softwareTrigger();
  const Frame a1 = a->grab(1s), a2 = a->grab(1s), a3 = a->grab(1s);
  const Frame b1 = b->grab(1s);
  ASSERT_EQ(a1.status, FrameStatus::Complete);
  ASSERT_EQ(b1.status, FrameStatus::Complete);
  EXPECT_EQ(a1.frameId, 1u);
  EXPECT_EQ(a2.frameId, 2u);
  EXPECT_EQ(a3.frameId, 3u);
  EXPECT_EQ(b1.frameId, 1u);
  EXPECT_EQ(cv::norm(a1.image, b1.image, cv::NORM_INF), 0) << "same id, same frame";
  EXPECT_GT(cv::norm(a1.image, a2.image, cv::NORM_INF), 0) << "a new noise draw per frame";
  // A restarted stream goes on counting: its frames are new noise draws, not the last stream's again.
  b->stop();
  b->start(4);
  b->softwareTrigger();
  const Frame b2 = b->grab(1s);
  ASSERT_EQ(b2.status, FrameStatus::Complete);
  EXPECT_EQ(b2.frameId, 2u);
  EXPECT_EQ(cv::norm(a2.image, b2.image, cv::NORM_INF), 0) << "same id, same frame";
  // And SimImager (what serve-camera uses) gives the same frame for the id.
  SimImager imager(scene_);
  cv::Mat expected;
  imager.capture(imager.resolve(s, "test"), 2, expected);
  EXPECT_EQ(cv::norm(a2.image, expected, cv::NORM_INF), 0);
}

TEST_F(SimCameraTest, SoftwareTriggerDeliversExactlyOneFrame) {
  auto camera = openSimCamera(scene_);
  CameraSettings s = mono16(1000);
  s.trigger = TriggerMode::Software;
  camera->configure(s);
  camera->start(2);
  EXPECT_EQ(camera->grab(50ms).status, FrameStatus::Timeout);
  for (int i = 0; i < 3; ++i) {
    camera->softwareTrigger();
    EXPECT_EQ(camera->grab(1s).status, FrameStatus::Complete);
    EXPECT_EQ(camera->grab(20ms).status, FrameStatus::Timeout);
  }
  // More triggers than buffers: the extra frames are underruns.
  for (int i = 0; i < 3; ++i) camera->executeCommand("TriggerSoftware");
  EXPECT_EQ(camera->statistics().underruns, 1u);
  EXPECT_EQ(camera->grab(1s).frameId, 4u);
  EXPECT_EQ(camera->grab(1s).frameId, 5u);
  EXPECT_EQ(camera->statistics().completed, 5u);
}

// Every frame id a free-running stream skipped is an underrun, and every underrun an id skipped: `last` and
// `skipped` are the last id grabbed and the ids skipped until it. Reads the underruns (ids skipped up to `last`
// must be among them), then grabs on. A frame the camera made after the read (its timestamp is its due time on
// this host's steady clock) found none queued, so every underrun read is an id skipped before it and every id
// skipped before it was one by then: the counts are equal. A consumer that fell behind (the frame was queued
// at the read) checks at the frame after the buffers' worth, which the camera made after the read, that the
// underruns read are ids skipped before it.
void expectUnderrunsAreSkippedIds(Camera& camera, int buffers, std::uint64_t& last, std::uint64_t& skipped) {
  const std::uint64_t underruns = camera.statistics().underruns;
  const auto readAt = static_cast<std::uint64_t>(
      std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
          .count());
  EXPECT_GE(underruns, skipped) << "frame ids skipped that no underrun counts";
  Frame frame;
  for (int n = 1;; ++n) {
    camera.grabInto(frame, 1s);
    ASSERT_EQ(frame.status, FrameStatus::Complete);
    skipped += frame.frameId - last - 1;
    last = frame.frameId;
    if (n == 1 && frame.timestamp_ns > readAt) {
      EXPECT_EQ(underruns, skipped) << "underruns and frame ids skipped before frame " << frame.frameId;
      std::printf("[ info     ] %llu underruns, %llu ids skipped before frame %llu\n",
                  static_cast<unsigned long long>(underruns), static_cast<unsigned long long>(skipped),
                  static_cast<unsigned long long>(frame.frameId));
      return;
    }
    if (n > buffers) {
      EXPECT_LE(underruns, skipped) << "underruns counted for frames delivered, before frame " << frame.frameId;
      std::printf("[ info     ] frames queued at the read: %llu underruns, %llu ids skipped before frame %llu\n",
                  static_cast<unsigned long long>(underruns), static_cast<unsigned long long>(skipped),
                  static_cast<unsigned long long>(frame.frameId));
      return;
    }
  }
}

TEST_F(SimCameraTest, FreeRunKeepsTheFrameRateAndCountsUnderruns) {
  // 64 buffers hold 0.32 s of frames. A host that stalls this test longer loses frames to underruns: each lost
  // one is a skipped id and an underrun counted, so the test holds whatever the host's load.
  auto camera = freeRunning(1000, 200, 64);
  const auto t0 = std::chrono::steady_clock::now();
  Frame frame;
  std::uint64_t previous = 0, previousTime = 0, skipped = 0;
  for (int i = 0; i < 20; ++i) {
    camera->grabInto(frame, 1s);
    ASSERT_EQ(frame.status, FrameStatus::Complete);
    if (i > 0) {
      ASSERT_GT(frame.frameId, previous);
      skipped += frame.frameId - previous - 1;
      // The device's clock: frames 1/200 s apart (to its tick), however the host scheduled the grabs.
      EXPECT_NEAR(static_cast<double>(frame.timestamp_ns - previousTime),
                  5e6 * static_cast<double>(frame.frameId - previous), 1.0);
    }
    previous = frame.frameId;
    previousTime = frame.timestamp_ns;
  }
  // And the grabs waited for them: 20 frames take at least 19 periods (a lower bound, which no host load breaks).
  EXPECT_GE(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 19 / 200.0 - 1e-3);
  expectUnderrunsAreSkippedIds(*camera, 64, previous, skipped);
  // A consumer that falls behind: 3 buffers.
  camera = freeRunning(1000, 200, 3);
  camera->grabInto(frame, 1s);
  previous = frame.frameId;
  const std::uint64_t first = previous;
  skipped = 0;
  std::this_thread::sleep_for(100ms);  // 20 frames due, 3 buffers
  camera->grabInto(frame, 1s);
  EXPECT_EQ(frame.frameId, previous + 1) << "the oldest queued frame comes first";
  previous = frame.frameId;
  EXPECT_GE(camera->statistics().underruns, 15u);
  for (int i = 0; i < 3; ++i) {
    camera->grabInto(frame, 1s);
    skipped += frame.frameId - previous - 1;
    previous = frame.frameId;
  }
  EXPECT_GT(frame.frameId, first + 10) << "ids skip the frames that found no buffer";
  expectUnderrunsAreSkippedIds(*camera, 3, previous, skipped);
}

// A frame exposed before ExposureTime changed keeps the exposure it was taken
// with, as a real camera's would: the frames waiting in the buffers show the
// old one, frames exposed after the change the new one.
TEST_F(SimCameraTest, FramesKeepTheExposureTheyWereTakenWith) {
  auto camera = freeRunning(1000, 200, 4);
  std::this_thread::sleep_for(50ms);  // the four buffers fill at 1000 us
  camera->setFloatFeature("ExposureTime", 3000);
  Frame frame;
  camera->grabInto(frame, 1s);
  ASSERT_EQ(frame.status, FrameStatus::Complete);
  const double before = cv::mean(frame.image)[0];
  for (int i = 0; i < 3; ++i) camera->grabInto(frame, 1s);  // the rest of the old ones
  camera->grabInto(frame, 1s);                              // exposed after the change
  ASSERT_EQ(frame.status, FrameStatus::Complete);
  const double after = cv::mean(frame.image)[0];
  EXPECT_NEAR(after / before, 3.0, 0.3) << before << " DN, then " << after << " DN";
}

// A consumer faster than the frame rate waits for each frame: at rates whose
// period is no whole number of clock ticks (30 Hz), the wait must end with the
// frame, not with the grab's timeout (a due time rounded one way, the count
// of due frames the other, once lost 134 of 199 frames so).
TEST_F(SimCameraTest, AFastConsumerGetsEveryFrameAtAnyRate) {
  for (const double rate : {30.0, 24.0, 60.0}) {
    auto camera = freeRunning(1000, rate, 4);
    Frame frame;
    for (int i = 0; i < 8; ++i) {
      camera->grabInto(frame, 2s);
      ASSERT_EQ(frame.status, FrameStatus::Complete) << rate << " Hz, grab " << i;
    }
    EXPECT_EQ(camera->statistics().completed, 8u) << rate;
  }
}

TEST_F(SimCameraTest, SceneFileCameraSensorTable) {
  const SceneDescription d = loadSceneFile(scene_);
  EXPECT_DOUBLE_EQ(d.cameraSensor.fullWell_e, 20000);
  EXPECT_DOUBLE_EQ(d.cameraSensor.readNoise_e, 5);
  EXPECT_EQ(d.cameraSensor.bitDepth, 12);
  EXPECT_DOUBLE_EQ(d.cameraSensor.electronsPerUnitPerUs, 2.0);
  std::string text = kUniformScene;
  text.replace(text.find("bit_depth = 12"), 14, "bit_depht = 12");
  const fs::path typo = dir_ / "typo.toml";
  std::ofstream(typo) << text;
  EXPECT_TRUE(throwsError([&] { loadSceneFile(typo); }, Errc::Config, {"bit_depht"}));
  // Without the table: the defaults.
  text = kUniformScene;
  text.erase(text.find("[camera_sensor]"), text.find("[[object]]") - text.find("[camera_sensor]"));
  const fs::path plain = dir_ / "plain.toml";
  std::ofstream(plain) << text;
  EXPECT_DOUBLE_EQ(loadSceneFile(plain).cameraSensor.fullWell_e, CameraSensorParameters{}.fullWell_e);
}

}  // namespace
}  // namespace lfi::sim
