// SPDX-License-Identifier: Apache-2.0
#pragma once
// The fixture of the usb: display backend's tests against the emulated device: each test
// checks that umockdev's preload library is active (the process has a private TMPDIR for
// its testbed) and registers the display backends; helpers compare presented panels.

#include "lfi/drivers/builtin_backends.h"
#include "lfi/drivers/display.h"
#include "lfi/emulation/emulated_usb_display.h"

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <cstdint>

namespace lfi::testing_support {

using emulation::EmulatedDisplayConfig;
using emulation::EmulatedUsbDisplay;

inline const bool kPrivateTmp = (emulation::usePrivateTmpDir(), true);

class UsbDisplayTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(kPrivateTmp);
    ASSERT_TRUE(emulation::umockdevPreloadActive())
        << "umockdev's preload library is not active: run this test through ctest, umockdev-wrapper or "
           "LD_PRELOAD=libumockdev-preload.so.0";
    registerDriverBackends();
  }

  static cv::Mat randomPanel(const DisplayInfo& info, unsigned seed) {
    cv::Mat panel(info.panelHeight_px, info.panelWidth_px, info.panelType());
    cv::RNG rng(seed);
    rng.fill(panel, cv::RNG::UNIFORM, 0, 256);
    return panel;
  }

  static bool sameBytes(const cv::Mat& a, const cv::Mat& b) {
    return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0;
  }

  // `panel` is presented whole, after one CLEAR_HALT that drops what the device holds of an earlier frame.
  static void expectPresentedAfterOneClearHalt(EmulatedUsbDisplay& device, Display& display, const cv::Mat& panel) {
    const std::uint32_t halts = device.state().clearHalts;
    const PresentResult result = display.show(panel);
    ASSERT_EQ(result.status, PresentStatus::Presented) << result.message;
    EXPECT_TRUE(sameBytes(device.presented(), panel));
    EXPECT_EQ(device.state().clearHalts, halts + 1);
  }
};

}  // namespace lfi::testing_support
