// SPDX-License-Identifier: Apache-2.0
// The emulated USB3 Vision camera's faults through lfi's aravis: backend and
// Aravis's USB3 Vision code: each ends in a named error or a frame the
// controller counts as incomplete and retries, never a hang, and the camera
// works again once the fault is gone (after a replug, it opens again).

#include "lfi/core/error.h"
#include "lfi/drivers/camera_registry.h"

#include "lfi_test_support.h"
#include "u3v_camera_fixture.h"

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <algorithm>
#include <chrono>
#include <memory>
#include <string>
#include <vector>

namespace lfi {
namespace {

using namespace std::chrono_literals;
using testing_support::throwsError;
using testing_support::U3vCameraTest;

class U3vCameraFaults : public U3vCameraTest {
 protected:
  std::unique_ptr<Camera> streaming() {
    auto camera = openCamera("aravis:" + device_->deviceId());
    CameraSettings s;
    s.trigger = TriggerMode::Software;
    s.roiWidth_px = 64, s.roiHeight_px = 48;
    camera->configure(s);
    camera->start(4);
    return camera;
  }

  // A software-triggered frame, complete and the one the device made for it.
  void expectGoodFrame(Camera& camera) {
    camera.softwareTrigger();
    const Frame frame = camera.grab(5s);
    ASSERT_EQ(frame.status, FrameStatus::Complete);
    const cv::Mat expected = made(frame.frameId);
    ASSERT_FALSE(expected.empty());
    EXPECT_EQ(cv::norm(frame.image, expected, cv::NORM_INF), 0) << "frame " << frame.frameId;
  }
};

TEST_F(U3vCameraFaults, ACameraUnpluggedMidStreamIsADeviceErrorAndOpensAgainWhenPluggedIn) {
  auto camera = streaming();
  expectGoodFrame(*camera);
  device_->unplug();
  EXPECT_TRUE(throwsError(
      [&] {
        for (int i = 0; i < 10; ++i) {  // (a frame on its way may still arrive)
          camera->softwareTrigger();
          camera->grab(2s);
        }
      },
      Errc::Device, {device_->deviceId()}));
  device_->plug();
  camera->close();
  camera->open();
  CameraSettings s;
  s.trigger = TriggerMode::Software;
  camera->configure(s);
  camera->start(4);
  expectGoodFrame(*camera);
}

// A halted stream endpoint delivers nothing: grabs time out (the controller
// counts them and names the camera); frames come again once it is cleared.
TEST_F(U3vCameraFaults, AStalledStreamEndpointTimesGrabsOutUntilItIsCleared) {
  auto camera = streaming();
  expectGoodFrame(*camera);
  device_->stallStream(true);
  camera->softwareTrigger();
  EXPECT_EQ(camera->grab(1s).status, FrameStatus::Timeout);
  device_->stallStream(false);
  Frame frame = camera->grab(5s);  // (the frame made while stalled arrives now)
  EXPECT_EQ(frame.status, FrameStatus::Complete);
  expectGoodFrame(*camera);
}

// A short payload: that frame is incomplete, the next one whole. A trailer
// without its magic: the host reads it as data and keeps the frame open until
// a trailer comes; in Aravis's sync mode the next frame's leader then falls into
// a trailer-sized transfer and overflows it, so that frame is lost. Whatever is
// lost, no frame is delivered complete that is not the one made under its id,
// and frames come whole again.
TEST_F(U3vCameraFaults, AShortOrBadlyClosedFrameCostsFramesButNeverGivesAWrongOne) {
  auto camera = streaming();
  device_->shortenNextFrame(100);
  camera->softwareTrigger();
  EXPECT_EQ(camera->grab(5s).status, FrameStatus::Incomplete);
  expectGoodFrame(*camera);
  device_->corruptNextTrailer();
  int complete = 0;
  for (int i = 0; i < 4; ++i) {
    camera->softwareTrigger();
    const Frame frame = camera->grab(1s);
    if (frame.status != FrameStatus::Complete) continue;
    ++complete;
    EXPECT_EQ(cv::norm(frame.image, made(frame.frameId), cv::NORM_INF), 0) << "frame " << frame.frameId;
  }
  EXPECT_LT(complete, 4);  // (one lost at least)
  expectGoodFrame(*camera);
}

// A GenCP status error answers a write: a Device error naming the device and
// the feature; the write after it goes through. A device that stops answering
// GenCP is lost (after Aravis's tries): a Device error, the camera closed, and
// it opens again once the device answers.
TEST_F(U3vCameraFaults, AGencpErrorIsANamedErrorAndASilentDeviceIsLostUntilItAnswers) {
  auto camera = openCamera("aravis:" + device_->deviceId());
  camera->configure({});
  device_->failNextCommand(0x8FFF);  // GenCP's generic ERROR
  EXPECT_TRUE(throwsError([&] { camera->setFloatFeature("ExposureTime", 3000); }, Errc::Device,
                          {device_->deviceId(), "ExposureTime"}));
  camera->setFloatFeature("ExposureTime", 3000);
  EXPECT_DOUBLE_EQ(camera->getFloatFeature("ExposureTime"), 3000);
  device_->setSilent(true);
  EXPECT_TRUE(throwsError([&] { camera->getFloatFeature("ExposureTime"); }, Errc::Device, {device_->deviceId()}));
  EXPECT_EQ(camera->state(), Camera::State::Closed);
  device_->setSilent(false);
  camera->open();
  EXPECT_DOUBLE_EQ(camera->getFloatFeature("ExposureTime"), 3000);
}

}  // namespace
}  // namespace lfi
