// SPDX-License-Identifier: Apache-2.0
// The ray-traced display backend ("sim:<scene-file>") and the physical display
// emitter (PanelEmission): the state machine through the registry, a light field
// encoded for the display and emitted through the panel + lenslet model against
// the source light field, the light a parallax barrier loses, and a SimCamera on
// the same scene file seeing what the SimDisplay shows.

#include "lfi/sim/devices/sim_display.h"
#include "lfi/drivers/camera_registry.h"
#include "lfi/drivers/display_optics.h"
#include "lfi/drivers/display_registry.h"
#include "lfi/sim/devices/sim_bench.h"
#include "lfi/sim/devices/sim_camera.h"
#include "lfi/sim/render.h"
#include "lfi_test_support.h"
#include "scene_text.h"
#include "test_folder.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <filesystem>
#include <numbers>
#include <random>
#include <string>
#include <thread>

namespace lfi::sim {
namespace {

using namespace std::chrono_literals;
using testing_support::cameraSceneText;
using testing_support::TestFolder;
using testing_support::throwsError;
namespace fs = std::filesystem;

const LenticularOptics& lenticular(const DisplayOptics& optics) {
  return *optics.model<LenticularOptics>();
}

// A telecentric camera (magnification 1, 16 mm field) looking down at a display
// in the plane z = 0; `display` is the [display] table's body, with the optics
// of the default lenticular display (whose 0.075 mm pixels make a panel of a few
// hundred pixels cover the field) unless it names others.
std::string sceneText(const std::string& display, bool defaultOptics = false) {
  const bool lenticular = !defaultOptics && display.find("optics =") == std::string::npos;
  return cameraSceneText({.samplesPerPixel = 16,
                          .seed = 5,
                          .pixelPitch_mm = 0.25,
                          .width_px = 64,
                          .height_px = 64,
                          .fullWell_e = 20000,
                          .readNoise_e = 2,
                          .bitDepth = 12,
                          .electronsPerUnitPerUs = 2.0}) +
         "[display]\n" + (lenticular ? "optics = \"lenticular\"\n" : "") + display;
}

class SimDisplayTest : public ::testing::Test {
 protected:
  void SetUp() override { registerSimBackends(); }
  fs::path write(const std::string& name, const std::string& text) { return dir_.write(name, text); }
  static std::string uri(const fs::path& file) { return "sim:" + file.string(); }
  // A camera and a 400 x 300 mono display of brightness 1 on one bench.
  std::pair<std::unique_ptr<Camera>, std::unique_ptr<Display>> openMonoBench() {
    const fs::path file = write("bench.toml", sceneText("panel_width_px = 400\npanel_height_px = 300\n"
                                                        "subpixels = \"mono\"\nbrightness = 1\n"));
    return {openCamera(uri(file)), openDisplay(uri(file))};
  }

