// SPDX-License-Identifier: Apache-2.0
// The controller on the ray-traced bench: capture -> emit -> inspect through
// the same sim: URIs a user would give, and the errors it reports.

#include "lfi/controller/controller.h"
#include "lfi/controller/bench_devices.h"
#include "lfi/controller/bench_file.h"
#include "lfi/core/exr_io.h"
#include "lfi/drivers/builtin_backends.h"
#include "lfi/drivers/camera_registry.h"
#include "lfi/drivers/capture_registry.h"
#include "lfi/drivers/display_registry.h"
#include "lfi/sim/devices/sim_camera.h"

#include "lfi_test_support.h"
#include "scene_text.h"
#include "test_folder.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <thread>

namespace {

using namespace lfi;
using lfi::testing_support::cameraSceneText;
using lfi::testing_support::lensObject;
using lfi::testing_support::TestFolder;
using lfi::testing_support::throwsError;

// The reference lens (N-BK7, R = 51.5 mm, Ø25.4) under a 0.243x telecentric
// camera (object NA 0.0152, 0.5 mm object pixels); a lenticular display of the
// default class 30 mm below the lens, 640 x 400 pixels (48 x 30 mm).
std::string sceneText(bool inclusion) {
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
                     R"([display]
position_mm = [0, 0, -30]
panel_width_px = 640
panel_height_px = 400
)" + lensObject({.radius_mm = 51.5, .centreThickness_mm = 5, .diameter_mm = 25.4, .ior = 1.5168});
  if (inclusion)
    text += R"([[object]]
name = "particle"
shape = "sphere"
radius_mm = 1.5
material = "absorber"
)";
  return text;
}

// A camera that passes everything to another and records the timestamps of
// the complete frames grabbed through it (what the controller averaged) and
// the stream starts; `loseNextFrame` makes the next grab time out without
// taking the frame, which stays in the stream (a frame late beyond the timeout).
class RecordingCamera : public Camera {
 public:
  explicit RecordingCamera(Camera& inner) : inner_(inner) {}
  std::vector<std::int64_t> timestamps_ns;
  int starts = 0;
  bool loseNextFrame = false;

  State state() const override { return inner_.state(); }
  void open() override { inner_.open(); }
  void close() noexcept override { inner_.close(); }
  CameraInfo info() const override { return inner_.info(); }
  void configure(const CameraSettings& settings) override { inner_.configure(settings); }
  CameraSettings settings() const override { return inner_.settings(); }
  void start(int bufferCount) override {
    inner_.start(bufferCount);
    ++starts;
  }
  void stop() override { inner_.stop(); }
  void softwareTrigger() override { inner_.softwareTrigger(); }
  void grabInto(Frame& frame, std::chrono::milliseconds timeout) override {
    if (std::exchange(loseNextFrame, false)) {
      frame.status = FrameStatus::Timeout;
      return;
    }
    inner_.grabInto(frame, timeout);
    if (frame.status == FrameStatus::Complete) timestamps_ns.push_back(frame.timestamp_ns);
  }
  StreamStatistics statistics() const override { return inner_.statistics(); }
  std::string getFeature(const std::string& name) override { return inner_.getFeature(name); }
  void setFeature(const std::string& name, const std::string& value) override { inner_.setFeature(name, value); }
  std::int64_t getIntegerFeature(const std::string& name) override { return inner_.getIntegerFeature(name); }
  void setIntegerFeature(const std::string& name, std::int64_t value) override {
    inner_.setIntegerFeature(name, value);
  }
  double getFloatFeature(const std::string& name) override { return inner_.getFloatFeature(name); }
  void setFloatFeature(const std::string& name, double value) override { inner_.setFloatFeature(name, value); }
  void executeCommand(const std::string& name) override { inner_.executeCommand(name); }

 private:
  Camera& inner_;
};

class ControllerTest : public testing::Test {
 protected:
  void SetUp() override {
    registerDriverBackends();
    sim::registerSimBackends();  // camera, display and light field capture
    dir_.write("intact.toml", sceneText(false));
    dir_.write("particle.toml", sceneText(true));
  }

  std::string uri(const char* scene) const { return "sim:" + (dir_ / scene).string(); }
  std::string captureUri() const { return uri("intact.toml") + "?spatial=16&angular=16&spp=32"; }

