// SPDX-License-Identifier: Apache-2.0
// The coded reference capture (coded:) on the ray-traced bench: the study's
// lens over a full-parallax lenslet display, seen by the telecentric camera
// with its noise on. What it measures is checked against what the camera
// sees, and every refusal against a bench that gives it.

#include "lfi/controller/coded_capture.h"
#include "lfi/controller/controller.h"
#include "lfi/core/error.h"
#include "lfi/drivers/camera_registry.h"
#include "lfi/drivers/capture_registry.h"
#include "lfi/drivers/display_optics.h"
#include "lfi/drivers/display_registry.h"
#include "lfi/sim/devices/sim_camera.h"

#include "lfi_test_support.h"
#include "scene_text.h"
#include "test_folder.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

namespace {

using namespace lfi;
using lfi::testing_support::cameraSceneText;
using lfi::testing_support::lensObject;
using lfi::testing_support::TestFolder;
using lfi::testing_support::throwsError;

// data/scenes/inspection_bench.toml: the lens 30 mm above an 800 x 800 lenslet display (1 mm lenses over
// 0.0315 mm pixels, RGB stripes), a 56 x 56 Mono12 camera of 0.5 mm object pixels.
struct SceneOptions {
  double displayX_mm = 0;
  bool lens = true;
};

std::string sceneText(const SceneOptions& o) {
  std::string text = cameraSceneText({.samplesPerPixel = 8,
                                      .seed = 5,
                                      .focalLength_mm = 20.03,
                                      .imageDistance_mm = 24.9075,
                                      .stopDiameter_mm = 0.609,
                                      .pixelPitch_mm = 0.1215,
                                      .width_px = 56,
                                      .height_px = 56,
                                      .positionZ_mm = 102.5,
                                      .fullWell_e = 10500,
                                      .readNoise_e = 2.4,
                                      .bitDepth = 12}) +
                     fmt::format(
                         "[display]\nposition_mm = [{}, 0, -30]\noptics = \"lenslet_array\"\npanel_width_px = 800\n"
                         "panel_height_px = 800\n",
                         o.displayX_mm);
  if (o.lens) text += lensObject({.radius_mm = 51.5, .centreThickness_mm = 5, .diameter_mm = 25.4, .ior = 1.5168});
  return text;
}

// A display that refuses its n-th frame, as a device that fails a CRC does, and passes everything else on.
class RefusingDisplay final : public Display {
 public:
  RefusingDisplay(Display& inner, int refuse) : inner_(inner), refuse_(refuse) {}
  State state() const override { return inner_.state(); }
  std::string name() const override { return inner_.name(); }
  void open() override { inner_.open(); }
  void close() noexcept override { inner_.close(); }
  DisplayInfo info() const override { return inner_.info(); }
  PresentResult show(const cv::Mat& panel) override {
    if (++shown_ == refuse_) return {PresentStatus::Rejected, 0, "frame CRC mismatch"};
    return inner_.show(panel);
  }
  void blank() override { inner_.blank(); }
  void setBrightness(int level) override { inner_.setBrightness(level); }
  DisplayStatus status() override { return inner_.status(); }

 private:
  Display& inner_;
  int refuse_;
  int shown_ = 0;
};

class CodedCaptureTest : public testing::Test {
 protected:
  void SetUp() override {
    sim::registerSimBackends();
    registerControllerBackends();
  }

  struct Bench {
    std::unique_ptr<Display> display;
    std::unique_ptr<Camera> camera;
  };
  Bench bench(const SceneOptions& options, double exposure_us = 10000) {
    const std::string uri = "sim:" + dir_.write("scene.toml", sceneText(options)).string();
    Bench b{openDisplay(uri), openCamera(uri)};
    CameraSettings settings;
    settings.exposure_us = exposure_us;
    settings.pixelFormat = PixelFormat::Mono12;
    settings.trigger = TriggerMode::Software;
    b.camera->configure(settings);
    return b;
  }

  // The panel pixels that an independent trace of the bench's light transport lights: the reference of the
  // simulated light field sensor (sim:) on the bench's scene, encoded onto the display's panel as emit() shows it, any
  // subpixel lit, grown by a pixel.
  cv::Mat tracedSupport(Bench& b) {
    auto sensor = openLightFieldCapture("sim:" + (dir_.path() / "scene.toml").string());
    sensor->setDistance(30);
    Controller traced(*sensor, *b.display, *b.camera);
    const LightField lightField = traced.captureReference();
    const cv::Mat panel =
        encodeLightField(lightField, DisplayOptics(b.display->info()), Controller::defaultWhite(lightField));
    std::vector<cv::Mat> subpixels;
    cv::split(panel, subpixels);
    cv::Mat any = cv::Mat::zeros(panel.size(), CV_8UC1);
    for (const cv::Mat& s : subpixels) any = cv::max(any, s);
    cv::Mat support;
    cv::dilate(any > 0, support, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(3, 3)));
    return support;
  }

