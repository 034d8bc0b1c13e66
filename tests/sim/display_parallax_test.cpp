// The method on the bench it drives: the intact reference lens lit by the
// light field it produces, emitted by a full-parallax lenslet-array display and
// by a horizontal-parallax lenticular display, seen by a telecentric camera of
// 224 x 224 pixels over the lens. Capture (the sim: lensless sensor), emit (the
// sim: display's physical emitter) and inspect (the sim: camera), through the
// device interfaces as the controller runs them.

#include "lfi/drivers/camera_registry.h"
#include "lfi/drivers/capture_registry.h"
#include "lfi/drivers/display_registry.h"
#include "lfi/sim/devices/sim_camera.h"
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

std::string benchText(const std::string& display) {
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
)",
                     display);
}

struct Lighting {
  double fractionLit;  // of the pixels within 0.9 R, those at least half their median
  double cv;           // their standard deviation over their mean
};

// Capture, emit, inspect; the frame's statistics over the lens within 0.9 R.
Lighting inspectIntactLens(const std::filesystem::path& scene) {
  const std::string uri = "sim:" + scene.string();
  auto capture = openLightFieldCapture(uri);
  const LightField reference = capture->capture();
  auto display = openDisplay(uri);
  auto camera = openCamera(uri);
  const double white = [&] {  // the controller's: the 99.9th percentile of the light field
    std::vector<float> values(reference.lensletImage().begin<float>(), reference.lensletImage().end<float>());
    std::nth_element(values.begin(), values.begin() + static_cast<long>(0.999 * values.size()), values.end());
    return static_cast<double>(values[static_cast<size_t>(0.999 * values.size())]);
  }();
  EXPECT_EQ(display->show(reference, white).status, PresentStatus::Presented);
  camera->configure({.exposure_us = 2000, .pixelFormat = PixelFormat::Mono12, .trigger = TriggerMode::Software});
  camera->start(1);
  camera->softwareTrigger();
  const Frame frame = camera->grab(std::chrono::seconds(120));
  EXPECT_EQ(frame.status, FrameStatus::Complete);
  std::vector<double> inner;
  const double centre = 0.5 * (frame.image.cols - 1);
  for (int row = 0; row < frame.image.rows; ++row)
    for (int col = 0; col < frame.image.cols; ++col)
      if (std::hypot(col - centre, row - centre) * kObjectPixel_mm < 0.9 * kLensRadius_mm)
        inner.push_back(frame.image.at<std::uint16_t>(row, col));
  std::vector<double> sorted = inner;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(sorted.size() / 2), sorted.end());
  const double median = sorted[sorted.size() / 2];
  double lit = 0, sum = 0, sum2 = 0;
  for (double v : inner) {
    lit += v >= 0.5 * median ? 1 : 0;
    sum += v;
    sum2 += v * v;
  }
  const double mean = sum / static_cast<double>(inner.size());
  return {lit / static_cast<double>(inner.size()),
          std::sqrt(std::max(0.0, sum2 / static_cast<double>(inner.size()) - mean * mean)) / mean};
}

TEST(DisplayParallax, AFullParallaxDisplayLightsTheWholeIntactLens) {
  registerSimBackends();
  TestFolder dir("lfi-parallax");
  // The default lenslet array (1 mm square lenses, 40 degree cone) and the
  // default lenticular sheet (7.2 px lenses slanted 10.5 degrees, 40 degree
  // cone across the lenses), each covering the 10 mm through which the lens
  // sends the capture beam at the display.
  const Lighting full = inspectIntactLens(
      dir.write("full.toml", benchText("optics = \"lenslet_array\"\npanel_width_px = 800\npanel_height_px = 800")));
  const Lighting lenticular = inspectIntactLens(
      dir.write("lenticular.toml", benchText("optics = \"lenticular\"\npanel_width_px = 640\npanel_height_px = 400")));
  std::printf("lit within 0.9 R: lenslet array %.3f (cv %.3f), lenticular %.3f (cv %.3f)\n", full.fractionLit,
              full.cv, lenticular.fractionLit, lenticular.cv);
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