  // Mean of the lens's inner 8 mm radius (16 pixels) and of its centre (1 mm,
  // inside the image of the 1.5 mm particle of the second scene).
  static std::pair<double, double> lensAndCentre(const cv::Mat& image) {
    cv::Mat lens = cv::Mat::zeros(image.size(), CV_8UC1), centre = lens.clone();
    cv::circle(lens, {28, 28}, 16, cv::Scalar(255), cv::FILLED);
    cv::circle(centre, {28, 28}, 2, cv::Scalar(255), cv::FILLED);
    return {cv::mean(image, lens)[0], cv::mean(image, centre)[0]};
  }
  // Mean of the ring 3..7 mm from the lens's centre (6..14 pixels): clear of
  // the 1.5 mm particle's shadow (its chief rays pass the particle by more
  // than a millimetre), so the same with and without it.
  static double ring(const cv::Mat& image) {
    cv::Mat ring = cv::Mat::zeros(image.size(), CV_8UC1);
    cv::circle(ring, {28, 28}, 14, cv::Scalar(255), cv::FILLED);
    cv::circle(ring, {28, 28}, 6, cv::Scalar(0), cv::FILLED);
    return cv::mean(image, ring)[0];
  }

  // The intact bench's capture, display and camera, the camera configured at
  // 2 ms exposure and `frameRate_hz`.
  struct Rig {
    std::unique_ptr<LightFieldCapture> capture;
    std::unique_ptr<Display> display;
    std::unique_ptr<Camera> camera;
  };
  Rig intactRig(double frameRate_hz) const {
    Rig rig{openLightFieldCapture(captureUri()), openDisplay(uri("intact.toml")), openCamera(uri("intact.toml"))};
    CameraSettings settings;
    settings.exposure_us = 2000;
    settings.pixelFormat = PixelFormat::Mono12;
    settings.frameRate_hz = frameRate_hz;
    rig.camera->configure(settings);
    return rig;
  }

  TestFolder dir_{"lfi-controller"};
};

// registerSimBackends() may be called again and again, also when another
// library took a scheme first: a light field capture backend "sim" of its
// own leaves lfi's camera and display backends registered. In a child
// process: the registry is process-wide, and the other tests here want lfi's.
TEST(SimBackends, RegisterWhenAnotherLibraryTookTheCaptureScheme) {
  auto body = [] {
    const std::vector<std::string> captures = backendRegistry<LightFieldCapture>().schemes();
    if (std::ranges::find(captures, std::string("sim")) != captures.end()) std::_Exit(2);  // (not a fresh registry)
    backendRegistry<LightFieldCapture>().add(LightFieldCaptureBackend{
        .scheme = "sim",
        .keys = {},
        .description = "another library's",
        .factory = [](const DeviceUri&) -> std::unique_ptr<LightFieldCapture> {
          fail(Errc::Device, "another library's");
        },
    });
    sim::registerSimBackends();
    sim::registerSimBackends();
    const std::vector<std::string> cameras = backendRegistry<Camera>().schemes(),
                                   displays = backendRegistry<Display>().schemes();
    const bool registered = std::ranges::find(cameras, std::string("sim")) != cameras.end() &&
                            std::ranges::find(displays, std::string("sim")) != displays.end();
    std::_Exit(registered ? 0 : 1);
  };
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(body(), ::testing::ExitedWithCode(0), "");
}