  TestFolder dir_{"lfi-coded-capture"};
};

TEST_F(CodedCaptureTest, ItFindsTheLightThatReachesTheCameraThroughThePart) {
  Bench b = bench({});
  auto capture = openLightFieldCapture("coded:");
  capture->setDistance(30);
  ASSERT_TRUE(capture->measuresThroughBench());
  Controller controller(*capture, *b.display, *b.camera);
  const LightField lightField = controller.captureReference();
  const auto& report = dynamic_cast<CodedCapture&>(*capture).report();
  const cv::Mat& panel = controller.referencePanel();

  // Frames: white and black, then per round 2·⌈log2 800⌉ + 2·⌈log2 800⌉ = 40 patterns and the all-white panel
  // less the pixels found, which measures the light left.
  ASSERT_GE(report.rounds, 1);
  EXPECT_EQ(report.patternFrames, 2 + 41 * report.rounds);
  EXPECT_GE(report.refineFrames, 1);
  EXPECT_GT(report.decoded, report.lit / 2) << "min_decoded";
  EXPECT_TRUE(report.lightLeft <= 0.02 || report.rounds == 3) << report.lightLeft;

  // The reference: drive levels in [0, 1] on few of the panel's pixels (the camera's stop passes about one
  // direction per lens).
  ASSERT_EQ(panel.type(), CV_32FC1);
  ASSERT_EQ(panel.size(), cv::Size(800, 800));
  double lo = 0, hi = 0;
  cv::minMaxLoc(panel, &lo, &hi);
  EXPECT_GE(lo, 0);
  EXPECT_LE(hi, 1);
  EXPECT_EQ(cv::countNonZero(panel), report.panelPixelsLit);
  EXPECT_LT(report.panelPixelsLit, 0.02 * panel.total());

  // It chose the panel pixels the light takes. An independent trace of the intact part's light transport,
  // the simulated light field sensor's reference (sim: on the same scene) encoded onto the panel, lights
  // the pixels whose rays reach the camera's stop, with a margin of a pixel (the encoding samples a lens's
  // directions on its own grid). The found pixels inside that support must give the camera the support's
  // light less what the capture may leave unfound (max_light_left); pixels chosen wrongly (elsewhere, or the
  // brightest left out) take that light away. Shares are means over the lit camera pixels (> 1500) against
  // the all-white panel's: shot noise of 2500 DN at 0.39 DN per electron is 31 DN a pixel and frame,
  // 0.8 DN in such a mean, about 1.1 DN in the difference of two; 5 DN is 4.5 σ.
  const cv::Mat found = panel > 0;
  const auto image = [&](const cv::Mat& levels) {
    controller.showPanel(levels);
    return controller.inspect();
  };
  const cv::Mat white = image(cv::Mat(800, 800, CV_8UC1, cv::Scalar(255))),
                black = image(cv::Mat::zeros(800, 800, CV_8UC1));
  const cv::Mat lit = (white - black) > 0.5 * (cv::mean(white - black)[0]);
  const double all = cv::mean(white - black, lit)[0];
  ASSERT_GT(all, 1000);
  const auto share = [&](const cv::Mat& levels) { return cv::mean(image(levels) - black, lit)[0] / all; };
  const cv::Mat support = tracedSupport(b);
  const double traced = share(support), foundInside = share(found & support);
  std::printf("[ info     ] light share: traced support %.4f (%d pixels), found %.4f (%d), found inside %.4f\n", traced,
              cv::countNonZero(support), share(found), cv::countNonZero(found), foundInside);
  EXPECT_GT(traced, 0.9) << "the trace's support gives the camera the part's light";
  EXPECT_GE(foundInside, traced - CodedCaptureSettings{}.maxLightLeft - 5.0 / all);

  // The reference as a light field: the display's optics' grid (1 mm lenses, 87 directions: 2 · 1.37 mm gap /
  // 0.0315 mm pixels, rounded up), 26 lenses across the 25.2 mm panel, Δ as the URI states it.
  const LightFieldGeometry g = lightField.geometry();
  EXPECT_EQ(g, codedLightFieldGeometry(b.display->info(), 30));
  EXPECT_EQ(g.angular, 87);
  EXPECT_EQ(g.spatialX, 26);
  EXPECT_DOUBLE_EQ(g.elementPitch_mm(), 1.0);
  EXPECT_EQ(g.distance_mm, 30);
  EXPECT_GT(cv::countNonZero(lightField.lensletImage()), 0);
}

