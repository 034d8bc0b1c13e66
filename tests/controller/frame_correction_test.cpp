// SPDX-License-Identifier: Apache-2.0
// Dark and flat frames (frame_correction.h): the correction's known answer on
// synthetic frames, its refusals, the frame files' round trip and checks, and
// through the ray-traced bench a camera with a black level, dark and response
// non-uniformity and vignetting corrected to its noise.

#include "lfi/controller/frame_correction.h"

#include "lfi/controller/bench_devices.h"
#include "lfi/controller/controller.h"
#include "lfi/core/exr_io.h"
#include "lfi/drivers/camera_registry.h"
#include "lfi/drivers/display_registry.h"
#include "lfi/sim/devices/sim_camera.h"

#include "calibration_bench.h"
#include "lfi_test_support.h"
#include "scene_text.h"
#include "test_folder.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>

namespace lfi {
namespace {

using testing_support::benchCameraSettings;
using testing_support::cameraSceneText;
using testing_support::inspectionBenchCamera;
using testing_support::TestFolder;
using testing_support::throwsError;

CalibrationFrame frame(CalibrationFrameKind kind, cv::Mat image) {
  CalibrationFrame f;
  f.kind = kind;
  f.image = std::move(image);
  f.camera = "sim:test";
  f.settings = benchCameraSettings();  // Mono12: full scale 4095 DN
  f.frames = 64;
  return f;
}

// A sensor's pattern: offsets about 64 DN and responses about 1, both varying by pixel.
struct Pattern {
  cv::Mat offset = cv::Mat(40, 60, CV_32FC1), response = cv::Mat(40, 60, CV_32FC1);
  Pattern() {
    cv::RNG rng(7);
    rng.fill(offset, cv::RNG::UNIFORM, 60.0, 70.0);
    rng.fill(response, cv::RNG::UNIFORM, 0.8, 1.1);
  }
  cv::Mat image(double signal_dn) const { return offset + signal_dn * response; }
};

TEST(FrameCorrection, AnImageOfAnyLevelComesOutUniformAtTheMedianPixelsResponse) {
  const Pattern p;
  const FrameCorrection c(frame(CalibrationFrameKind::Dark, p.offset),
                          frame(CalibrationFrameKind::Flat, p.image(2000)));
  // The median pixel's response (the median of flat - dark over 2000 DN).
  std::vector<float> r(p.response.begin<float>(), p.response.end<float>());
  std::nth_element(r.begin(), r.begin() + static_cast<std::ptrdiff_t>(r.size() / 2), r.end());
  const double median = r[r.size() / 2];
  for (const double level : {0.0, 100.0, 1500.0}) {
    cv::Mat image = p.image(level);
    c.apply(image);
    double least = 0, most = 0;
    cv::minMaxLoc(image, &least, &most);
    // float arithmetic on values up to 4095: a few ulp of it.
    EXPECT_NEAR(least, level * median, 2e-3) << "level " << level;
    EXPECT_NEAR(most, level * median, 2e-3) << "level " << level;
  }
  // A pixel the image saturates stays at full scale.
  cv::Mat image = p.image(1500);
  image.at<float>(3, 4) = 4095;
  c.apply(image);
  EXPECT_EQ(image.at<float>(3, 4), 4095.0f);
  // Without a flat frame, the dark frame alone.
  const FrameCorrection darkOnly(frame(CalibrationFrameKind::Dark, p.offset), std::nullopt);
  cv::Mat dark = p.image(500);
  darkOnly.apply(dark);
  EXPECT_LT(cv::norm(dark, cv::Mat(500 * p.response), cv::NORM_INF), 1e-3);
}

TEST(FrameCorrection, FlatFramesThatCannotCorrectAreRefusedByName) {
  const Pattern p;
  const CalibrationFrame dark = frame(CalibrationFrameKind::Dark, p.offset);
  auto flat = [&](cv::Mat image) {
    CalibrationFrame f = frame(CalibrationFrameKind::Flat, std::move(image));
    f.file = "flat.exr";
    return f;
  };
  cv::Mat saturated = p.image(2000);
  saturated.at<float>(5, 7) = 4095;
  EXPECT_TRUE(throwsError([&] { FrameCorrection(dark, flat(saturated)); }, Errc::Config,
                          {"flat frame 'flat.exr'", "1 saturated pixels", "(7, 5)", "lower the exposure"}));
  cv::Mat deadPixel = p.image(2000);
  deadPixel.at<float>(9, 11) = 64 + 0.19f * 2000;  // under 0.2 of the median response
  EXPECT_TRUE(throwsError([&] { FrameCorrection(dark, flat(deadPixel)); }, Errc::Config,
                          {"flat frame 'flat.exr'", "1 pixels that respond less than 0.2", "(11, 9)"}));
  // The light off for the flat frame (or on for the dark one): no brighter than the dark frame.
  EXPECT_TRUE(throwsError([&] { FrameCorrection(dark, flat(p.image(0.5))); }, Errc::Config,
                          {"flat frame 'flat.exr' is no brighter than the dark frame", "median difference"}));
  EXPECT_TRUE(throwsError([&] { FrameCorrection(frame(CalibrationFrameKind::Dark, p.image(2000)), flat(p.offset)); },
                          Errc::Config, {"no brighter than the dark frame"}));
  // Frames of other settings or sizes than each other, or the bench's.
  CalibrationFrame longer = flat(p.image(2000));
  longer.settings.exposure_us = 20000;
  EXPECT_TRUE(throwsError([&] { FrameCorrection(dark, longer); }, Errc::Config,
                          {"flat frame 'flat.exr'", "exposure_us 20000 against 10000"}));
  EXPECT_TRUE(throwsError([&] { FrameCorrection(dark, flat(p.image(2000)(cv::Rect(0, 0, 30, 40)).clone())); },
                          Errc::Config, {"30 x 40", "60 x 40"}));
  const FrameCorrection c(dark, flat(p.image(2000)));
  CameraSettings bench = benchCameraSettings();
  bench.pixelFormat = PixelFormat::Mono16;
  EXPECT_TRUE(throwsError([&] { c.requireSettings(bench, "bench.toml: [camera]"); }, Errc::Config,
                          {"bench.toml: [camera]", "pixel_format Mono12 against Mono16", "take it again"}));
  cv::Mat binned(20, 30, CV_32FC1, cv::Scalar(100));
  EXPECT_TRUE(throwsError([&] { c.apply(binned); }, Errc::Config, {"30 x 20", "60 x 40", "region and binning"}));
}

TEST(FrameCorrection, FramesRoundTripThroughTheirFilesWhichNameWhatIsWrong) {
  TestFolder dir("frame_correction");
  const Pattern p;
  CalibrationFrame dark = frame(CalibrationFrameKind::Dark, p.offset);
  dark.settings.gain = 2.5;
  writeCalibrationFrame(dir.path() / "dark.exr", dark);
  const CalibrationFrame back = readCalibrationFrame(dir.path() / "dark.exr", CalibrationFrameKind::Dark);
  EXPECT_EQ(cv::norm(back.image, dark.image, cv::NORM_INF), 0.0);
  EXPECT_EQ(back.camera, dark.camera);
  EXPECT_EQ(back.settings.exposure_us, dark.settings.exposure_us);
  EXPECT_EQ(back.settings.gain, 2.5);
  EXPECT_EQ(back.settings.pixelFormat, PixelFormat::Mono12);
  EXPECT_EQ(back.settings.binning, 1);
  EXPECT_EQ(back.frames, 64);
  EXPECT_EQ(back.file, dir.path() / "dark.exr");
  // Never replaced; a dark frame is not a flat one; a radiance image is neither.
  EXPECT_TRUE(throwsError([&] { writeCalibrationFrame(dir.path() / "dark.exr", dark); }, Errc::Exists, {"dark.exr"}));
  EXPECT_TRUE(throwsError([&] { readCalibrationFrame(dir.path() / "dark.exr", CalibrationFrameKind::Flat); },
                          Errc::InvalidFile, {"dark.exr", "a dark frame", "where a flat frame belongs"}));
  RadianceImageInfo info;
  info.pixelUnit = kCameraDigitalNumbers;
  writeRadianceExr(dir.path() / "image.exr", p.offset, info);
  EXPECT_TRUE(throwsError([&] { readCalibrationFrame(dir.path() / "image.exr", CalibrationFrameKind::Dark); },
                          Errc::InvalidFile, {"image.exr", "'lfi.settings.kind' is missing"}));
  writeRadianceExr(dir.path() / "radiance.exr", p.offset, {});
  EXPECT_TRUE(throwsError([&] { readCalibrationFrame(dir.path() / "radiance.exr", CalibrationFrameKind::Dark); },
                          Errc::InvalidFile, {"radiance.exr", "not a camera's dark frame"}));
}

// The inspection bench's camera with a fixed pattern, over the display with
// nothing in view (dark) or a uniform source in the part's place (flat, and the image corrected).
class FrameCorrectionOnTheBench : public testing::Test {
 protected:
  void SetUp() override { sim::registerSimBackends(); }