TEST_F(ControllerTest, InverseSchlierenCycleLightsTheIntactLensAndDarkensTheParticle) {
  auto capture = openLightFieldCapture(captureUri());
  CameraSettings settings;
  settings.exposure_us = 2000;
  settings.pixelFormat = PixelFormat::Mono12;

  // Intact part: camera and display on the intact bench.
  auto camera = openCamera(uri("intact.toml"));
  auto display = openDisplay(uri("intact.toml"));
  camera->configure(settings);
  Controller controller(*capture, *display, *camera);
  const LightField reference = controller.captureReference();
  EXPECT_EQ(reference.geometry().distance_mm, 30);
  // Blank display: the lens stays dark (nothing else lights the scene).
  const cv::Mat dark = controller.inspect();
  controller.emit(reference);
  const cv::Mat lit = controller.inspect();
  const auto [darkLens, darkCentre] = lensAndCentre(dark);
  // The whole inner lens is lit, not a part of it: the ring's pixels above the
  // blank display by 40 DN, five times a pixel's noise at the lit level (~150
  // DN, 385 e-: 7.7 DN), but for the odd pixel whose 8 samples found little
  // of the display (2 of 500 with this seed).
  cv::Mat ringMask = cv::Mat::zeros(lit.size(), CV_8UC1);
  cv::circle(ringMask, {28, 28}, 14, cv::Scalar(255), cv::FILLED);
  cv::circle(ringMask, {28, 28}, 6, cv::Scalar(0), cv::FILLED);
  cv::Mat litPixels;
  cv::compare(lit, darkLens + 40, litPixels, cv::CMP_GT);
  EXPECT_GE(cv::countNonZero(litPixels & ringMask), 0.98 * cv::countNonZero(ringMask));
  const auto [litLens, litCentre] = lensAndCentre(lit);
  std::printf("intact: lens %.1f DN (blank display %.1f), centre %.1f DN\n", litLens, darkLens, litCentre);
  // The emitted light field is the one the intact lens makes parallel: the
  // camera must receive light through the lens. 20 DN over the blank display is
  // more than 9 times the noise of a 13-pixel mean at these levels (shot noise
  // 7.7 DN per pixel at the lit ~150 DN with 2.56 e-/DN).
  EXPECT_GT(litLens, darkLens + 20);
  EXPECT_GT(litCentre, darkCentre + 20);

  // The same cycle with an opaque 1.5 mm particle at the centre of the lens:
  // the reference is still the intact one (a part is compared with what an
  // intact part would do), so the particle blocks the centre.
  auto camera2 = openCamera(uri("particle.toml"));
  auto display2 = openDisplay(uri("particle.toml"));
  camera2->configure(settings);
  Controller second(*capture, *display2, *camera2);
  second.emit(reference);
  const cv::Mat withParticle = second.inspect();
  const auto [partLens, partCentre] = lensAndCentre(withParticle);
  std::printf("particle: lens %.1f DN, centre %.1f DN, ring %.1f DN (intact %.1f)\n", partLens, partCentre,
              ring(withParticle), ring(lit));
  EXPECT_LT(partCentre, 0.2 * litCentre);
  // ... and only the centre: the ring around the particle's shadow is as bright
  // as on the intact part (the same samples; the sensor's noise differs, under
  // 0.5 DN in a mean of ~500 pixels).
  EXPECT_NEAR(ring(withParticle), ring(lit), 0.03 * ring(lit));
}

// A free-running camera keeps exposing while the display changes: after an
// emit(), inspect() must not average the frames it took of the old panel.
TEST_F(ControllerTest, InspectionAfterAnEmitSeesOnlyTheNewPanel) {
  const Rig rig = intactRig(100);
  Camera& camera = *rig.camera;
  ControllerOptions options;
  options.frames = 2;
  Controller controller(*rig.capture, *rig.display, camera, options);
  const LightField reference = controller.captureReference();
  const auto [darkLens, darkCentre] = lensAndCentre(controller.inspect());  // starts the camera: blank display
  ASSERT_EQ(camera.state(), Camera::State::Streaming);
  std::this_thread::sleep_for(std::chrono::milliseconds(100));  // the buffers fill with frames of the blank display
  controller.emit(reference);
  const auto [litLens, litCentre] = lensAndCentre(controller.inspect());
  // Settled: the stream has run on the new panel for a while.
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  const auto [settledLens, settledCentre] = lensAndCentre(controller.inspect());
  std::printf("blank %.1f DN, lit %.1f DN, settled %.1f DN\n", darkLens, litLens, settledLens);
  ASSERT_GT(settledLens, darkLens + 20);
  // One frame of the blank display among the two averaged would take the lit
  // mean half-way down to the blank one; the sensor's noise moves a mean of
  // ~800 pixels by well under 1 %.
  EXPECT_NEAR(litLens, settledLens, 0.03 * (settledLens - darkLens))
      << "a frame of the blank display was averaged into the lit inspection";
  EXPECT_EQ(camera.state(), Camera::State::Streaming);
  // The stream is the controller's: it stops it when it goes.
}

