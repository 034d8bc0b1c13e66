// SPDX-License-Identifier: Apache-2.0
#pragma once
// The fixture of the USB3 Vision tests: an emulated USB3 Vision camera
// (emulated_u3v_camera.h) plugged in for each test, whose frames are a pattern
// of their id, region and format, each kept so that a test can compare what a
// client received with what the device made. Runs under umockdev's preload
// library (run_with_umockdev.sh); Aravis's GigE Vision discovery is off.

#include "lfi/drivers/builtin_backends.h"
#include "lfi/emulation/emulated_u3v_camera.h"
#include "lfi/emulation/emulated_usb_display.h"

#include <arv.h>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>

namespace lfi::testing_support {

using emulation::EmulatedU3vCamera;
using emulation::EmulatedU3vCameraConfig;
using emulation::ServedFrameRequest;

inline const bool kPrivateTmp = (emulation::usePrivateTmpDir(), true);

class U3vCameraTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(kPrivateTmp);
    ASSERT_TRUE(emulation::umockdevPreloadActive()) << "run this test through ctest or run_with_umockdev.sh";
    registerDriverBackends();
    arv_disable_interface("GigEVision");  // (an id that matches no USB device would be looked for on the network)
    config_.sensorWidth_px = 320;
    config_.sensorHeight_px = 240;
    device_ = std::make_unique<EmulatedU3vCamera>(config_, [this](const ServedFrameRequest& r, cv::Mat& image) {
      // A pattern of the frame id, the region and the format's bits: no two frames alike.
      const int bits = r.pixelFormat ? significantBits(*r.pixelFormat) : 8;
      const int mask = (1 << bits) - 1;
      for (int y = 0; y < image.rows; ++y)
        for (int x = 0; x < image.cols; ++x) {
          const int v = static_cast<int>((x + r.offsetX_px) * 7 + (y + r.offsetY_px) * 131 + r.frameId * 977) & mask;
          if (image.type() == CV_8UC1)
            image.at<std::uint8_t>(y, x) = static_cast<std::uint8_t>(v);
          else
            image.at<std::uint16_t>(y, x) = static_cast<std::uint16_t>(v);
        }
      std::lock_guard lock(madeMutex_);
      made_[r.frameId] = image.clone();
    });
    device_->plug();
  }

  cv::Mat made(std::uint64_t frameId) {
    std::lock_guard lock(madeMutex_);
    auto it = made_.find(frameId);
    return it == made_.end() ? cv::Mat() : it->second;
  }

  EmulatedU3vCameraConfig config_;
  std::unique_ptr<EmulatedU3vCamera> device_;
  std::mutex madeMutex_;
  std::map<std::uint64_t, cv::Mat> made_;
};

}  // namespace lfi::testing_support
