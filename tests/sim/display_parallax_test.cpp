// SPDX-License-Identifier: Apache-2.0
// The method on the bench it drives: the intact reference lens lit by the
// light field it produces, emitted by a full-parallax lenslet-array display and
// by a horizontal-parallax lenticular display, seen by a telecentric camera of
// 224 x 224 pixels over the lens. Capture (the sim: lensless sensor), emit (the
// sim: display's physical emitter) and inspect (the sim: camera), through the
// device interfaces as the controller runs them.

#include "lfi/core/image.h"
#include "lfi/drivers/camera_registry.h"
#include "lfi/drivers/capture_registry.h"
#include "lfi/drivers/display_registry.h"
#include "lfi/sim/devices/sim_camera.h"
#include "lfi/sim/devices/sim_light_field_capture.h"
#include "lfi_test_support.h"
#include "test_folder.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <opencv2/core.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>
#include <vector>

namespace lfi::sim {
namespace {

using testing_support::TestFolder;

// data/scenes/inspection_bench.toml with a finer camera: 224 x 224 pixels of
// 0.0304 mm at magnification b / wz = 24.9075 / 102.3 = 0.2435, 0.1249 mm in
// object space, 28 mm over the Ø 25.4 mm lens.
constexpr double kObjectPixel_mm = 0.0304 * (1 / (1 / 20.03 - 1 / 24.9075)) / 24.9075;
constexpr double kLensRadius_mm = 12.7;

std::string benchText(const std::string& display, const std::string& extraObjects = "") {
  return fmt::format(R"(format = "lfi-scene"
version = 1
[render]
samples_per_pixel = 8
seed = 5
[camera]
focal_length_mm = 20.03
image_distance_mm = 24.9075
stop_diameter_mm = 0.609
pixel_pitch_mm = 0.0304
width = 224
height = 224
position_mm = [0, 0, 102.5]
rotation_deg = [180, 0, 0]
[camera_sensor]
full_well_e = 10500
read_noise_e = 2.4
bit_depth = 12
[display]
position_mm = [0, 0, -30]
{}
[[object]]
name = "lens"
shape = "lens"
front_radius_mm = 51.5
back_radius_mm = -51.5
centre_thickness_mm = 5
diameter_mm = 25.4
material = "dielectric"
ior = 1.5168
{}
)",
                     display, extraObjects);
}

struct Lighting {
  double fractionLit;  // of the pixels within 0.9 R, those at least half their median
  double cv;           // their standard deviation over their mean
  double particle;     // the mean within 1 mm of the centre over the mean within 0.9 R
};

// The drive scale: the 99.9th percentile of the radiance, as Controller::defaultWhite takes it.
double white(const cv::Mat& radiance) {
  const double w = percentile(radiance, 0.999);
  return w > 0 ? w : 1.0;
}

// Shows `panel` (the display's drive levels) or `reference` (encoded) on the
// bench of `scene`, grabs a frame, and measures it over the lens.
Lighting inspect(const std::filesystem::path& scene, const LightField* reference, const cv::Mat* panel) {
  const std::string uri = "sim:" + scene.string();
  auto display = openDisplay(uri);
  auto camera = openCamera(uri);
  const PresentResult shown = display->show(
      reference ? encodeLightField(*reference, DisplayOptics(display->info()), white(reference->lensletImage()))
                : *panel);
  EXPECT_EQ(shown.status, PresentStatus::Presented);
  camera->configure({.exposure_us = 2000, .pixelFormat = PixelFormat::Mono12, .trigger = TriggerMode::Software});
  camera->start(1);
  camera->softwareTrigger();
  const Frame frame = camera->grab(std::chrono::seconds(120));
  EXPECT_EQ(frame.status, FrameStatus::Complete);
  std::vector<double> inner;
  double centreSum = 0, centreCount = 0;
  const double middle = 0.5 * (frame.image.cols - 1);
  for (int row = 0; row < frame.image.rows; ++row)
    for (int col = 0; col < frame.image.cols; ++col) {
      const double r_mm = std::hypot(col - middle, row - middle) * kObjectPixel_mm;
      const double v = frame.image.at<std::uint16_t>(row, col);
      if (r_mm < 0.9 * kLensRadius_mm) inner.push_back(v);
      if (r_mm < 1.0) centreSum += v, ++centreCount;
    }
  std::vector<double> sorted = inner;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(sorted.size() / 2), sorted.end());
  const double median = sorted[sorted.size() / 2];
  double lit = 0, sum = 0, sum2 = 0;
  for (double v : inner) {
    lit += v >= 0.5 * median ? 1 : 0;
    sum += v;
    sum2 += v * v;
  }
  const double n = static_cast<double>(inner.size()), mean = sum / n;
  return {lit / n, std::sqrt(std::max(0.0, sum2 / n - mean * mean)) / mean, centreSum / centreCount / mean};
}

// The reference captured by the simulated lensless sensor (the controller's default URI).
LightField sensorReference(const std::filesystem::path& scene) {
  return openLightFieldCapture("sim:" + scene.string())->capture();
}

Lighting inspectIntactLens(const std::filesystem::path& scene) {
  const LightField reference = sensorReference(scene);
  return inspect(scene, &reference, nullptr);
}