TEST_F(CodedCaptureTest, ADisplayOutOfTheCamerasViewIsRefusedAfterTwoFrames) {
  Bench b = bench({.displayX_mm = 200});
  auto capture = openLightFieldCapture("coded:");
  Controller controller(*capture, *b.display, *b.camera);
  EXPECT_TRUE(throwsError([&] { controller.captureReference(); }, Errc::Device,
                          {"no change between the all-white and the all-black panel", "not in the camera's view"}));
}

TEST_F(CodedCaptureTest, ACameraThatSaturatesIsRefused) {
  Bench b = bench({}, 40000);  // four times the exposure that puts the part at 2500 of 4095 DN
  auto capture = openLightFieldCapture("coded:");
  Controller controller(*capture, *b.display, *b.camera);
  EXPECT_TRUE(throwsError([&] { controller.captureReference(); }, Errc::Device,
                          {"full scale (4095 DN)", "lower the exposure"}));
}

TEST_F(CodedCaptureTest, AMissingPartIsRefused) {
  // Through air the telecentric camera sees each lens's axial view only.
  Bench b = bench({.lens = false});
  auto capture = openLightFieldCapture("coded:");
  Controller controller(*capture, *b.display, *b.camera);
  EXPECT_TRUE(throwsError([&] { controller.captureReference(); }, Errc::Device,
                          {"nothing deflects them", "part missing", "allow_undeflected=1"}));
  // ... and accepted when the bench says a part that deflects nothing is meant.
  auto flat = openLightFieldCapture("coded:?allow_undeflected=1");
  Controller accepting(*flat, *b.display, *b.camera);
  EXPECT_NO_THROW(accepting.captureReference());
  EXPECT_FALSE(accepting.referencePanel().empty());
}

TEST_F(CodedCaptureTest, TooFewDecodedPixelsAreRefusedNamingTheThreshold) {
  // The bench decodes about three quarters of its lit pixels in the first round (the rest see more than two
  // panel columns or rows each): asking for all of them refuses it.
  Bench b = bench({});
  auto capture = openLightFieldCapture("coded:?min_decoded=1");
  Controller controller(*capture, *b.display, *b.camera);
  EXPECT_TRUE(throwsError([&] { controller.captureReference(); }, Errc::Device, {"fewer than min_decoded = 1"}));
}

TEST_F(CodedCaptureTest, AFrameTheDisplayRefusesIsNamed) {
  Bench b = bench({});
  RefusingDisplay refusing(*b.display, 5);  // white, black, then the third pattern
  auto capture = openLightFieldCapture("coded:");
  Controller controller(*capture, refusing, *b.camera);
  EXPECT_TRUE(throwsError([&] { controller.captureReference(); }, Errc::Device,
                          {"frame 5 (pattern)", "did not show the panel image", "frame CRC mismatch"}));
  EXPECT_TRUE(controller.referencePanel().empty());
}

TEST_F(CodedCaptureTest, ItNeedsTheBenchAndValidSettings) {
  auto capture = openLightFieldCapture("coded:");
  EXPECT_TRUE(throwsError([&] { capture->capture(); }, Errc::InvalidArgument, {"no bench"}));
  EXPECT_TRUE(
      throwsError([&] { openLightFieldCapture("coded:?rounds=0"); }, Errc::Config, {"rounds = '0'", "1 .. 16"}));
  EXPECT_TRUE(throwsError([&] { openLightFieldCapture("coded:?target_cv=x"); }, Errc::Config, {"target_cv = 'x'"}));
  EXPECT_TRUE(throwsError([&] { openLightFieldCapture("coded:?frames=3"); }, Errc::Config, {"frames"}));
  EXPECT_TRUE(throwsError([&] { openLightFieldCapture("coded:bench.toml"); }, Errc::Config, {"takes no path"}));
  EXPECT_TRUE(throwsError([&] { CodedCapture({.targetCv = 0}); }, Errc::InvalidArgument, {"target_cv"}));
}

}  // namespace
