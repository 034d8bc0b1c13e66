// SPDX-License-Identifier: Apache-2.0
// The camera's exposure for the bench (exposure_calibration.h).

#include "lfi/controller/exposure_calibration.h"

#include "lfi/controller/bench_devices.h"
#include "lfi/core/error.h"

#include "optics_table.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

namespace lfi {

namespace {

constexpr int kRounds = 8;
constexpr double kPercentile = 0.999, kTolerance = 0.01;

double quantile(const cv::Mat& image, double q) {
  std::vector<float> v(image.begin<float>(), image.end<float>());
  const auto at = v.begin() + static_cast<std::ptrdiff_t>(q * static_cast<double>(v.size() - 1));
  std::nth_element(v.begin(), at, v.end());
  return *at;
}

}  // namespace

ExposureCalibration calibrateExposure(Camera& camera, Display& display, const CameraSettings& settings,
                                      ControllerOptions options, const ExposureCalibrationSettings& calibration,
                                      const std::function<void(double)>& progress) {
  if (!(calibration.fraction >= 0.05 && calibration.fraction <= 0.98))
    fail(Errc::InvalidArgument, "calibrate exposure: fraction {} is outside 0.05 .. 0.98", calibration.fraction);
  const auto t0 = std::chrono::steady_clock::now();
  options.correction = nullptr;
  const std::string name = camera.info().deviceId;
  const DisplayInfo panel = display.info();
  const cv::Mat white(panel.panelHeight_px, panel.panelWidth_px, CV_8UC1, cv::Scalar(255)),
      black(panel.panelHeight_px, panel.panelWidth_px, CV_8UC1, cv::Scalar(0));
  ExposureCalibration out;
  out.startExposure_us = settings.exposure_us;
  out.fullScale_dn = (1 << significantBits(settings.pixelFormat)) - 1;
  CameraSettings s = settings;
  for (int round = 1; round <= kRounds; ++round) {
    if (camera.state() == Camera::State::Streaming) camera.stop();
    try {
      camera.configure(s);
    } catch (const Error& e) {
      fail(Errc::Device,
           "calibrate exposure: camera '{}' refuses the exposure of {:.6g} us the bench's light needs ({}): more "
           "light, or a gain",
           name, s.exposure_us, e.what());
    }
    NoCapture nothing;
    cv::Mat image, dark;
    {
      Controller controller(nothing, display, camera, options);
      image = controller.probe().take(white);
      dark = controller.probe().take(black);
    }
    out.rounds = round;
    out.exposure_us = camera.settings().exposure_us;
    out.dark_dn = quantile(dark, 0.5);
    out.brightest_dn = quantile(image, kPercentile) - out.dark_dn;
    if (progress) progress(static_cast<double>(round) / kRounds);
    const int saturated = cv::countNonZero(image >= out.fullScale_dn - 0.5);
    const double wanted = calibration.fraction * out.fullScale_dn - out.dark_dn;
    if (!(out.brightest_dn > 0.01 * wanted) && saturated == 0)
      fail(Errc::Device,
           "calibrate exposure: camera '{}' sees the display all white no brighter than dark ({:.3g} DN above its "
           "{:.3g} DN at {:.6g} us): is the display on and in view, the lens uncapped?",
           name, out.brightest_dn, out.dark_dn, out.exposure_us);
    if (saturated == 0 && std::abs(out.brightest_dn / wanted - 1) <= kTolerance) {
      out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      return out;
    }
    // Saturated pixels say nothing of how far beyond full scale they are: halve first.
    s.exposure_us = saturated > 0 ? out.exposure_us * std::min(0.5, wanted / std::max(out.brightest_dn, 1.0))
                                  : out.exposure_us * wanted / out.brightest_dn;
  }
  fail(Errc::Device,
       "calibrate exposure: camera '{}' did not settle in {} rounds: the brightest pixels at {:.3g} of full scale at "
       "{:.6g} us, {:.3g} wanted (a camera that is not linear in its exposure, or light that changes)",
       name, kRounds, (out.brightest_dn + out.dark_dn) / out.fullScale_dn, out.exposure_us, calibration.fraction);
}

void setExposureCalibration(BenchFileEdit& edit, const ExposureCalibration& c, double fraction,
                            const std::string& stampUtc) {
  edit.set("camera", "exposure_us", detail::tomlNumber(c.exposure_us),
           fmt::format("lfi calibrate exposure {}: the brightest pixels at {:g} of full scale", stampUtc, fraction));
  edit.remove("camera", "dark_frame");
  edit.remove("camera", "flat_frame");
}

std::string exposureCalibrationRecord(const ExposureCalibration& c, double fraction, const BenchFile& bench,
                                      const std::string& stampUtc, const std::string& cameraDescription) {
  const nlohmann::json record = {
      {"format", "lfi-calibration-record"},
      {"version", 1},
      {"what", "exposure"},
      {"time_utc", stampUtc},
      {"bench", bench.file.string()},
      {"units", "µs, camera digital numbers (DN) of the pixel format"},
      {"method",
       "the intact part in view, the display all white; the exposure scaled until the image's 99.9th percentile "
       "less the dark median sits at the fraction of full scale, no pixel saturated (docs/calibration.md)"},
      {"camera", {{"uri", bench.cameraUri.text()}, {"device", cameraDescription}}},
      {"fraction", fraction},
      {"exposure_us", c.exposure_us},
      {"previous_exposure_us", c.startExposure_us},
      {"brightest_dn", c.brightest_dn},
      {"dark_dn", c.dark_dn},
      {"full_scale_dn", c.fullScale_dn},
      {"rounds", c.rounds},
      {"seconds", c.seconds},
  };
  return record.dump(2) + "\n";
}

}  // namespace lfi