// An image is of the reference only while the display shows it: a display
// blanked, sent another frame by someone else, or gone is an error that names
// it, never an image judged as if it were lit by the reference.
TEST_F(ControllerTest, ADisplayThatNoLongerShowsTheReferenceIsAnError) {
  const Rig rig = intactRig(100);
  Controller controller(*rig.capture, *rig.display, *rig.camera, {});
  EXPECT_TRUE(throwsError([&] { controller.requireShowing(); }, Errc::InvalidArgument, {"was not sent anything"}));
  const LightField reference = controller.captureReference();
  controller.emit(reference);
  controller.inspect();
  EXPECT_NO_THROW(controller.requireShowing());
  const cv::Mat other = cv::Mat::zeros(rig.display->info().panelHeight_px, rig.display->info().panelWidth_px,
                                       rig.display->info().panelType());
  ASSERT_EQ(rig.display->show(other).status, PresentStatus::Presented);  // (frame 2, not the controller's)
  EXPECT_TRUE(throwsError([&] { controller.requireShowing(); }, Errc::Device, {"frame 1 was shown; it shows frame 2"}));
  rig.display->blank();
  EXPECT_TRUE(throwsError([&] { controller.requireShowing(); }, Errc::Device, {"no longer shows the reference"}));
  EXPECT_TRUE(throwsError([&] { controller.requireShowing(); }, Errc::Device, {"is dark"}));
  controller.emit(reference);
  EXPECT_NO_THROW(controller.requireShowing());
}

// With a settle time, no frame that counts starts exposing before the panel has
// had it (a physical panel's response time).
TEST_F(ControllerTest, FramesAfterAnEmitStartOnlyAfterTheSettleTime) {
  const Rig rig = intactRig(100);
  ControllerOptions options;
  options.settle = std::chrono::milliseconds(150);
  options.frames = 3;
  RecordingCamera camera(*rig.camera);
  Controller controller(*rig.capture, *rig.display, camera, options);
  const LightField reference = controller.captureReference();
  controller.inspect();  // starts the stream
  const auto emitting = std::chrono::steady_clock::now();
  controller.emit(reference);
  camera.timestamps_ns.clear();
  controller.inspect();
  // Every frame that inspect() averaged started after the settle time.
  ASSERT_EQ(camera.timestamps_ns.size(), static_cast<size_t>(options.frames));
  for (const std::int64_t t : camera.timestamps_ns)
    EXPECT_GE(std::chrono::nanoseconds(t), (emitting + options.settle).time_since_epoch());
  // The same for a stream the caller starts between emit() and inspect().
  camera.stop();
  const auto emittingAgain = std::chrono::steady_clock::now();
  controller.emit(reference);
  camera.start(4);
  camera.timestamps_ns.clear();
  controller.inspect();
  ASSERT_EQ(camera.timestamps_ns.size(), static_cast<size_t>(options.frames));
  for (const std::int64_t t : camera.timestamps_ns)
    EXPECT_GE(std::chrono::nanoseconds(t), (emittingAgain + options.settle).time_since_epoch());
  options.settle = std::chrono::milliseconds(-1);
  EXPECT_TRUE(throwsError([&] { Controller(*rig.capture, *rig.display, *rig.camera, options); }, Errc::InvalidArgument,
                          {"settle"}));
}

// A software-triggered stream holds no frame once every trigger has been
// answered: a new panel needs no restart of it (tens of ms on a GigE camera).
// One whose trigger went unanswered may get the late frame of the old panel:
// it is restarted, and the image is of the new panel.
TEST_F(ControllerTest, ASoftwareTriggeredStreamRestartsForANewPanelOnlyAfterAnUnansweredTrigger) {
  const Rig rig = intactRig(0);
  CameraSettings settings = rig.camera->settings();
  settings.trigger = TriggerMode::Software;
  rig.camera->configure(settings);
  RecordingCamera camera(*rig.camera);
  Controller controller(*rig.capture, *rig.display, camera, {.frames = 2});
  const LightField reference = controller.captureReference();
  controller.emit(reference);
  const double lit = lensAndCentre(controller.inspect()).first;
  EXPECT_EQ(camera.starts, 1);
  controller.emit(reference);
  EXPECT_NEAR(lensAndCentre(controller.inspect()).first, lit, 0.05 * lit);
  EXPECT_EQ(camera.starts, 1) << "every trigger was answered: the stream holds nothing of the old panel";
  camera.loseNextFrame = true;  // (its frame, of the lit panel, stays in the stream)
  controller.inspect();
  const DisplayInfo info = rig.display->info();
  controller.showPanel(cv::Mat::zeros(info.panelHeight_px, info.panelWidth_px, CV_8UC1));
  const double dark = lensAndCentre(controller.inspect()).first;
  EXPECT_EQ(camera.starts, 2) << "a trigger went unanswered: the stream restarts";
  EXPECT_LT(dark, 0.05 * lit) << "the late frame of the lit panel was averaged into the dark one";
}

