// SPDX-License-Identifier: Apache-2.0
// The `usb:` display backend recovering from the emulated device's faults (emulated_usb_display.h):
// stalls, short transfers, timeouts, failed CLEAR_HALTs and a device that vanishes and comes back.
// Runs under umockdev's preload library (CTest starts it through tests/drivers/run_with_umockdev.sh).

#include "lfi_test_support.h"
#include "usb_display_fixture.h"

#include "lfi/drivers/display.h"
#include "lfi/drivers/display_registry.h"
#include "lfi/drivers/usb/usb_display.h"

#include <gtest/gtest.h>

#include <cerrno>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <random>
#include <string>
#include <vector>

namespace lfi {
namespace {

using emulation::EmulatedUsbDisplay;
using testing_support::throwsError;
using testing_support::UsbDisplayTest;
using Clock = std::chrono::steady_clock;

TEST_F(UsbDisplayTest, StallIsClearedAndTheFrameResent) {
  EmulatedUsbDisplay device;
  device.plug();
  auto display = openDisplay("usb:1209:4c46");
  const cv::Mat panel = randomPanel(display->info(), 5);
  const std::uint32_t halts = device.state().clearHalts;  // one at open
  device.stallNextFrame();
  const PresentResult result = display->show(panel);
  ASSERT_EQ(result.status, PresentStatus::Presented) << result.message;
  EXPECT_TRUE(sameBytes(device.presented(), panel));
  EXPECT_EQ(device.state().clearHalts, halts + 1);
  EXPECT_EQ(display->status().stallsCleared, 1u);

  device.stallAlways(true);
  EXPECT_TRUE(throwsError([&] { display->show(panel); }, Errc::Device,
                          {"usb:1209:4c46", "endpoint 0x01 stalled again", "frame 2"}));
  device.stallAlways(false);
  EXPECT_EQ(display->show(panel).status, PresentStatus::Presented);
}

// A stall on a later transfer of a frame: the device's CLEAR_HALT drops the
// part it took, so the host must send the whole frame again, not the rest.
TEST_F(UsbDisplayTest, AStallOnALaterTransferIsClearedAndTheWholeFrameResent) {
  EmulatedUsbDisplay device;
  device.plug();
  UsbDisplayOptions options;
  options.transferSize_bytes = 64 * 1024;  // 13 transfers for the 640 x 400 RGB panel
  const UsbDisplaySelector selector{usbdisplay::kDefaultVendorId, usbdisplay::kDefaultProductId, ""};
  auto display = openUsbDisplay(selector, options);
  const cv::Mat panel = randomPanel(display->info(), 21);
  const std::uint32_t halts = device.state().clearHalts;
  device.stallNextFrame(5);
  const PresentResult result = display->show(panel);
  ASSERT_EQ(result.status, PresentStatus::Presented) << result.message;
  EXPECT_TRUE(sameBytes(device.presented(), panel));
  EXPECT_EQ(device.state().clearHalts, halts + 1);
  EXPECT_EQ(display->status().stallsCleared, 1u);
}

// A transfer the device acknowledged with fewer bytes than it was given
// leaves a hole in the frame: the frame is an error, never PRESENTed, and
// the next one (after a CLEAR_HALT that drops the rest) arrives whole.
TEST_F(UsbDisplayTest, ATransferTheDeviceTookOnlyPartOfIsAnErrorAndTheNextFrameIsWhole) {
  EmulatedUsbDisplay device;
  device.plug();
  UsbDisplayOptions options;
  options.transferSize_bytes = 64 * 1024;
  const UsbDisplaySelector selector{usbdisplay::kDefaultVendorId, usbdisplay::kDefaultProductId, ""};
  auto display = openUsbDisplay(selector, options);
  const cv::Mat first = randomPanel(display->info(), 22), second = randomPanel(display->info(), 23);
  device.shortenNextFrame(2, 100);
  EXPECT_TRUE(
      throwsError([&] { display->show(first); }, Errc::Device, {"usb:1209:4c46", "bulk OUT of frame 1", "failed"}));
  EXPECT_EQ(device.state().framesPresented, 0u);
  EXPECT_EQ(device.state().framesRejected, 0u);  // (nothing PRESENTed, so nothing refused)
  expectPresentedAfterOneClearHalt(device, *display, second);
}

// The device vanishes at each request the host sends, at open and after: each
// is an error naming the device and the request, the display is closed, and
// it opens again once the device is back.
TEST_F(UsbDisplayTest, ADeviceThatVanishesAtAnyRequestIsNamedAndOpensAgainWhenBack) {
  using usbdisplay::Request;
  struct Case {
    Request request;
    bool atOpen;
    std::function<void(Display&, const cv::Mat&)> act;
  };
  const std::vector<Case> cases = {
      {Request::GetProtocolVersion, true, {}},
      {Request::GetDeviceInfo, true, {}},
      {Request::GetCalibration, true, {}},
      {Request::Blank, true, {}},
      {Request::SetBrightness, true, {}},
      {Request::SetBrightness, false, [](Display& d, const cv::Mat&) { d.setBrightness(7); }},
      {Request::Present, false, [](Display& d, const cv::Mat& panel) { d.show(panel); }},
      {Request::GetStatus, false, [](Display& d, const cv::Mat&) { d.status(); }},
      {Request::Blank, false, [](Display& d, const cv::Mat&) { d.blank(); }},
  };
  for (const Case& c : cases) {
    const std::string name = usbdisplay::toString(c.request);
    SCOPED_TRACE(name);
    EmulatedUsbDisplay device;
    device.plug();
    auto display = openDisplay("usb:1209:4c46");
    const cv::Mat panel = randomPanel(display->info(), 24);
    if (c.atOpen) display->close();
    device.unplugAtRequest(c.request);
    EXPECT_TRUE(throwsError([&] { c.atOpen ? display->open() : c.act(*display, panel); }, Errc::Device,
                            {"usb:1209:4c46", "vanished during " + name}));
    EXPECT_EQ(display->state(), Display::State::Closed);
    device.unplug();
    device.plug();
    display->open();
    const cv::Mat again = randomPanel(display->info(), 25);
    const PresentResult result = display->show(again);
    ASSERT_EQ(result.status, PresentStatus::Presented) << result.message;
    EXPECT_TRUE(sameBytes(device.presented(), again));
  }
  // And while it reads the reason for a refused frame.
  EmulatedUsbDisplay device;
  device.plug();
  auto display = openDisplay("usb:1209:4c46");
  device.corruptNextFrame();
  device.unplugAtRequest(Request::GetLastError);
  EXPECT_TRUE(throwsError([&] { display->show(randomPanel(display->info(), 26)); }, Errc::Device,
                          {"usb:1209:4c46", "vanished during GET_LAST_ERROR"}));
  EXPECT_EQ(display->state(), Display::State::Closed);
}

// The timeout of the tests below whose device falls silent: only a silent device reaches it, and no
// transfer of a device that answers comes near it on a loaded host (each is one URB through umockdev).
constexpr std::chrono::milliseconds kTimeout{2000};

TEST_F(UsbDisplayTest, ADeviceThatNeverAnswersTimesOut) {
  EmulatedUsbDisplay device;
  device.plug();
  device.setSilent(true);
  auto start = Clock::now();
  EXPECT_TRUE(throwsError([] { openDisplay("usb:1209:4c46?timeout_ms=2000"); }, Errc::Timeout,
                          {"usb:1209:4c46", "timed out after 2000 ms"}));
  std::printf("[ info     ] timed out after %.3f s\n", std::chrono::duration<double>(Clock::now() - start).count());

  device.setSilent(false);
  auto display = openDisplay("usb:1209:4c46?timeout_ms=2000");
  const cv::Mat panel = randomPanel(display->info(), 9);
  device.setSilent(true);
  start = Clock::now();
  const PresentResult result = display->show(panel);
  EXPECT_EQ(result.status, PresentStatus::Timeout);
  EXPECT_NE(result.message.find("timed out"), std::string::npos) << result.message;
  std::printf("[ info     ] timed out after %.3f s\n", std::chrono::duration<double>(Clock::now() - start).count());
  EXPECT_TRUE(throwsError([&] { display->status(); }, Errc::Timeout, {"GET_STATUS timed out"}));
  device.setSilent(false);
  EXPECT_EQ(display->show(panel).status, PresentStatus::Presented);
  EXPECT_TRUE(sameBytes(device.presented(), panel));
}

// A device that stops answering keeps the bytes of the frame it was taking
// until PRESENT or CLEAR_HALT resets it: the next frame must not be appended
// to them (it would overflow and be refused), whether the device fell silent
// mid-frame or at PRESENT.
TEST_F(UsbDisplayTest, AFrameAfterATimeoutIsPresented) {
  EmulatedUsbDisplay device;
  device.plug();
  UsbDisplayOptions options;
  options.transferSize_bytes = 64 * 1024;  // several transfers per frame
  options.transferTimeout = options.controlTimeout = kTimeout;
  const UsbDisplaySelector selector{usbdisplay::kDefaultVendorId, usbdisplay::kDefaultProductId, ""};
  auto display = openUsbDisplay(selector, options);
  const cv::Mat first = randomPanel(display->info(), 12), second = randomPanel(display->info(), 13);
  device.silentAfterBulkUrbs(2);
  const PresentResult result = display->show(first);
  EXPECT_EQ(result.status, PresentStatus::Timeout);
  EXPECT_NE(result.message.find("timed out"), std::string::npos) << result.message;
  device.setSilent(false);
  std::uint32_t halts = device.state().clearHalts;
  PresentResult next = display->show(second);
  EXPECT_EQ(next.status, PresentStatus::Presented) << next.message;
  EXPECT_TRUE(sameBytes(device.presented(), second));
  EXPECT_EQ(device.state().clearHalts, halts + 1);

  device.silentAtNextPresent();
  EXPECT_TRUE(throwsError([&] { display->show(first); }, Errc::Timeout, {"PRESENT timed out"}));
  device.setSilent(false);
  halts = device.state().clearHalts;
  next = display->show(first);
  EXPECT_EQ(next.status, PresentStatus::Presented) << next.message;
  EXPECT_TRUE(sameBytes(device.presented(), first));
  EXPECT_EQ(device.state().clearHalts, halts + 1);
}

// A device that does not take the CLEAR_HALT meant to discard a failed frame
// (Linux reports the kernel's timeout as LIBUSB_ERROR_OTHER): that frame is a
// Timeout, and the next one clears the halt again before it is sent.
TEST_F(UsbDisplayTest, AFailedClearHaltIsTriedAgainBeforeTheNextFrame) {
  EmulatedUsbDisplay device;
  device.plug();
  UsbDisplayOptions options;
  options.transferSize_bytes = 64 * 1024;
  options.transferTimeout = options.controlTimeout = kTimeout;
  const UsbDisplaySelector selector{usbdisplay::kDefaultVendorId, usbdisplay::kDefaultProductId, ""};
  auto display = openUsbDisplay(selector, options);
  const cv::Mat first = randomPanel(display->info(), 14), second = randomPanel(display->info(), 15);
  device.silentAfterBulkUrbs(2);
  EXPECT_EQ(display->show(first).status, PresentStatus::Timeout);
  device.setSilent(false);
  device.failClearHalt(ETIMEDOUT);
  const PresentResult refused = display->show(second);
  EXPECT_EQ(refused.status, PresentStatus::Timeout);
  EXPECT_NE(refused.message.find("CLEAR_HALT"), std::string::npos) << refused.message;
  EXPECT_NE(refused.message.find("LIBUSB_ERROR_OTHER"), std::string::npos) << refused.message;
  device.failClearHalt(0);
  expectPresentedAfterOneClearHalt(device, *display, second);
}

// The same when the host that left part of a frame is gone (a crashed
// process): the next host's first frame is presented.
TEST_F(UsbDisplayTest, AFrameAfterAnotherHostLeftPartOfOneIsPresented) {
  EmulatedUsbDisplay device;
  device.plug();
  UsbDisplayOptions options;
  options.transferSize_bytes = 64 * 1024;
  options.transferTimeout = kTimeout;
  const UsbDisplaySelector selector{usbdisplay::kDefaultVendorId, usbdisplay::kDefaultProductId, ""};
  auto first = openUsbDisplay(selector, options);
  const cv::Mat panel = randomPanel(first->info(), 14);
  device.silentAfterBulkUrbs(2);
  EXPECT_EQ(first->show(panel).status, PresentStatus::Timeout);
  first.reset();
  device.setSilent(false);
  auto second = openUsbDisplay(selector, options);
  const PresentResult result = second->show(panel);
  EXPECT_EQ(result.status, PresentStatus::Presented) << result.message;
  EXPECT_TRUE(sameBytes(device.presented(), panel));
}

TEST_F(UsbDisplayTest, UnplugMidTransferThenReplug) {
  EmulatedUsbDisplay device;
  device.plug();
  UsbDisplayOptions options;
  options.transferSize_bytes = 64 * 1024;  // several transfers per frame
  const UsbDisplaySelector selector{usbdisplay::kDefaultVendorId, usbdisplay::kDefaultProductId, ""};
  auto display = openUsbDisplay(selector, options);
  const cv::Mat panel = randomPanel(display->info(), 11);
  device.unplugDuringNextFrame();
  EXPECT_TRUE(throwsError([&] { display->show(panel); }, Errc::Device,
                          {"usb:1209:4c46", "vanished during bulk OUT of frame 1"}));
  EXPECT_EQ(display->state(), Display::State::Closed);
  device.unplug();
  EXPECT_TRUE(throwsError([&] { display->open(); }, Errc::NotFound, {"usb:1209:4c46"}));
  device.plug();
  display->open();
  const PresentResult result = display->show(panel);
  ASSERT_EQ(result.status, PresentStatus::Presented) << result.message;
  EXPECT_TRUE(sameBytes(device.presented(), panel));
}

// 100 uploads, each cut by the device vanishing at a random point of it (at any of the frame's bulk URBs, or at
// its PRESENT): each is a Device error naming the display that leaves it closed, and once the device is plugged
// in again the next upload is presented whole. (A hang would be the test's timeout.)
TEST_F(UsbDisplayTest, AnUploadCutAtARandomPointIsAnErrorAHundredTimesAndTheNextOneArrives) {
  EmulatedUsbDisplay device;
  device.plug();
  UsbDisplayOptions options;
  options.transferSize_bytes = 64 * 1024;
  const UsbDisplaySelector selector{usbdisplay::kDefaultVendorId, usbdisplay::kDefaultProductId, ""};
  auto display = openUsbDisplay(selector, options);
  const cv::Mat panel = randomPanel(display->info(), 13);
  const std::size_t frameBytes = usbdisplay::kFrameHeaderSize + panel.total() * panel.elemSize();
  const int urbs = static_cast<int>((frameBytes + options.transferSize_bytes - 1) / options.transferSize_bytes);
  std::mt19937 random(20261128);
  std::uniform_int_distribution<int> point(0, urbs);  // urbs: at PRESENT
  int atPresent = 0;
  for (int upload = 0; upload < 100; ++upload) {
    SCOPED_TRACE(upload);
    const int at = point(random);
    if (at < urbs) {
      device.unplugAfterBulkUrbs(at);
    } else {
      device.unplugAtRequest(usbdisplay::Request::Present);
      ++atPresent;
    }
    EXPECT_TRUE(throwsError([&] { display->show(panel); }, Errc::Device, {"usb:1209:4c46", "vanished"}));
    EXPECT_EQ(display->state(), Display::State::Closed);
    device.unplug();
    device.plug();
    display->open();
    const PresentResult result = display->show(panel);
    ASSERT_EQ(result.status, PresentStatus::Presented) << result.message;
    EXPECT_TRUE(sameBytes(device.presented(), panel));
  }
  std::printf("[ info     ] 100 uploads of %d bulk URBs cut, %d of them at PRESENT\n", urbs, atPresent);
}

TEST_F(UsbDisplayTest, UnplugWhileIdle) {
  EmulatedUsbDisplay device;
  device.plug();
  auto display = openDisplay("usb:1209:4c46");
  device.unplug();
  EXPECT_TRUE(throwsError([&] { display->setBrightness(3); }, Errc::Device, {"vanished during SET_BRIGHTNESS"}));
  EXPECT_EQ(display->state(), Display::State::Closed);
  device.plug();
  display->open();
  EXPECT_EQ(display->state(), Display::State::Open);
}

}  // namespace
}  // namespace lfi