  // `seed`: the frames' noise (a sim: camera's frames of one seed repeat theirs at every opening); the
  // pattern is the sensor's, the same at every seed.
  std::string scene(bool source, int seed = 3) {
    std::string text = cameraSceneText(inspectionBenchCamera(4, seed)) +
                       "black_level_dn = 64\ndark_fpn_dn = 2\ngain_fpn = 0.02\nvignetting = 0.15\n"
                       "[display]\nposition_mm = [0, 0, -30]\noptics = \"lenslet_array\"\n"
                       "panel_width_px = 800\npanel_height_px = 800\n";
    if (source)  // radiance 0.75: 5250 e- of the 10 500 e- well at 10 ms
      text +=
          "[[object]]\nname = \"source\"\nshape = \"rectangle\"\nsize_mm = [40, 40]\nemitter = \"lambertian\"\n"
          "radiance = 0.75\n";
    return "sim:" + dir_.write(fmt::format("{}-{}.toml", source ? "flat" : "dark", seed), text).string();
  }

  // The frame taken through the bench on `uri`, the mean of `frames` frames; with a correction, corrected.
  template <typename Take>
  auto through(const std::string& uri, int frames, Take&& take,
               std::shared_ptr<const FrameCorrection> correction = nullptr) {
    auto display = openDisplay(uri);
    auto camera = openCamera(uri);
    camera->configure(benchCameraSettings());
    NoCapture nothing;
    ControllerOptions options;
    options.frames = frames;
    options.correction = std::move(correction);
    Controller controller(nothing, *display, *camera, options);
    return take(controller.probe(), *camera);
  }