// The same on a line, with no new panel: a trigger that went unanswered may
// still be answered, by a frame exposed before the next part came. The stream
// restarts, and every frame averaged for the next part is exposed after its
// inspect() began.
TEST_F(ControllerTest, AFrameLateBeyondItsTimeoutIsNotTakenForTheNextPart) {
  const Rig rig = intactRig(0);
  CameraSettings settings = rig.camera->settings();
  settings.trigger = TriggerMode::Software;
  rig.camera->configure(settings);
  RecordingCamera camera(*rig.camera);
  Controller controller(*rig.capture, *rig.display, camera, {.frames = 2});
  controller.emit(controller.captureReference());
  controller.inspect();
  camera.loseNextFrame = true;  // (its frame stays in the stream)
  controller.inspect();
  EXPECT_EQ(camera.starts, 1);
  camera.timestamps_ns.clear();
  const std::int64_t next =
      std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch()).count();
  controller.inspect();
  EXPECT_EQ(camera.starts, 2) << "a trigger went unanswered: the stream restarts";
  ASSERT_EQ(camera.timestamps_ns.size(), 2u);
  for (const std::int64_t t : camera.timestamps_ns) EXPECT_GE(t, next) << "a frame exposed before this part's inspect";
}

// A camera the caller started stays the caller's after the controller restarted it.
TEST_F(ControllerTest, ARestartedStreamStaysTheCallers) {
  const Rig rig = intactRig(25);
  rig.camera->start(4);
  {
    Controller controller(*rig.capture, *rig.display, *rig.camera);
    controller.emit(controller.captureReference());
    controller.inspect();
  }
  EXPECT_EQ(rig.camera->state(), Camera::State::Streaming);
  {
    Controller controller(*rig.capture, *rig.display, *rig.camera);
    controller.inspect();
  }
  EXPECT_EQ(rig.camera->state(), Camera::State::Streaming);
}

TEST_F(ControllerTest, ErrorsNameTheProblem) {
  auto capture = openLightFieldCapture(captureUri());
  auto camera = openCamera(uri("intact.toml"));
  auto display = openDisplay(uri("intact.toml"));
  EXPECT_TRUE(
      throwsError([&] { Controller(*capture, *display, *camera, {.frames = 0}); }, Errc::InvalidArgument, {"frames"}));
  Controller controller(*capture, *display, *camera);
  // The camera was never configured.
  EXPECT_TRUE(throwsError([&] { controller.inspect(); }, Errc::InvalidArgument, {"configured or streaming"}));
  // A light field capture URI with an unknown key, and one on a missing file.
  EXPECT_TRUE(throwsError([&] { openLightFieldCapture(uri("intact.toml") + "?spacial=3"); }, Errc::Config,
                          {"spacial", "accepted"}));
  EXPECT_TRUE(throwsError([&] { openLightFieldCapture("sim:" + (dir_ / "missing.toml").string()); }, Errc::NotFound,
                          {"missing.toml"}));
  EXPECT_TRUE(
      throwsError([&] { openLightFieldCapture(uri("intact.toml") + "?angular=0"); }, Errc::Config, {"angular"}));
  // The lens spans z = -2.5 .. 2.5 mm: a sensor plane or a beam inside it is refused, naming both (the sensor's
  // plane when the bench hands Δ in, the beam's at open).
  auto near = openLightFieldCapture(uri("intact.toml"));
  EXPECT_TRUE(throwsError([&] { near->setDistance(2); }, Errc::Config, {"intact.toml", "'lens'", "-Δ", "-2"}));
  EXPECT_TRUE(throwsError([&] { near->setDistance(0); }, Errc::InvalidArgument, {"intact.toml", "Δ = 0"}));
  EXPECT_TRUE(throwsError([&] { openLightFieldCapture(uri("intact.toml") + "?beam_distance_mm=2.4"); }, Errc::Config,
                          {"'lens'", "beam_distance_mm", "2.4"}));
  auto tight = openLightFieldCapture(uri("intact.toml") + "?beam_distance_mm=2.6");
  EXPECT_NO_THROW(tight->setDistance(2.6));
  EXPECT_EQ(tight->geometry().distance_mm, 2.6);
  // Numbers that parse but mean nothing here: a beam at infinity lights nothing; more samples than a scene file takes.
  for (const char* bad : {"beam_distance_mm=inf", "beam_distance_mm=1e300", "beam_distance_mm=nan"})
    EXPECT_TRUE(throwsError([&] { openLightFieldCapture(uri("intact.toml") + "?" + bad); }, Errc::Config,
                            {"beam_distance_mm", "1e-06 .. 1000000 mm"}))
        << bad;
  EXPECT_TRUE(throwsError([&] { openLightFieldCapture(uri("intact.toml") + "?spp=2000000"); }, Errc::Config,
                          {uri("intact.toml") + "?spp=2000000", "spp = '2000000'", "1 .. 1048576"}));
  EXPECT_TRUE(throwsError([&] { openLightFieldCapture(uri("intact.toml") + "?beam_half_angle_rad=0"); }, Errc::Config,
                          {uri("intact.toml") + "?beam_half_angle_rad=0", "1e-06 .. 1.5 rad"}));
}