TEST(DisplayParallax, AFullParallaxDisplayLightsTheWholeIntactLens) {
  registerSimBackends();
  TestFolder dir("lfi-parallax");
  // The default lenslet array (1 mm square lenses, 40 degree cone) and the
  // default lenticular sheet (7.2 px lenses slanted 10.5 degrees, 40 degree
  // cone across the lenses), each covering the 10 mm through which the lens
  // sends the capture beam at the display.
  const Lighting full = inspectIntactLens(
      dir.write("full.toml", benchText("optics = \"lenslet_array\"\npanel_width_px = 640\npanel_height_px = 640")));
  const Lighting lenticular = inspectIntactLens(
      dir.write("lenticular.toml", benchText("optics = \"lenticular\"\npanel_width_px = 640\npanel_height_px = 400")));
  std::printf("lit within 0.9 R: lenslet array %.3f (cv %.3f), lenticular %.3f (cv %.3f)\n", full.fractionLit, full.cv,
              lenticular.fractionLit, lenticular.cv);
  RecordProperty("lenslet_array_fraction_lit", std::to_string(full.fractionLit));
  RecordProperty("lenticular_fraction_lit", std::to_string(lenticular.fractionLit));
  // The lens bends the rays it needs by up to 14 degrees in every direction
  // around the axis; the lenslet array sends every direction of its 40 degree
  // cone from every lens, so all of the lens is lit.
  EXPECT_GE(full.fractionLit, 0.95);
  // What is left is a grain: the sensor's shot noise (about 1.5 % at half its
  // 10 500 e- well) and the display's sampling (1 mm lenses, 23 mrad per
  // subpixel against the camera's 30 mrad acceptance). At most 10 %.
  EXPECT_LE(full.cv, 0.10);
  // The lenticular sheet sends rays in the plane across its lens axes only,
  // nearly horizontal: the lens's top and bottom, which need rays bent up or
  // down by more than a subpixel's height allows, stay dark, and at most 80 %
  // of the lens is lit.
  EXPECT_LE(lenticular.fractionLit, 0.80);
}

}  // namespace
}  // namespace lfi::sim

namespace lfi::sim {
namespace {

// The two ways to capture the reference on the same bench: the lensless light
// field sensor, then encoded into the panel (resampled through the light
// field's parametrisation), and the display's own ray space (every subpixel's
// rays traced back through the intact lens to the beam: no resampling). Both
// must light the intact lens and show an absorbing particle at its centre as
// dark; the test states how they compare (docs/performance.md has the figures).
TEST(DisplayParallax, BothReferenceCapturesLightTheLensAndShowAParticle) {
  registerSimBackends();
  TestFolder dir("lfi-capture-paths");
  const std::string display = "optics = \"lenslet_array\"\npanel_width_px = 640\npanel_height_px = 640";
  const auto intact = dir.write("intact.toml", benchText(display));
  const auto particle = dir.write("particle.toml", benchText(display,
                                                             "[[object]]\nname = \"particle\"\nshape = \"sphere\"\n"
                                                             "radius_mm = 1.5\nmaterial = \"absorber\""));

  const auto t0 = std::chrono::steady_clock::now();
  const LightField reference = sensorReference(intact);
  const auto t1 = std::chrono::steady_clock::now();
  SimCaptureSettings settings;
  settings.samplesPerPixel = 8;
  settings.beamHalfAngle_rad = 0.0152;  // the camera's acceptance: stop radius / f = 0.3045 / 20.03
  const cv::Mat radiance = capturePanelReference(intact, settings);
  const auto t2 = std::chrono::steady_clock::now();
  cv::Mat panel;  // drive levels: 255 at the 99.9th percentile, as the encode's white
  radiance.convertTo(panel, CV_8U, 255.0 / white(radiance), 0.5);
  panel = panel.reshape(3, radiance.rows);  // (RGB stripe: three subpixels a pixel)

  const Lighting sensorIntact = inspect(intact, &reference, nullptr);
  const Lighting sensorParticle = inspect(particle, &reference, nullptr);
  const Lighting panelIntact = inspect(intact, nullptr, &panel);
  const Lighting panelParticle = inspect(particle, nullptr, &panel);
  const auto seconds = [](auto a, auto b) { return std::chrono::duration<double>(b - a).count(); };
  std::printf("sensor path: lit %.3f, cv %.3f, particle %.3f of the mean (capture %.2f s)\n", sensorIntact.fractionLit,
              sensorIntact.cv, sensorParticle.particle, seconds(t0, t1));
  std::printf("panel path:  lit %.3f, cv %.3f, particle %.3f of the mean (capture %.2f s)\n", panelIntact.fractionLit,
              panelIntact.cv, panelParticle.particle, seconds(t1, t2));
  RecordProperty("sensor_path_cv", std::to_string(sensorIntact.cv));
  RecordProperty("panel_path_cv", std::to_string(panelIntact.cv));
  // The sensor's reference, encoded, lights every direction near the one the
  // lens needs (the light field's 16 angular elements over the hemisphere are
  // interpolated), so the lens is lit smoothly. The display-space reference
  // lights each subpixel by the share of its rays that leave the lens within
  // the camera's acceptance (the capture beam's half-angle is the camera's,
  // 0.0152 rad): selective, but each level is a mean of 8 rays, and a subpixel
  // that one ray in eight reaches is lit at 1/8 with a relative error of
  // sqrt(7) ≈ 2.6: a grain that leaves some pixels under half the median.
  EXPECT_GE(sensorIntact.fractionLit, 0.95);
  EXPECT_GE(panelIntact.fractionLit, 0.90);
  EXPECT_LT(sensorIntact.cv, panelIntact.cv);
  // The particle (Ø 3 mm, opaque) covers the whole 1 mm disc it is measured
  // in; what light reaches there is the camera's blur and the display's
  // coarser rays around it: under a quarter of the lens's mean.
  for (const Lighting& withParticle : {sensorParticle, panelParticle}) EXPECT_LT(withParticle.particle, 0.25);
}

}  // namespace
}  // namespace lfi::sim
