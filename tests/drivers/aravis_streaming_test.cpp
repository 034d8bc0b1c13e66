// SPDX-License-Identifier: Apache-2.0
// The Aravis backend's stream (aravis_camera_fixture.h): continuous and triggered
// frames, underruns, and frames refused for another pixel format or region.

#include "aravis_camera_fixture.h"
#include "stream_tally.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <cstdio>
#include <string>
#include <thread>

namespace lfi {
namespace {

using lfi::testing_support::StreamLedger;

// A device that sends another pixel format than the one configured (its
// firmware ignores PixelFormat, or a generic feature write changed it) must
// not hand out a complete frame of the wrong type or scale.
TEST_F(AravisCameraTest, AFrameInAnotherPixelFormatIsAnError) {
  auto camera = openFake();
  CameraSettings s = smallSettings();
  ASSERT_EQ(s.pixelFormat, PixelFormat::Mono8);
  camera->configure(s);
  camera->setFeature("PixelFormat", "Mono16");
  camera->start(4);
  Frame frame;
  EXPECT_TRUE(throwsError([&] { camera->grabInto(frame, 2s); }, Errc::Device,
                          {fake_->id(), "pixel format is 0x01100007", "configured Mono8"}));
  camera->stop();
  camera->setFeature("PixelFormat", "Mono8");
  camera->start(4);
  camera->grabInto(frame, 2s);
  EXPECT_EQ(frame.status, FrameStatus::Complete);
  EXPECT_EQ(frame.image.type(), CV_8UC1);
}

// The buffers are sized for the region the stream started with: a device that
// sends frames of another size (here one whose region changes while it
// streams; real ones lock it) gives an error naming both sizes, not a frame
// of a size the settings do not say.
TEST_F(AravisCameraTest, AFrameOfAnotherSizeThanTheStreamsRegionIsAnError) {
  auto camera = openFake();
  camera->configure(smallSettings());
  camera->start(4);
  Frame frame;
  camera->grabInto(frame, 2s);
  ASSERT_EQ(frame.status, FrameStatus::Complete);
  ASSERT_EQ(frame.image.size(), cv::Size(256, 256));
  camera->setFeature("Width", "128");
  std::string refused;
  for (int i = 0; i < 50 && refused.empty(); ++i) {  // (frames already on their way are still 256 wide)
    try {
      camera->grabInto(frame, 2s);
      ASSERT_EQ(frame.image.size(), cv::Size(256, 256));
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), Errc::Device);
      refused = e.what();
    }
  }
  EXPECT_NE(refused.find(fake_->id()), std::string::npos) << refused;
  EXPECT_NE(refused.find("128 x 256 px, not the 256 x 256 px region"), std::string::npos) << refused;
}