// Δ has one owner, the bench's [geometry] distance_mm: the capture the bench opens records there, and a light
// field file recorded at another Δ is refused naming the bench and the file.
TEST_F(ControllerTest, TheBenchHandsItsDistanceToTheCapture) {
  BenchFile b = readBenchFile(std::filesystem::path(LFI_SOURCE_DIR) / "data" / "benches" / "inspection_sim.toml");
  b.distance_mm = 36.5;
  EXPECT_EQ(openBenchCapture(b)->geometry().distance_mm, 36.5);
  b.distance_mm = 1;  // the sensor's plane inside the lens
  EXPECT_TRUE(throwsError([&] { openBenchCapture(b); }, Errc::Config,
                          {"inspection_sim.toml", "[geometry] distance_mm = 1", "'lens'"}));
  const std::filesystem::path file = dir_ / "at-30.exr";
  writeLightFieldExr(
      file, LightField({.spatialX = 2, .spatialY = 2, .angular = 2, .pixelPitch_mm = 0.05, .distance_mm = 30}));
  b.captureUri.reset();
  b.lightFieldFile = file;
  b.distance_mm = 30;
  EXPECT_EQ(openBenchCapture(b)->geometry().distance_mm, 30);
  b.distance_mm = 31;
  EXPECT_TRUE(throwsError([&] { openBenchCapture(b); }, Errc::Config,
                          {"inspection_sim.toml", "at-30.exr", "recorded 30 mm", "Δ = 31 mm"}));
}

// No part passes a line-triggered bench's sensor while it calibrates or takes its reference: lfi triggers
// those exposures itself. (The sim: camera has no trigger lines: configured as the bench says, it refuses.)
TEST_F(ControllerTest, ALineTriggeredBenchIsSoftwareTriggeredWhenLfiAsksForTheExposures) {
  BenchFile b = readBenchFile(std::filesystem::path(LFI_SOURCE_DIR) / "data" / "benches" / "inspection_sim.toml");
  b.camera.trigger = TriggerMode::Line;
  b.camera.triggerLine = "Line0";
  EXPECT_TRUE(throwsError([&] { openBenchCamera(b); }, Errc::InvalidArgument, {"TriggerMode::Line"}));
  EXPECT_EQ(openBenchCamera(b, BenchExposures::OnRequest)->settings().trigger, TriggerMode::Software);
  b.camera.trigger = TriggerMode::FreeRun;  // (a camera without a software trigger runs free: it stays so)
  EXPECT_EQ(openBenchCamera(b, BenchExposures::OnRequest)->settings().trigger, TriggerMode::FreeRun);
}

}  // namespace
