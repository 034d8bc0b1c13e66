// SPDX-License-Identifier: Apache-2.0
// The window: display against a real X server (Xvfb, started here): what the
// server's framebuffer holds after each present is the panel image in the
// output's layout, pixel for pixel; a mode or an output that is not there is
// refused by name; a server that goes away is a Device error, and a display
// opened again on a new server shows again.
#include "lfi/drivers/window/window_display.h"
#include "lfi/core/error.h"
#include "lfi/drivers/builtin_backends.h"
#include "lfi/drivers/display_registry.h"
#include "lfi/emulation/xvfb_screen.h"

#include "lfi_test_support.h"

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <cstdlib>
#include <memory>
#include <optional>
#include <string>

namespace {

using lfi::Errc;
using lfi::emulation::XvfbScreen;
using lfi::testing_support::throwsError;

class WindowDisplayTest : public ::testing::Test {
 protected:
  void SetUp() override {
    lfi::registerDriverBackends();
    server_ = start(800, 800);
  }
  void TearDown() override { ::unsetenv("DISPLAY"); }
  // A server of its own for this test, the one the presenters it starts talk to.
  static std::unique_ptr<XvfbScreen> start(int width, int height) {
    try {
      auto server = std::make_unique<XvfbScreen>(width, height);
      ::setenv("DISPLAY", server->display().c_str(), 1);
      return server;
    } catch (const lfi::Error& e) {
      ADD_FAILURE() << e.what();
      return nullptr;
    }
  }
  // A panel image of uniform noise: every level in every subpixel, none related to its neighbour.
  static cv::Mat noise(int width, int height, int type, int seed) {
    cv::Mat m(height, width, type);
    cv::RNG rng(static_cast<std::uint64_t>(seed));
    rng.fill(m, cv::RNG::UNIFORM, 0, 256);
    return m;
  }
  // The pixels of `a` and `b` that differ, for a message.
  static int differing(const cv::Mat& a, const cv::Mat& b) {
    if (a.size() != b.size() || a.type() != b.type()) return -1;
    cv::Mat diff;
    cv::absdiff(a.reshape(1), b.reshape(1), diff);
    return cv::countNonZero(diff);
  }