// 60 frames in a row, each the fake camera's frame for its id, into the same memory; every frame lost on the
// way accounted for (stream_tally.h).
TEST_F(AravisCameraTest, StreamsContinuousCompleteFramesIntoReusedMemory) {
  auto camera = openFake();
  camera->configure(rampSettings());
  camera->start(8);
  StreamLedger ledger(*camera, 8, hostDrops_);
  const auto expectWhole = [](const Frame& f) {
    if (f.status != FrameStatus::Complete) return;
    ASSERT_EQ(f.image.size(), cv::Size(256, 256));
    EXPECT_EQ(cv::norm(f.image, fakeCameraFrame(f.frameId, 256, 256), cv::NORM_INF), 0)
        << "frame id " << f.frameId << " came complete but is not the frame sent";
  };
  constexpr int kFrames = 60;
  Frame frame;
  do {
    camera->grabInto(frame, 2s);
    ASSERT_TRUE(ledger.add(frame));
  } while (ledger.wantsMore(1));
  ASSERT_EQ(frame.status, FrameStatus::Complete);
  expectWhole(frame);
  const std::uint8_t* memory = frame.image.data;
  bool previousComplete = true;  // (an incomplete frame may give its memory up)
  std::uint64_t lastTimestamp = frame.timestamp_ns;
  const auto t0 = Clock::now();
  while (ledger.wantsMore(kFrames)) {
    camera->grabInto(frame, 2s);
    ASSERT_TRUE(ledger.add(frame));
    if (frame.status == FrameStatus::Complete) {  // (an incomplete frame may lack its leader's timestamp)
      expectWhole(frame);
      EXPECT_GT(frame.timestamp_ns, lastTimestamp);
      lastTimestamp = frame.timestamp_ns;
      if (previousComplete) {
        EXPECT_EQ(frame.image.data, memory) << "grabInto must reuse the frame's memory";
      }
      memory = frame.image.data;
    }
    previousComplete = frame.status == FrameStatus::Complete;
  }
  ASSERT_TRUE(ledger.ok());
  const double fps = static_cast<double>(ledger.complete() - 1 + ledger.incomplete() + ledger.skipped()) /
                     secondsSince(t0);  // (frame ids per second)
  RecordProperty("frames_per_second", std::to_string(fps));
  std::printf("[ info     ] %d frames of 256 x 256 Mono8 at %.1f frames/s (asked 200)\n", kFrames - 1, fps);
  ledger.close(expectWhole);

  // A caller holding on to a frame's image keeps it: the next complete grab writes elsewhere.
  cv::Mat kept = frame.image;
  const int before = ledger.complete();
  do {
    camera->grabInto(frame, 2s);
    ASSERT_TRUE(ledger.add(frame));
  } while (ledger.wantsMore(before + 1));
  ASSERT_EQ(frame.status, FrameStatus::Complete);
  EXPECT_NE(frame.image.data, kept.data);
  expectWhole(frame);

  const StreamStatistics stats = camera->statistics();
  EXPECT_GE(stats.completed, static_cast<std::uint64_t>(kFrames));
  camera->stop();
  const StreamStatistics after = camera->statistics();  // kept after stop
  EXPECT_GE(after.completed, stats.completed);
}

// A consumer slower than the stream: the frames that find no buffer are underruns, for each id skipped exactly
// the packets of a frame (stream_tally.h: at the cut U = P·S when no frame came incomplete).
TEST_F(AravisCameraTest, SlowConsumerSeesUnderruns) {
  auto camera = openFake();
  camera->configure(smallSettings());
  camera->start(2);
  StreamLedger ledger(*camera, 2, hostDrops_);
  std::this_thread::sleep_for(300ms);  // ~60 frames arrive for 2 buffers
  Frame frame;
  camera->grabInto(frame, 2s);
  EXPECT_EQ(frame.status, FrameStatus::Complete);
  ASSERT_TRUE(ledger.add(frame));
  EXPECT_GT(camera->statistics().underruns, 0u);
  // On past the frames the two buffers held to the first that found a buffer again; then to the cut.
  while (ledger.wantsMore(3)) {
    camera->grabInto(frame, 2s);
    ASSERT_TRUE(ledger.add(frame));
  }
  EXPECT_GT(ledger.skipped(), 0u);
  ledger.close();
}

TEST_F(AravisCameraTest, SoftwareTriggerGivesExactlyOneFramePerTrigger) {
  auto camera = openFake();
  CameraSettings s = smallSettings();
  s.trigger = TriggerMode::Software;
  camera->configure(s);
  camera->start(4);
  EXPECT_EQ(camera->grab(300ms).status, FrameStatus::Timeout) << "a frame arrived without a trigger";
  std::uint64_t lastId = 0;
  for (int i = 0; i < 5; ++i) {
    camera->softwareTrigger();
    const Frame frame = camera->grab(2s);
    ASSERT_EQ(frame.status, FrameStatus::Complete) << "trigger " << i;
    if (i > 0) {
      EXPECT_EQ(frame.frameId, lastId + 1);
    }
    lastId = frame.frameId;
    EXPECT_EQ(camera->grab(200ms).status, FrameStatus::Timeout) << "more than one frame for trigger " << i;
  }
  EXPECT_EQ(camera->statistics().completed, 5u);
}

}  // namespace
}  // namespace lfi