  CalibrationFrame take(CalibrationFrameKind kind, int frames) {
    return through(scene(kind == CalibrationFrameKind::Flat), frames, [&](BenchProbe& probe, Camera& camera) {
      return takeCalibrationFrame(probe, kind, camera.info().deviceId, camera.settings(), frames);
    });
  }

  TestFolder dir_{"frame_correction_bench"};
};

double variation(const cv::Mat& image) {
  cv::Scalar mean, sigma;
  cv::meanStdDev(image, mean, sigma);
  return sigma[0] / mean[0];
}

TEST_F(FrameCorrectionOnTheBench, ACamerasFixedPatternIsCorrectedToItsNoise) {
  constexpr int kFrames = 64, kImageFrames = 16;
  const CalibrationFrame dark = take(CalibrationFrameKind::Dark, kFrames);
  // The dark frame is the black level (a pixel's mean of 64 frames: its 2 DN spread, 0.12 DN of read noise).
  cv::Scalar darkMean, darkSpread;
  cv::meanStdDev(dark.image, darkMean, darkSpread);
  EXPECT_NEAR(darkMean[0], 64, 5 * 2 / 56.0);
  EXPECT_NEAR(darkSpread[0], 2, 0.5);
  const auto correction = std::make_shared<const FrameCorrection>(dark, take(CalibrationFrameKind::Flat, kFrames));
  const auto image = [&](std::shared_ptr<const FrameCorrection> c) {
    return through(
        scene(true, 4), kImageFrames,
        [](BenchProbe& probe, Camera&) { return probe.take(cv::Mat(800, 800, CV_8UC1, cv::Scalar(255))); },
        std::move(c));
  };
  const cv::Mat raw = image(nullptr), corrected = image(correction);
  // What remains is the noise of a pixel's mean: its shot noise of 5250 e- (less at the vignetted corners) over
  // the image's 16 frames and the flat frame's 64: sqrt(1/16 + 1/64) / sqrt(5250 · 0.85) = 0.43 %.
  const double noise = std::sqrt(1.0 / kImageFrames + 1.0 / kFrames) / std::sqrt(5250 * 0.85);
  EXPECT_LT(variation(corrected), 1.5 * noise) << "raw " << variation(raw);
  EXPECT_GT(variation(corrected), 0.5 * noise);
  // Uncorrected, the pattern: the vignetting's spread over a square field, 0.15 · sqrt(2/45) = 3.2 %, and the
  // 2 % PRNU, over the mean response 0.95: 3.9 %; 3.8 % with the black level's 64 DN under 1950 DN of signal.
  EXPECT_GT(variation(raw), 0.032);
  EXPECT_LT(variation(raw), 0.045);
}

}  // namespace
}  // namespace lfi