  std::unique_ptr<XvfbScreen> server_;
};

TEST_F(WindowDisplayTest, TheServersOutputIsListedWithItsMode) {
  ASSERT_TRUE(server_);
  const std::vector<lfi::WindowOutput> outputs = lfi::listWindowOutputs();
  ASSERT_EQ(outputs.size(), 1u);
  EXPECT_EQ(outputs[0].index, 0);
  EXPECT_EQ(outputs[0].width_px, 800);
  EXPECT_EQ(outputs[0].height_px, 800);
  EXPECT_EQ(outputs[0].driver, "x11");
  EXPECT_EQ(outputs[0].uri(), "window:0");
}

TEST_F(WindowDisplayTest, EveryFramePresentedIsTheServersFramebufferPixelForPixel) {
  ASSERT_TRUE(server_);
  auto display = lfi::openDisplay("window:0?pitch_mm=0.1&mode=800x800");
  const lfi::DisplayInfo info = display->info();
  EXPECT_EQ(info.panelWidth_px, 800);
  EXPECT_EQ(info.panelHeight_px, 800);
  EXPECT_EQ(info.subpixels, lfi::SubpixelLayout::RgbStripe);
  EXPECT_FALSE(info.opticsStated);
  for (int frame = 0; frame < 4; ++frame) {
    const cv::Mat panel = noise(800, 800, CV_8UC3, frame);
    const lfi::PresentResult r = display->show(panel);
    ASSERT_EQ(r.status, lfi::PresentStatus::Presented) << r.message;
    EXPECT_EQ(differing(server_->screen(), panel), 0) << "frame " << frame;
  }
  EXPECT_EQ(display->status().framesPresented, 4u);
  display->blank();
  EXPECT_EQ(cv::countNonZero(server_->screen().reshape(1)), 0) << "blank leaves light on the screen";
}

TEST_F(WindowDisplayTest, EachLayoutPutsThePanelsSubpixelsWhereTheOutputShowsThem) {
  ASSERT_TRUE(server_);
  {
    auto display = lfi::openDisplay("window:0?pitch_mm=0.1&layout=bgr");
    const cv::Mat panel = noise(800, 800, CV_8UC3, 11);  // channels left to right: blue, green, red
    display->show(panel);
    cv::Mat expected(800, 800, CV_8UC3);
    cv::mixChannels(panel, expected, {0, 2, 1, 1, 2, 0});
    EXPECT_EQ(differing(server_->screen(), expected), 0) << "bgr";
  }
  {
    auto display = lfi::openDisplay("window:0?pitch_mm=0.1&layout=mono");
    EXPECT_EQ(display->info().subpixels, lfi::SubpixelLayout::Mono);
    const cv::Mat panel = noise(800, 800, CV_8UC1, 12);
    display->show(panel);
    cv::Mat expected;
    cv::merge(std::vector<cv::Mat>{panel, panel, panel}, expected);
    EXPECT_EQ(differing(server_->screen(), expected), 0) << "mono";
  }
  {
    // A resin printer's mono LCD: three panel pixels in each output pixel, left one in red.
    auto display = lfi::openDisplay("window:0?pitch_mm=0.047&layout=mono_subpixels");
    const lfi::DisplayInfo info = display->info();
    EXPECT_EQ(info.panelWidth_px, 2400);
    EXPECT_EQ(info.subpixels, lfi::SubpixelLayout::Mono);
    const cv::Mat panel = noise(2400, 800, CV_8UC1, 13);
    display->show(panel);
    cv::Mat expected(800, 800, CV_8UC3);
    for (int y = 0; y < 800; ++y)
      for (int x = 0; x < 800; ++x)
        expected.at<cv::Vec3b>(y, x) =
            cv::Vec3b(panel.at<uchar>(y, 3 * x), panel.at<uchar>(y, 3 * x + 1), panel.at<uchar>(y, 3 * x + 2));
    EXPECT_EQ(differing(server_->screen(), expected), 0) << "mono_subpixels";
  }
}

TEST_F(WindowDisplayTest, AFourKFrameArrivesWhole) {
  server_.reset();
  server_ = start(3840, 2160);
  ASSERT_TRUE(server_);
  {
    auto display = lfi::openDisplay("window:0?pitch_mm=0.03&mode=3840x2160");
    for (int frame = 0; frame < 2; ++frame) {
      const cv::Mat panel = noise(3840, 2160, CV_8UC3, 20 + frame);
      display->show(panel);
      EXPECT_EQ(differing(server_->screen(), panel), 0) << "frame " << frame;
    }
  }
  // An 11520 x 2160 mono panel in the same mode: its bytes, row by row, are the output's RGB bytes.
  auto display = lfi::openDisplay("window:0?pitch_mm=0.01&mode=3840x2160&layout=mono_subpixels");
  const cv::Mat panel = noise(11520, 2160, CV_8UC1, 22);
  display->show(panel);
  EXPECT_EQ(differing(server_->screen().reshape(1), panel), 0) << "mono_subpixels";
}

TEST_F(WindowDisplayTest, AModeOtherThanThePanelsIsRefusedNamingTheOutputAndBothModes) {
  ASSERT_TRUE(server_);
  EXPECT_TRUE(throwsError([] { lfi::openDisplay("window:0?pitch_mm=0.1&mode=1440x2560"); }, Errc::Config,
                          {"window:0", "800x800", "1440x2560"}));
}

TEST_F(WindowDisplayTest, AnOutputThatIsNotThereIsNotFoundAndTheOutputsAreListed) {
  ASSERT_TRUE(server_);
  EXPECT_TRUE(throwsError([] { lfi::openDisplay("window:HDMI-9?pitch_mm=0.1"); }, Errc::NotFound,
                          {"window:HDMI-9", "no output 'HDMI-9'", "0 '", "800x800"}));
  EXPECT_TRUE(throwsError([] { lfi::openDisplay("window:3?pitch_mm=0.1"); }, Errc::NotFound, {"window:3"}));
}

TEST_F(WindowDisplayTest, AURIWithoutThePitchOrWithABadLayoutOrModeIsRefusedByName) {
  ASSERT_TRUE(server_);
  EXPECT_TRUE(throwsError([] { lfi::openDisplay("window:0"); }, Errc::Config, {"pitch_mm is required"}));
  EXPECT_TRUE(
      throwsError([] { lfi::openDisplay("window:0?pitch_mm=0.1&layout=rgbw"); }, Errc::Config, {"layout 'rgbw'"}));
  EXPECT_TRUE(throwsError([] { lfi::openDisplay("window:0?pitch_mm=0.1&mode=800"); }, Errc::Config, {"mode '800'"}));
}

TEST_F(WindowDisplayTest, AServerKilledMidRunIsADeviceErrorAndTheDisplayOpensOnTheNextServer) {
  ASSERT_TRUE(server_);
  auto display = lfi::openDisplay("window:0?pitch_mm=0.1");
  const cv::Mat panel = noise(800, 800, CV_8UC3, 30);
  display->show(panel);
  EXPECT_TRUE(display->status().showing);
  // Gone while the panel should be showing: the next status says so, before an image relies on it.
  server_->stop(/*kill=*/true);
  EXPECT_TRUE(throwsError([&] { display->status(); }, Errc::Device, {"window:0", "presenter ended"}));
  EXPECT_EQ(display->state(), lfi::Display::State::Closed);
  server_.reset();
  server_ = start(800, 800);
  ASSERT_TRUE(server_);
  display->open();
  display->show(panel);
  EXPECT_EQ(differing(server_->screen(), panel), 0);
  // Gone before a frame: the frame's present says so.
  server_->stop(/*kill=*/true);
  EXPECT_TRUE(throwsError([&] { display->show(panel); }, Errc::Device, {"window:0", "presenter ended"}));
  EXPECT_EQ(display->state(), lfi::Display::State::Closed);
}

TEST_F(WindowDisplayTest, WithNoServerTheDisplayIsNotFound) {
  server_.reset();
  ::unsetenv("DISPLAY");
  EXPECT_TRUE(throwsError([] { lfi::openDisplay("window:0?pitch_mm=0.1"); }, Errc::NotFound, {"window:0", "SDL"}));
}

}  // namespace
