// SPDX-License-Identifier: Apache-2.0
// The `usb:` display backend showing frames on the emulated device (emulated_usb_display.h): the
// state machine, brightness, frames that arrive byte-exact, and frames or statuses the device refuses.
// Runs under umockdev's preload library (CTest starts it through tests/drivers/run_with_umockdev.sh).

#include "lfi_test_support.h"
#include "usb_display_fixture.h"

#include "lfi/drivers/display.h"
#include "lfi/drivers/display_optics.h"
#include "lfi/drivers/display_registry.h"
#include "lfi/drivers/usb/usb_display.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <mutex>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

namespace lfi {
namespace {

using emulation::EmulatedDisplayConfig;
using emulation::EmulatedUsbDisplay;
using testing_support::throwsError;
using testing_support::UsbDisplayTest;
using Clock = std::chrono::steady_clock;

TEST_F(UsbDisplayTest, StateMachine) {
  EmulatedUsbDisplay device;
  device.plug();
  auto display = openDisplay("usb:1209:4c46");
  const DisplayInfo info = display->info();
  EXPECT_TRUE(throwsError([&] { display->open(); }, Errc::InvalidArgument, {"open", "state Open"}));
  display->blank();  // Open → Open
  EXPECT_EQ(display->state(), Display::State::Open);
  EXPECT_EQ(display->show(randomPanel(info, 1)).status, PresentStatus::Presented);
  EXPECT_EQ(display->state(), Display::State::Showing);
  EXPECT_EQ(display->show(randomPanel(info, 2)).status, PresentStatus::Presented);
  EXPECT_EQ(display->state(), Display::State::Showing);
  EXPECT_TRUE(display->status().showing);
  display->blank();
  EXPECT_EQ(display->state(), Display::State::Open);
  EXPECT_FALSE(display->status().showing);
  EXPECT_FALSE(device.state().showing);
  display->close();
  EXPECT_EQ(display->state(), Display::State::Closed);
  EXPECT_FALSE(device.state().claimed);
  EXPECT_TRUE(throwsError([&] { display->info(); }, Errc::InvalidArgument, {"info", "state Closed"}));
  EXPECT_TRUE(throwsError([&] { display->show(randomPanel(info, 3)); }, Errc::InvalidArgument, {"show"}));
  EXPECT_TRUE(throwsError([&] { display->blank(); }, Errc::InvalidArgument, {"blank"}));
  display->close();  // idempotent
  display->open();
  EXPECT_EQ(display->state(), Display::State::Open);
  // A wrong panel image is the caller's error.
  EXPECT_TRUE(
      throwsError([&] { display->show(cv::Mat(4, 4, CV_8UC3)); }, Errc::InvalidArgument, {"640x400", "got 4x4"}));
}

TEST_F(UsbDisplayTest, Brightness) {
  EmulatedUsbDisplay device;
  device.plug();
  auto display = openDisplay("usb:1209:4c46");
  display->setBrightness(100);
  EXPECT_EQ(device.state().brightness, 100);
  EXPECT_EQ(display->status().brightness, 100);
  EXPECT_TRUE(throwsError([&] { display->setBrightness(256); }, Errc::InvalidArgument, {"brightness 256", "0..255"}));
}

struct PanelCase {
  int width;
  int height;
  usbdisplay::SubpixelCode subpixels;
};

// (GoogleTest would print the struct's bytes, padding included, into the CTest names: a different name each build.)
void PrintTo(const PanelCase& c, std::ostream* out) {
  *out << c.width << " x " << c.height << (c.subpixels == usbdisplay::SubpixelCode::Mono ? " mono" : " RGB stripe");
}

class UsbDisplayFrames : public UsbDisplayTest, public ::testing::WithParamInterface<PanelCase> {};

TEST_P(UsbDisplayFrames, ArriveByteExact) {
  EmulatedDisplayConfig config;
  config.panelWidth_px = GetParam().width;
  config.panelHeight_px = GetParam().height;
  config.subpixels = GetParam().subpixels;
  EmulatedUsbDisplay device(config);
  device.plug();
  UsbDisplayOptions options;
  options.transferSize_bytes = 256 * 1024;
  auto display = openUsbDisplay({usbdisplay::kDefaultVendorId, usbdisplay::kDefaultProductId, ""}, options);
  const DisplayInfo info = display->info();
  for (unsigned seed = 1; seed <= 2; ++seed) {
    const cv::Mat panel = randomPanel(info, seed);
    const auto start = Clock::now();
    const PresentResult result = display->show(panel);
    const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
    ASSERT_EQ(result.status, PresentStatus::Presented) << result.message;
    EXPECT_TRUE(sameBytes(device.presented(), panel));
    EXPECT_EQ(device.state().presentedSequence, result.sequence);
    RecordProperty(fmt::format("show_{}x{}x{}_ms", info.panelWidth_px, info.panelHeight_px, panel.channels()),
                   static_cast<int>(seconds * 1000));
  }
  const std::size_t bytes =
      static_cast<std::size_t>(info.panelWidth_px) * info.panelHeight_px * info.subpixelsPerPixel();
  if (bytes > 2 * options.transferSize_bytes) {
    EXPECT_GE(device.state().maxUrbsInFlight, 2u);
  }
  EXPECT_EQ(display->status().framesPresented, 2u);
}

INSTANTIATE_TEST_SUITE_P(Sizes, UsbDisplayFrames,
                         ::testing::Values(PanelCase{1, 1, usbdisplay::SubpixelCode::Mono},
                                           PanelCase{333, 77, usbdisplay::SubpixelCode::Mono},
                                           PanelCase{640, 400, usbdisplay::SubpixelCode::RgbStripe},
                                           PanelCase{3840, 2160, usbdisplay::SubpixelCode::RgbStripe}),
                         [](const auto& param) {
                           return fmt::format("{}x{}x{}", param.param.width, param.param.height,
                                              param.param.subpixels == usbdisplay::SubpixelCode::Mono ? 1 : 3);
                         });

TEST_F(UsbDisplayTest, PresentedImageIsTheEncodedLightField) {
  EmulatedUsbDisplay device;
  device.plug();
  auto display = openDisplay("usb:1209:4c46");
  const DisplayInfo info = display->info();
  LightFieldGeometry g{.spatialX = 24, .spatialY = 16, .angular = 8, .pixelPitch_mm = 0.25};
  LightField lf(g);
  cv::RNG rng(7);
  rng.fill(lf.lensletImage(), cv::RNG::UNIFORM, 0.0, 1.0);
  const cv::Mat expected = encodeLightField(lf, DisplayOptics(info));  // what the controller sends (emit)
  const PresentResult result = display->show(expected);
  ASSERT_EQ(result.status, PresentStatus::Presented) << result.message;
  EXPECT_TRUE(sameBytes(device.presented(), expected));
  EXPECT_GT(cv::countNonZero(expected.reshape(1)), static_cast<int>(expected.total()));  // not a blank panel
}

TEST_F(UsbDisplayTest, EveryPresentedFrameReachesTheHandlerOnceAndNoRejectedOne) {
  // What drives a simulated bench's renderer: each frame the device presents, as it presents it, with its
  // sequence; a frame it rejects never.
  EmulatedUsbDisplay device;
  std::mutex mutex;  // (the handler runs on the device's thread)
  std::vector<std::pair<cv::Mat, std::uint32_t>> seen;
  device.observePanel({.presented = [&](const cv::Mat& panel, std::uint32_t sequence) {
    std::lock_guard lock(mutex);
    seen.emplace_back(panel.clone(), sequence);
  }});
  device.plug();
  auto display = openDisplay("usb:1209:4c46");
  const DisplayInfo info = display->info();
  const cv::Mat first = randomPanel(info, 11), second = randomPanel(info, 12);
  const PresentResult a = display->show(first);
  device.corruptNextFrame();
  EXPECT_EQ(display->show(randomPanel(info, 13)).status, PresentStatus::Rejected);
  const PresentResult b = display->show(second);
  ASSERT_EQ(a.status, PresentStatus::Presented);
  ASSERT_EQ(b.status, PresentStatus::Presented);
  std::lock_guard lock(mutex);
  ASSERT_EQ(seen.size(), 2u);
  EXPECT_TRUE(sameBytes(seen[0].first, first));
  EXPECT_EQ(seen[0].second, a.sequence);
  EXPECT_TRUE(sameBytes(seen[1].first, second));
  EXPECT_EQ(seen[1].second, b.sequence);
}

TEST_F(UsbDisplayTest, TheObserverSeesBrightnessAndBlankAndNothingOnceRemoved) {
  EmulatedUsbDisplay device;
  std::mutex mutex;
  std::vector<std::string> seen;
  const auto note = [&](std::string what) {
    std::lock_guard lock(mutex);
    seen.push_back(std::move(what));
  };
  device.observePanel({.presented = [&](const cv::Mat&, std::uint32_t s) { note(fmt::format("present {}", s)); },
                       .brightness = [&](int level) { note(fmt::format("brightness {}", level)); },
                       .blanked = [&] { note("blank"); }});
  device.plug();
  auto display = openDisplay("usb:1209:4c46");
  const cv::Mat panel = randomPanel(display->info(), 14);
  {
    std::lock_guard lock(mutex);
    seen.clear();  // (what open() does: blank, full brightness; display.h's state after open)
  }
  ASSERT_EQ(display->show(panel).status, PresentStatus::Presented);
  display->setBrightness(7);
  display->blank();
  device.observePanel({});
  EXPECT_EQ(display->show(panel).status, PresentStatus::Presented);
  display->setBrightness(9);
  std::lock_guard lock(mutex);
  EXPECT_EQ(seen, (std::vector<std::string>{"present 1", "brightness 7", "blank"}));
}

// An open display is dark at full backlight, as display.h says and the sim:
// display is: close() blanks a panel that shows a frame, and open() blanks
// whatever an earlier host left (here one whose BLANK at close went unanswered).
TEST_F(UsbDisplayTest, ADisplayOpensDarkAtFullBacklightWhateverTheLastHostLeft) {
  EmulatedUsbDisplay device;
  device.plug();
  auto display = openDisplay("usb:1209:4c46?timeout_ms=300");
  EXPECT_FALSE(device.state().showing);
  EXPECT_EQ(device.state().brightness, device.config().brightnessMax);
  display->setBrightness(7);
  ASSERT_EQ(display->show(randomPanel(display->info(), 30)).status, PresentStatus::Presented);
  display->close();
  EXPECT_FALSE(device.state().showing);
  EXPECT_EQ(device.state().brightness, 7);

  display->open();
  ASSERT_EQ(display->show(randomPanel(display->info(), 31)).status, PresentStatus::Presented);
  device.setSilent(true);
  display->close();  // its BLANK times out: the device still shows the frame
  device.setSilent(false);
  EXPECT_TRUE(device.state().showing);
  display->open();
  EXPECT_FALSE(device.state().showing);
  EXPECT_EQ(device.state().brightness, device.config().brightnessMax);
  const DisplayStatus status = display->status();
  EXPECT_FALSE(status.showing);
  EXPECT_EQ(status.brightness, device.config().brightnessMax);
  EXPECT_EQ(status.stallsCleared, 0u);
}

TEST_F(UsbDisplayTest, CrcMismatchIsARejectedFrame) {
  EmulatedUsbDisplay device;
  device.plug();
  auto display = openDisplay("usb:1209:4c46");
  const cv::Mat first = randomPanel(display->info(), 1), second = randomPanel(display->info(), 2);
  ASSERT_EQ(display->show(first).status, PresentStatus::Presented);
  device.corruptNextFrame();
  const PresentResult result = display->show(second);
  EXPECT_EQ(result.status, PresentStatus::Rejected);
  EXPECT_NE(result.message.find("usb:1209:4c46"), std::string::npos) << result.message;
  EXPECT_NE(result.message.find("PRESENT of frame 2"), std::string::npos) << result.message;
  EXPECT_NE(result.message.find("payload CRC mismatch"), std::string::npos) << result.message;
  EXPECT_TRUE(sameBytes(device.presented(), first));  // the panel keeps the last good frame
  const DisplayStatus status = display->status();
  EXPECT_EQ(status.framesRejected, 1u);
  EXPECT_NE(status.lastError.find("payload CRC mismatch"), std::string::npos) << status.lastError;
  EXPECT_EQ(display->show(second).status, PresentStatus::Presented);  // and the next one goes through
  EXPECT_TRUE(sameBytes(device.presented(), second));
}

TEST_F(UsbDisplayTest, TruncatedFrameIsARejectedFrame) {
  EmulatedUsbDisplay device;
  device.plug();
  auto display = openDisplay("usb:1209:4c46");
  const DisplayInfo info = display->info();
  device.truncateNextFrame(100);
  const PresentResult result = display->show(randomPanel(info, 3));
  EXPECT_EQ(result.status, PresentStatus::Rejected);
  EXPECT_NE(result.message.find("truncated frame"), std::string::npos) << result.message;
  const std::size_t full = 32 + static_cast<std::size_t>(info.panelWidth_px) * info.panelHeight_px * 3;
  EXPECT_NE(result.message.find(fmt::format("received {} of {} bytes", full - 100, full)), std::string::npos)
      << result.message;
  EXPECT_EQ(display->show(randomPanel(info, 4)).status, PresentStatus::Presented);
}

// A status that contradicts what the host did, or the device's own
// description, is an error naming the field; a rejection the device gives no
// reason for says so (never "no error" as the reason).
TEST_F(UsbDisplayTest, AStatusOrARejectionThatContradictsTheHostIsAnError) {
  EmulatedUsbDisplay device;
  device.plug();
  auto display = openDisplay("usb:1209:4c46");
  const DisplayInfo info = display->info();
  ASSERT_EQ(display->show(randomPanel(info, 5)).status, PresentStatus::Presented);  // frame 1
  EXPECT_NO_THROW(display->status());
  device.lieInStatus(-1, 7);
  EXPECT_TRUE(
      throwsError([&] { display->status(); }, Errc::Device,
                  {"usb:1209:4c46", "GET_STATUS says it shows frame 7", "last frame this host presented is 1"}));
  device.lieInStatus(info.brightnessMax + 1, -1);
  EXPECT_TRUE(throwsError([&] { display->status(); }, Errc::Device,
                          {"usb:1209:4c46", fmt::format("brightness {}", info.brightnessMax + 1)}));
  device.lieInStatus(-1, -1);
  EXPECT_NO_THROW(display->status());
  display->blank();
  EXPECT_NO_THROW(display->status());  // blank: no frame to hold the device to
  ASSERT_EQ(display->show(randomPanel(info, 7)).status, PresentStatus::Presented);  // frame 2
  EXPECT_EQ(display->status().presentedSequence, 2u);

  device.forgetErrors(true);
  device.corruptNextFrame();
  const PresentResult result = display->show(randomPanel(info, 6));  // frame 3
  EXPECT_EQ(result.status, PresentStatus::Rejected);
  EXPECT_NE(result.message.find("PRESENT of frame 3 refused by the device: the device gives no reason for it"),
            std::string::npos)
      << result.message;
}

}  // namespace
}  // namespace lfi