  TestFolder dir_{"lfi-sim-display"};
};

// A scene file whose path holds the URI's delimiters opens percent-encoded, and
// the display names itself by a URI that opens it again.
TEST_F(SimDisplayTest, APathWithTheUrisDelimitersIsPercentEncoded) {
  const fs::path file = write("100% a&b=c?.toml", sceneText("panel_width_px = 32\npanel_height_px = 20\n"));
  const std::string encoded = "sim:" + percentEncodeUriPart(file.string());
  EXPECT_NE(encoded.find("100%25%20a%26b%3Dc%3F.toml"), std::string::npos) << encoded;
  auto display = openDisplay(encoded);
  EXPECT_EQ(display->name(), encoded);
  const std::string deviceId = display->info().deviceId;
  EXPECT_EQ("sim:" + deviceId, encoded);  // the part that reopens it
  display->close();
  EXPECT_EQ(openDisplay("sim:" + deviceId)->name(), encoded);
  auto camera = openCamera(encoded);  // (the camera of the same scene file)
  EXPECT_EQ("sim:" + camera->info().deviceId, encoded);
  EXPECT_TRUE(throwsError([&] { openDisplay(uri(file)); }, Errc::Config, {"two hex digits"}));  // not encoded
}

TEST_F(SimDisplayTest, StateMachineThroughTheSimBackend) {
  const fs::path file =
      write("mono.toml", sceneText("panel_width_px = 320\npanel_height_px = 200\nsubpixels = \"mono\"\n"
                                   "brightness = 2\n",
                                   true));
  auto display = openDisplay(uri(file));
  ASSERT_EQ(display->state(), Display::State::Open);
  const DisplayInfo info = display->info();
  EXPECT_EQ(info.model, "SimDisplay");
  EXPECT_EQ(info.serial, "mono");
  EXPECT_EQ(info.deviceId, file.string());
  EXPECT_EQ(info.panelWidth_px, 320);
  EXPECT_EQ(info.panelHeight_px, 200);
  EXPECT_EQ(info.subpixels, SubpixelLayout::Mono);
  EXPECT_EQ(info.panelType(), CV_8UC1);
  // Optics default to the full-parallax lenslet array display of display_optics.h.
  EXPECT_EQ(info.optics, defaultLensletArrayDisplay().optics);
  EXPECT_EQ(info.viewCount, defaultLensletArrayDisplay().viewCount);

  auto bench = SimBench::open(file, "test");
  EXPECT_FALSE(bench->lit());
  // Dark until shown, without a level image (a large panel's would take gigabytes).
  ASSERT_TRUE(bench->emission().levels);
  EXPECT_TRUE(bench->emission().levels->empty());
  EXPECT_EQ(bench->emission().radiance({0, 0}, {0, 0, 1}), 0.0);
  const std::uint64_t v0 = bench->version();

  EXPECT_TRUE(throwsError([&] { display->show(cv::Mat(10, 10, CV_8UC1)); }, Errc::InvalidArgument,
                          {"sim:", "320x200", "CV_8UC1"}));
  EXPECT_TRUE(throwsError([&] { display->show(cv::Mat(200, 320, CV_8UC3)); }, Errc::InvalidArgument, {"CV_8UC1"}));
  EXPECT_EQ(display->state(), Display::State::Open);

  const PresentResult r = display->show(cv::Mat(200, 320, CV_8UC1, cv::Scalar(255)));
  EXPECT_EQ(r.status, PresentStatus::Presented);
  EXPECT_EQ(r.sequence, 1u);
  EXPECT_EQ(display->state(), Display::State::Showing);
  EXPECT_TRUE(bench->lit());
  EXPECT_GT(bench->version(), v0);
  EXPECT_DOUBLE_EQ(bench->emission().brightness, 2.0);
  EXPECT_EQ(bench->emission().levels->size(), cv::Size(320, 200));
  EXPECT_EQ(bench->emission().levels->at<float>(199, 319), 1.0f);  // level 255 → 1
  EXPECT_EQ(display->show(cv::Mat(200, 320, CV_8UC1, cv::Scalar(10))).sequence, 2u);
  DisplayStatus s = display->status();
  EXPECT_TRUE(s.showing);
  EXPECT_EQ(s.presentedSequence, 2u);
  EXPECT_EQ(s.framesPresented, 2u);
  EXPECT_EQ(s.brightness, 255);

  display->setBrightness(51);
  EXPECT_EQ(display->status().brightness, 51);
  EXPECT_NEAR(bench->emission().brightness, 2.0 * 51 / 255, 1e-12);
  EXPECT_TRUE(throwsError([&] { display->setBrightness(256); }, Errc::InvalidArgument, {"256", "0..255"}));

  display->blank();
  EXPECT_EQ(display->state(), Display::State::Open);
  EXPECT_FALSE(bench->lit());
  EXPECT_DOUBLE_EQ(bench->emission().brightness, 0.0);
  EXPECT_FALSE(display->status().showing);
  display->blank();  // allowed in Open

  display->close();
  EXPECT_EQ(display->state(), Display::State::Closed);
  EXPECT_TRUE(throwsError([&] { display->info(); }, Errc::InvalidArgument, {"info", "Closed"}));
  EXPECT_TRUE(throwsError([&] { display->show(cv::Mat(200, 320, CV_8UC1)); }, Errc::InvalidArgument, {"Closed"}));
  EXPECT_TRUE(throwsError([&] { display->blank(); }, Errc::InvalidArgument, {"Closed"}));
  display->close();  // any state
  display->open();
  EXPECT_EQ(display->state(), Display::State::Open);
  EXPECT_EQ(display->status().brightness, 255);  // open() resets the backlight
  EXPECT_TRUE(throwsError([&] { display->open(); }, Errc::InvalidArgument, {"open", "Open"}));
  // Frames count from 1 again after an open, as the USB protocol's do.
  EXPECT_EQ(display->show(cv::Mat(200, 320, CV_8UC1, cv::Scalar(9))).sequence, 1u);

  // One display drives the file's panel: a second is refused, naming it, and leaves the first showing.
  EXPECT_TRUE(throwsError([&] { openDisplay(uri(file)); }, Errc::Device, {uri(file), "already open"}));
  EXPECT_EQ(display->state(), Display::State::Showing);
  EXPECT_TRUE(bench->lit());
  display->close();
  auto second = openDisplay(uri(file));
  EXPECT_EQ(second->state(), Display::State::Open);
}

TEST_F(SimDisplayTest, BadUrisAndSceneFilesAreClearErrors) {
  const fs::path good = write("good.toml", sceneText("panel_width_px = 64\npanel_height_px = 64\n"));
  EXPECT_TRUE(throwsError([&] { openDisplay(uri(dir_ / "missing.toml")); }, Errc::NotFound, {"missing.toml"}));
  EXPECT_TRUE(throwsError([&] { openDisplay(uri(good) + "?gap_mm=1"); }, Errc::Config, {"unknown key 'gap_mm'"}));
  std::string noDisplay = sceneText("");
  noDisplay.resize(noDisplay.find("[display]"));
  noDisplay += "[[object]]\nname = \"light\"\nshape = \"rectangle\"\nsize_mm = [10, 10]\nemitter = \"lambertian\"\n";
  const fs::path plain = write("plain.toml", noDisplay);
  EXPECT_TRUE(throwsError([&] { openDisplay(uri(plain)); }, Errc::Config, {"plain.toml", "[display]"}));
  const fs::path typo = write("typo.toml", sceneText("panel_widht_px = 64\n"));
  EXPECT_TRUE(throwsError([&] { openDisplay(uri(typo)); }, Errc::Config, {"typo.toml", "panel_widht_px"}));
  const fs::path noSlit = write("noslit.toml", sceneText("optics = \"line_barrier\"\n"));
  EXPECT_TRUE(throwsError([&] { openDisplay(uri(noSlit)); }, Errc::Config, {"noslit.toml", "slit_width_mm"}));
  const fs::path lensKey = write("lenskey.toml", sceneText("optics = \"line_barrier\"\nslit_width_mm = 0.1\n"
                                                           "focal_length_mm = 1\n"));
  EXPECT_TRUE(throwsError([&] { openDisplay(uri(lensKey)); }, Errc::Config, {"focal_length_mm"}));
  const fs::path badRange = write("range.toml", sceneText("brightness_min = 10\nbrightness_max = 5\n"));
  EXPECT_TRUE(
      throwsError([&] { openDisplay(uri(badRange)); }, Errc::Config,
                  {"range.toml:", "'display.brightness_max'", "brightness_max = 5 is below brightness_min = 10"}));
  // The [display] panel is an object named 'display': another object may not take the name.
  const fs::path clash = write("clash.toml", sceneText("") +
                                                 "[[object]]\nname = \"display\"\nshape = \"sphere\"\nradius_mm = 1\n"
                                                 "position_mm = [0, 0, -50]\n");
  EXPECT_TRUE(throwsError([&] { openDisplay(uri(clash)); }, Errc::Config, {"clash.toml:", "'display' names the"}));
}

// The source light field: smooth in position, linear in the direction across the
// lenses (the only direction a lenticular display resolves: horizontal parallax).
struct SmoothLightField {
  Vec2 across;           // lens normal n
  double wavelength_mm;  // of the spatial pattern
  double spatialAmplitude;
  double angularSlope;  // radiance per unit of d·n
  double operator()(const Vec2& q, const Vec3& d) const {
    const double k = 2 * std::numbers::pi / wavelength_mm;
    return 0.5 + spatialAmplitude * std::sin(k * q.x) * std::cos(k * q.y) +
           angularSlope * (d.x * across.x + d.y * across.y);
  }
};

TEST_F(SimDisplayTest, EncodedLightFieldIsReproducedWithinTheDisplaysResolution) {
  // The default lenticular optics (7.2 px per lens, 10.5° slant, 40° view cone, RGB
  // stripe) on an 800 x 500 panel (60 x 38 mm), placed at z = -30 in the world.
  const fs::path file = write("lenticular.toml", sceneText("optics = \"lenticular\"\npanel_width_px = 800\n"
                                                           "panel_height_px = 500\nposition_mm = [0, 0, -30]\n"));
  auto display = openDisplay(uri(file));
  const DisplayInfo info = display->info();
  const DisplayOptics optics(info);
  const Vec2 n = lenticular(optics).lensNormal();
  const double halfCone = 0.5 * optics.viewCone_rad();
  const SmoothLightField source{n, 20.0, 0.2, 0.25 / std::sin(halfCone)};

  LightFieldGeometry g{.spatialX = 24, .spatialY = 16, .angular = 16, .pixelPitch_mm = 0.15625, .distance_mm = 30};
  auto lightField = std::make_shared<LightField>(g);
  for (int ey = 0; ey < g.spatialY; ++ey)
    for (int ex = 0; ex < g.spatialX; ++ex)
      for (int v = 0; v < g.angular; ++v)
        for (int u = 0; u < g.angular; ++u) {
          const Vec2 disc = lightField->angularCentre(u, v);
          if (disc.x * disc.x + disc.y * disc.y >= 1) continue;
          lightField->at(ex, ey, u, v) =
              static_cast<float>(source(lightField->elementCentre(ex, ey), LightField::directionFromDisc(disc)));
        }
  ASSERT_EQ(display->show(encodeLightField(*lightField, DisplayOptics(display->info()))).status,
            PresentStatus::Presented);

  // The bench's scene as the SimCamera sees it, probed with rays of sight.
  auto bench = SimBench::open(file, "test");
  Scene scene(bench->description().objects);
  bench->applyDisplay(scene);

  // What the display can resolve. Its rays leave each lens along the lens axis
  // (the chief ray of the subpixel that the probe's direction selects), so
  //   position error ≤ P⊥/2 across the lens + half a subpixel along the axis;
  //   direction error ≤ half a subpixel's extent across the lens / gap (slanted stripes:
  //     (p/3) cos s + p sin s wide across the lens);
  // plus 8-bit quantisation. Each times the light field's gradient gives the bound.
  const double p = info.pixelPitch_mm, s = info.optics.slant_rad, gap = info.optics.gap_mm;
  const double subW = p / info.subpixelsPerPixel();
  const double positionError =
      0.5 * lenticular(optics).lensPitchPerp_mm() + 0.5 * (subW * std::sin(s) + p * std::cos(s));
  const double angularStep = (subW * std::cos(s) + p * std::sin(s)) / gap;  // in tan(angle) across the lens
  const double gradient = source.spatialAmplitude * 2 * std::numbers::pi / source.wavelength_mm;
  const double bound = gradient * positionError + source.angularSlope * 0.5 * angularStep + 0.5 / 255 + 1e-4;

  // Probes: positions inside the light field and the panel, directions in the
  // plane across the lenses within 18° of the axis (inside the 40° cone, far
  // enough from its edge that no ray reaches the neighbouring lens's pixels).
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> ux(-22, 22), uy(-14, 14),
      ut(-std::tan(0.9 * halfCone), std::tan(0.9 * halfCone));
  const Rigid3& worldFromDisplay = bench->description().display->worldFromDisplay;
  Sampler sampler(1, 1);
  double sum2 = 0, maxError = 0;
  const int probes = 20000;
  for (int i = 0; i < probes; ++i) {
    const Vec2 q(ux(rng), uy(rng));
    const double t = ut(rng);
    const Vec3 d = Vec3(t * n.x, t * n.y, 1).normalized();
    const Vec3 start = worldFromDisplay.point(Vec3(q.x, q.y, 0) + d * 5.0);
    const double emitted = traceRadiance(scene, Ray{start, -worldFromDisplay.vector(d)}, sampler, 8);
    const double expected = lightField->radiance(q, d, LightFieldLookup::Interpolated);
    const double e = std::abs(emitted - expected);
    sum2 += e * e;
    maxError = std::max(maxError, e);
  }
  const double rms = std::sqrt(sum2 / probes);
  // Measured (20 000 probes): RMS 0.0091, max 0.032 of a 0.05..0.95 signal, against the bound 0.040 =
  // position 0.019 (0.31 mm: P⊥/2 = 0.27 mm, the lens pitch is the display's spatial resolution)
  // + direction 0.019 (half of a 0.052 tan step = 3.0°: a subpixel's width across the lens / gap,
  // 0.038 mm / 0.73 mm, the display's angular resolution; 21.7 subpixels share the 40° cone)
  // + quantisation 0.002 (half an 8-bit level).
  RecordProperty("rms_error", std::to_string(rms));
  RecordProperty("max_error", std::to_string(maxError));
  std::printf("light field reproduction: RMS %.4f, max %.4f, bound %.4f\n", rms, maxError, bound);
  EXPECT_LE(maxError, bound);
  EXPECT_LT(rms, 0.4 * bound);

  // A display that is out of focus (f = 2 gap) mixes neighbouring views: the same
  // light field comes out worse. That is the crosstalk of a real lens sheet.
  const fs::path blurred = write(
      "blurred.toml", sceneText(fmt::format("optics = \"lenticular\"\npanel_width_px = 800\npanel_height_px = 500\n"
                                            "focal_length_mm = {}\n",
                                            2 * gap)));
  auto display2 = openDisplay(uri(blurred));
  display2->show(encodeLightField(*lightField, DisplayOptics(display2->info())));
  auto bench2 = SimBench::open(blurred, "test");
  Scene scene2(bench2->description().objects);
  bench2->applyDisplay(scene2);
  std::mt19937 rng2(7);
  double sum2b = 0;
  for (int i = 0; i < probes; ++i) {
    const Vec2 q(ux(rng2), uy(rng2));
    const double t = ut(rng2);
    const Vec3 d = Vec3(t * n.x, t * n.y, 1).normalized();
    const double emitted = traceRadiance(scene2, Ray{Vec3(q.x, q.y, 0) + d * 5.0, -d}, sampler, 8);
    const double e = emitted - lightField->radiance(q, d, LightFieldLookup::Interpolated);
    sum2b += e * e;
  }
  const double rmsBlurred = std::sqrt(sum2b / probes);
  std::printf("defocused lens sheet (f = 2 gap): RMS %.4f\n", rmsBlurred);
  EXPECT_GT(rmsBlurred, 2 * rms);
}

TEST_F(SimDisplayTest, BarrierLosesTheLightTheSlitsBlock) {
  // A uniform full-level panel behind a barrier with slits a quarter of the pitch
  // wide: only the slits pass light, so the display's mean radiance is
  // brightness · slit / P⊥, whatever the direction (the panel behind is uniform).
  const DisplayInfo defaults = defaultLenticularDisplay();
  const double perpPitch = defaults.optics.lensPitch_px * defaults.pixelPitch_mm * std::cos(defaults.optics.slant_rad);
  const double slit = 0.25 * perpPitch;
  const fs::path file = write("barrier.toml", sceneText(fmt::format("panel_width_px = 400\npanel_height_px = 300\n"
                                                                    "subpixels = \"mono\"\noptics = \"line_barrier\"\n"
                                                                    "slit_width_mm = {}\nbrightness = 1\n",
                                                                    slit)));
  auto display = openDisplay(uri(file));
  display->show(cv::Mat(300, 400, CV_8UC1, cv::Scalar(255)));

  // Probe rays on a fine regular grid of positions (many lens periods) and a spread of directions.
  auto bench = SimBench::open(file, "test");
  Scene scene(bench->description().objects);
  bench->applyDisplay(scene);
  Sampler sampler(1, 1);
  double sum = 0;
  int count = 0;
  for (int j = 0; j < 200; ++j)
    for (int i = 0; i < 200; ++i) {
      const Vec2 q(-10 + 20.0 * (i + 0.5) / 200 + 0.0013 * j, -8 + 16.0 * (j + 0.5) / 200);
      const double a = 0.4 * ((i * 7 + j * 13) % 17 / 16.0 - 0.5);  // -0.2..0.2 rad
      const Vec3 d(std::sin(a), 0.3 * std::sin(a), std::cos(a));
      sum += traceRadiance(scene, Ray{Vec3(q.x, q.y, 0) + d.normalized() * 5.0, -d.normalized()}, sampler, 8);
      ++count;
    }
  const double probeMean = sum / count;
  const double expected = slit / perpPitch;
  std::printf("barrier: probe mean %.4f, camera mean %s, expected slit/P = %.4f\n", probeMean, "(below)", expected);
  EXPECT_NEAR(probeMean, expected, 0.01);

  // Through the camera: the noise-free radiance SimImager renders for the SimCamera.
  SimImager imager(file);
  const double cameraMean = cv::mean(imager.radiance(1))[0];
  std::printf("barrier: camera mean radiance %.4f (transmission %.1f %%, loss %.1f %%)\n", cameraMean, 100 * cameraMean,
              100 * (1 - cameraMean));
  EXPECT_NEAR(cameraMean, expected, 0.01);
}

TEST_F(SimDisplayTest, SimCameraSeesWhatTheSimDisplayShows) {
  const fs::path file = write("bench.toml", sceneText("panel_width_px = 400\npanel_height_px = 300\n"
                                                      "subpixels = \"mono\"\nbrightness = 1\n"));
  auto camera = openCamera(uri(file));
  auto display = openDisplay(uri(file));
  CameraSettings settings;
  settings.exposure_us = 5000;  // radiance 1 → 10 000 e- of 20 000: half scale
  settings.pixelFormat = PixelFormat::Mono16;
  settings.trigger = TriggerMode::Software;
  camera->configure(settings);
  camera->start(4);
  auto meanDn = [&] {
    camera->softwareTrigger();
    Frame frame;
    camera->grabInto(frame, 2000ms);
    EXPECT_EQ(frame.status, FrameStatus::Complete);
    return cv::mean(frame.image)[0] / 16;  // 12-bit ADC values
  };
  const double fullScale = 4095 * 2.0 * 5000 / 20000;  // ADC for radiance 1

  EXPECT_LT(meanDn(), 5) << "blank display at open";
  display->show(cv::Mat(300, 400, CV_8UC1, cv::Scalar(255)));
  EXPECT_NEAR(meanDn(), fullScale, 0.02 * fullScale) << "full-level panel";
  display->show(cv::Mat(300, 400, CV_8UC1, cv::Scalar(64)));
  // Within 2 % of the expected level and a few DN (the sensor's noise in a
  // frame's mean is well under one): a backlight curve (b/255)^1.2 would be
  // 13 % off at 128.
  EXPECT_NEAR(meanDn(), fullScale * 64 / 255, 0.02 * fullScale * 64 / 255 + 3) << "level 64";
  display->setBrightness(128);
  EXPECT_NEAR(meanDn(), fullScale * 64 / 255 * 128 / 255, 0.02 * fullScale * 64 / 255 * 128 / 255 + 3)
      << "backlight 128";
  display->blank();
  EXPECT_LT(meanDn(), 5) << "blanked";
  display->setBrightness(255);
  display->show(cv::Mat(300, 400, CV_8UC1, cv::Scalar(255)));
  EXPECT_NEAR(meanDn(), fullScale, 0.02 * fullScale) << "shown again";
  display->close();
  EXPECT_LT(meanDn(), 5) << "display closed";
  camera->stop();
}

// A panel's response curve (response_gamma, response_table) shapes the light
// each drive level emits, seen through the camera: the mean DN at level v over
// the mean at full drive is R(v / 255).
TEST_F(SimDisplayTest, APanelsResponseCurveShapesTheLightItEmits) {
  struct Case {
    std::string keys;
    std::vector<std::pair<int, double>> levels;  // drive level, R
  };
  const double table128 = 0.1 + (128.0 / 255 * 3 - 1) * 0.4;  // between the table's 0.1 at 85 and 0.5 at 170
  const std::vector<Case> cases = {
      {"response_gamma = 2.2\n", {{64, std::pow(64 / 255.0, 2.2)}, {128, std::pow(128 / 255.0, 2.2)}}},
      {"response_table = [0, 0.1, 0.5, 1]\n", {{85, 0.1}, {170, 0.5}, {128, table128}}},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.keys);
    const fs::path file = write("curve.toml", sceneText("panel_width_px = 400\npanel_height_px = 300\n"
                                                        "subpixels = \"mono\"\nbrightness = 1\n" +
                                                        c.keys));
    auto camera = openCamera(uri(file));
    auto display = openDisplay(uri(file));
    CameraSettings settings;
    settings.exposure_us = 5000;
    settings.pixelFormat = PixelFormat::Mono16;
    settings.trigger = TriggerMode::Software;
    camera->configure(settings);
    camera->start(4);
    auto meanDn = [&](int level) {
      display->show(cv::Mat(300, 400, CV_8UC1, cv::Scalar(level)));
      camera->softwareTrigger();
      Frame frame;
      camera->grabInto(frame, 2000ms);
      EXPECT_EQ(frame.status, FrameStatus::Complete);
      return cv::mean(frame.image)[0] / 16;
    };
    const double full = meanDn(255);
    // As the linear panel's test: within 2 % and the few DN of a frame's mean.
    for (const auto& [level, r] : c.levels)
      EXPECT_NEAR(meanDn(level), full * r, 0.02 * full * r + 3) << "level " << level;
    camera->stop();
  }
}

// The backlight's fall-off (backlight_falloff): 1 - f (r / r_corner)^2 of the
// level's light at a pixel r from the panel's centre, every subpixel alike.
TEST_F(SimDisplayTest, TheBacklightFallsOffTowardsThePanelsCorners) {
  DisplayInfo info;
  info.panelWidth_px = 401;
  info.panelHeight_px = 301;
  info.subpixels = SubpixelLayout::RgbStripe;
  PanelLight response;
  response.gamma = 2.2;
  response.backlightFalloff = 0.2;
  const cv::Mat levels = panelLevels(info, cv::Mat(301, 401, CV_8UC3, cv::Scalar::all(255)), response);
  ASSERT_EQ(levels.size(), cv::Size(3 * 401, 301));
  const double rc2 = 200.0 * 200 + 150.0 * 150;
  for (int s = 0; s < 3; ++s) {
    EXPECT_NEAR(levels.at<float>(150, 3 * 200 + s), 1.0, 1e-6) << "the centre";
    EXPECT_NEAR(levels.at<float>(0, s), 0.8, 1e-6) << "a corner";
    EXPECT_NEAR(levels.at<float>(300, 3 * 400 + s), 0.8, 1e-6) << "the opposite corner";
    EXPECT_NEAR(levels.at<float>(150, s), 1 - 0.2 * 200 * 200 / rc2, 1e-6) << "the left edge's middle";
    EXPECT_NEAR(levels.at<float>(0, 3 * 200 + s), 1 - 0.2 * 150 * 150 / rc2, 1e-6) << "the top edge's middle";
  }
  // The curve and the backlight multiply: level 128 at the corner.
  const cv::Mat half = panelLevels(info, cv::Mat(301, 401, CV_8UC3, cv::Scalar::all(128)), response);
  EXPECT_NEAR(half.at<float>(0, 0), 0.8 * std::pow(128 / 255.0, 2.2), 1e-6);
}

// Settings at which radiance 1 gives half the camera's 12-bit scale.
CameraSettings streamingSettings(double frameRate_hz) {
  CameraSettings settings;
  settings.exposure_us = 5000;
  settings.pixelFormat = PixelFormat::Mono16;
  settings.frameRate_hz = frameRate_hz;
  return settings;
}

// A free-running camera's buffered frames were exposed when they were due: the
// ones taken before a show() show the old panel, as on a real bench, and the
// ones after it the new one. Software-triggered frames are exposed at the trigger.
TEST_F(SimDisplayTest, FramesExposedBeforeAShowShowTheOldPanel) {
  auto [camera, display] = openMonoBench();
  CameraSettings settings = streamingSettings(100);
  camera->configure(settings);
  camera->start(4);
  std::this_thread::sleep_for(100ms);  // 10 frames due: the 4 buffers fill with the dark panel, 6 are underruns
  const auto showing = std::chrono::steady_clock::now();
  display->show(cv::Mat(300, 400, CV_8UC1, cv::Scalar(255)));
  Frame frame;
  auto meanDn = [&] {
    camera->grabInto(frame, 2000ms);
    EXPECT_EQ(frame.status, FrameStatus::Complete);
    return cv::mean(frame.image)[0] / 16;
  };
  for (int i = 0; i < 4; ++i) EXPECT_LT(meanDn(), 5) << "buffered frame " << i << " was exposed before the show";
  const double lit = meanDn();  // the next frame is due after the show
  EXPECT_GT(std::chrono::nanoseconds(frame.timestamp_ns), showing.time_since_epoch());
  // The frame due after the show shows the full-level panel: half the 12-bit scale.
  const double fullScale = 4095 * 2.0 * 5000 / 20000;
  EXPECT_NEAR(lit, fullScale, 0.02 * fullScale);
  EXPECT_GE(camera->statistics().underruns, 6u);
  camera->stop();

  settings.trigger = TriggerMode::Software;
  camera->configure(settings);
  camera->start(4);
  camera->softwareTrigger();
  display->blank();
  EXPECT_NEAR(meanDn(), fullScale, 0.02 * fullScale) << "triggered before the blank";
  camera->softwareTrigger();
  EXPECT_LT(meanDn(), 5) << "triggered after the blank";
  camera->stop();
}

// The display driven from one thread while the camera streams on another (a
// GUI thread and an acquisition thread): every frame shows one of the panels
// whole, never a mix, and neither side blocks the other for good.
TEST_F(SimDisplayTest, ADisplayDrivenFromAnotherThreadWhileTheCameraStreams) {
  auto [camera, display] = openMonoBench();
  camera->configure(streamingSettings(400));
  camera->start(4);
  const double fullScale = 4095 * 2.0 * 5000 / 20000;
  std::atomic<bool> done{false};
  std::thread driver([&] {
    for (int i = 0; !done; ++i) {
      display->show(cv::Mat(300, 400, CV_8UC1, cv::Scalar(i % 2 ? 255 : 0)));
      std::this_thread::sleep_for(1ms);
    }
  });
  int dark = 0, lit = 0, mixed = 0;
  Frame frame;
  for (int i = 0; i < 60; ++i) {
    camera->grabInto(frame, 2000ms);
    EXPECT_EQ(frame.status, FrameStatus::Complete);
    if (frame.status != FrameStatus::Complete) break;  // (the driver thread is joined below)
    const double dn = cv::mean(frame.image)[0] / 16;
    (dn < 5 ? dark : std::abs(dn - fullScale) < 0.02 * fullScale ? lit : mixed) += 1;
  }
  done = true;
  driver.join();
  camera->stop();
  EXPECT_EQ(mixed, 0);
  EXPECT_GT(dark, 0);
  EXPECT_GT(lit, 0);
}

}  // namespace
}  // namespace lfi::sim
