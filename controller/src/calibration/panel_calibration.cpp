// SPDX-License-Identifier: Apache-2.0
// The panel's response and backlight through the camera (panel_calibration.h).

#include "lfi/controller/panel_calibration.h"

#include "lfi/core/error.h"

#include "optics_table.h"
#include "record_json.h"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>

namespace lfi {

namespace {

using Clock = std::chrono::steady_clock;

// The mean of `image` over `mask`.
double meanOver(const cv::Mat& image, const cv::Mat& mask) {
  return cv::mean(image, mask)[0];
}

// The noise of the mean over `mask` of one image, from two images alike: their difference's spread over sqrt(2)
// and the root of the pixels' count.
double noiseOfMean(const cv::Mat& a, const cv::Mat& b, const cv::Mat& mask) {
  cv::Scalar mean, sigma;
  cv::meanStdDev(a - b, mean, sigma, mask);
  return sigma[0] / std::sqrt(2.0) / std::sqrt(static_cast<double>(cv::countNonZero(mask)));
}

// The six terms of B at display point (x, y).
std::array<double, 6> backlightTerms(double x, double y) {
  return {1, x, y, x * x, x * y, y * y};
}

}  // namespace

PanelCalibration calibratePanel(BenchProbe& bench, const calib::CameraMap& map, const std::string& camera,
                                const PanelCalibrationSettings& settings, const std::function<void(double)>& progress) {
  if (settings.levelStep < 1 || settings.levelStep > 128)
    fail(Errc::InvalidArgument, "calibrate panel: level step {} is outside 1 .. 128", settings.levelStep);
  if (!(settings.coverageFactor > 0))
    fail(Errc::InvalidArgument, "calibrate panel: coverage factor {} must be positive", settings.coverageFactor);
  const auto t0 = Clock::now();
  PanelCalibration out;
  out.display = bench.display();
  out.coverageFactor = settings.coverageFactor;
  const DisplayInfo& info = out.display;
  const int sub = info.subpixelsPerPixel(), curves = sub == 3 ? 3 : 1;
  std::vector<double>& levels = out.response.levels;
  for (int v = 0; v < 255; v += settings.levelStep) levels.push_back(v);
  levels.push_back(255);
  const int images = 4 + curves * (static_cast<int>(levels.size()) - 1);
  int taken = 0;
  const auto take = [&](const cv::Mat& panel) {
    cv::Mat image = bench.take(panel);
    if (progress) progress(static_cast<double>(++taken) / images);
    return image;
  };
  // One colour's subpixels at `level`, the others dark (curve -1: every subpixel, as on a mono panel).
  const auto panel = [&](int level, int curve) {
    cv::Mat p(info.panelHeight_px, info.panelWidth_px, info.panelType(), cv::Scalar::all(curve < 0 ? level : 0));
    if (curve >= 0) {
      const int channel = info.subpixels == SubpixelLayout::BgrStripe ? 2 - curve : curve;
      std::vector<cv::Mat> planes;
      cv::split(p, planes);
      planes[static_cast<std::size_t>(channel)].setTo(level);
      cv::merge(planes, p);
    }
    return p;
  };
  const cv::Mat dark = take(panel(0, -1)), white = take(panel(255, -1));
  // The camera pixels that see the panel, two camera pixels in from its edges.
  const cv::Size size = dark.size();
  const double margin = 2 * map.objectPixel_mm();
  const double halfX = info.panelWidth_px * info.pixelPitch_mm / 2 - margin,
               halfY = info.panelHeight_px * info.pixelPitch_mm / 2 - margin;
  cv::Mat mask(size, CV_8UC1, cv::Scalar(0));
  std::vector<std::pair<cv::Point, Vec2>> seen;
  for (int v = 0; v < size.height; ++v)
    for (int u = 0; u < size.width; ++u) {
      const Vec2 q = map.displayPoint({static_cast<double>(u), static_cast<double>(v)}, size);
      if (std::abs(q.x) <= halfX && std::abs(q.y) <= halfY) {
        mask.at<std::uint8_t>(v, u) = 255;
        seen.emplace_back(cv::Point(u, v), q);
      }
    }
  out.pixels = static_cast<int>(seen.size());
  if (out.pixels < 100)
    fail(Errc::Device,
         "calibrate panel: camera '{}' sees the panel with {} pixels (at least 100): is the camera map of the bench's "
         "[geometry] this camera's?",
         camera, out.pixels);
  const double m0 = meanOver(dark, mask);
  out.darkClipped = static_cast<double>(cv::countNonZero((dark <= 0) & mask)) / out.pixels;
  // Every curve's points.
  std::vector<std::vector<double>> means(static_cast<std::size_t>(curves));
  for (int c = 0; c < curves; ++c) {
    means[static_cast<std::size_t>(c)].push_back(m0);
    for (std::size_t i = 1; i < levels.size(); ++i)
      means[static_cast<std::size_t>(c)].push_back(
          meanOver(take(panel(static_cast<int>(levels[i]), curves == 1 ? -1 : c)), mask));
  }
  // The repeats: the noise of a mean, and no drift from the first images to the last.
  const cv::Mat darkAgain = take(panel(0, -1)), whiteAgain = take(panel(255, -1));
  const double whiteNoise = noiseOfMean(white, whiteAgain, mask), darkNoise = noiseOfMean(dark, darkAgain, mask);
  out.meanNoise_dn = std::max(whiteNoise, darkNoise);
  out.fullLight_dn = meanOver(white, mask) - m0;
  if (!(out.fullLight_dn > 100 * out.meanNoise_dn))
    fail(Errc::Device,
         "calibrate panel: camera '{}' sees the panel rise by {:.3g} DN from dark to full drive, under 100 times the "
         "noise of a mean ({:.3g} DN): is the display on and in view, the lens uncapped?",
         camera, out.fullLight_dn, out.meanNoise_dn);
  // A mean's variance grows with its light as shot noise does: from the dark pair's to the white pair's.
  const auto variance = [&](double mean) {
    const double d2 = darkNoise * darkNoise, w2 = whiteNoise * whiteNoise;
    return d2 + std::max(0.0, w2 - d2) * std::max(0.0, mean - m0) / out.fullLight_dn;
  };
  for (int c = 0; c < curves; ++c) {
    const std::vector<double>& m = means[static_cast<std::size_t>(c)];
    const double full = m.back() - m0, fullVariance = variance(m.back()), darkVariance = darkNoise * darkNoise;
    std::vector<double> light, lightSigma;
    for (const double mean : m) {
      // R = a / b, a = m(v) - m0, b = m(255) - m0, m0 in both: var R = (var a + R^2 var b - 2 R var m0) / b^2.
      const double r = (mean - m0) / full;
      const double va = variance(mean) + darkVariance, vb = fullVariance + darkVariance;
      light.push_back(std::clamp(r, 0.0, 1.0));
      lightSigma.push_back(std::sqrt(std::max(0.0, va + r * r * vb - 2 * r * darkVariance)) / full);
    }
    light.front() = 0;
    light.back() = 1;
    lightSigma.front() = lightSigma.back() = 0;
    // Noise can make a flat stretch fall by a hair: the curve keeps its greatest value so far.
    for (std::size_t i = 1; i < light.size(); ++i) light[i] = std::max(light[i], light[i - 1]);
    out.response.light.push_back(std::move(light));
    out.lightSigma.push_back(std::move(lightSigma));
  }
  // The backlight: white less dark at each seen pixel's display point.
  cv::Mat a(out.pixels, 6, CV_64FC1), b(out.pixels, 1, CV_64FC1);
  for (int i = 0; i < out.pixels; ++i) {
    const auto& [px, q] = seen[static_cast<std::size_t>(i)];
    const std::array<double, 6> t = backlightTerms(q.x, q.y);
    for (int j = 0; j < 6; ++j) a.at<double>(i, j) = t[static_cast<std::size_t>(j)];
    b.at<double>(i) = white.at<float>(px) - dark.at<float>(px);
  }
  cv::Mat coefficients;
  cv::solve(a, b, coefficients, cv::DECOMP_SVD);
  const cv::Mat residual = a * coefficients - b;
  const double c0 = coefficients.at<double>(0);
  const double dof = std::max(1, out.pixels - 6);
  const double residualVariance = residual.dot(residual) / dof;
  out.backlightResidual = std::sqrt(residualVariance) / c0;
  const cv::Mat covariance = (a.t() * a).inv(cv::DECOMP_SVD) * residualVariance;
  for (int j = 0; j < 6; ++j) {
    out.response.backlight[static_cast<std::size_t>(j)] = coefficients.at<double>(j) / c0;
    out.backlightSigma[static_cast<std::size_t>(j)] = std::sqrt(covariance.at<double>(j, j)) / c0;
  }
  out.response.backlight[0] = 1;
  out.backlightSigma[0] = 0;
  out.frames = taken;
  out.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  return out;
}

void setPanelCalibration(BenchFileEdit& edit, const PanelCalibration& c, const std::string& stampUtc) {
  const double k = c.coverageFactor;
  const std::string comment = fmt::format("lfi calibrate panel, {}", stampUtc);
  edit.set("display.response", "levels", fmt::format("[{:g}]", fmt::join(c.response.levels, ", ")), comment);
  const std::size_t curves = c.response.light.size();
  const std::vector<std::string> names =
      curves == 1 ? std::vector<std::string>{"light"} : std::vector<std::string>{"red", "green", "blue"};
  for (std::size_t i = 0; i < curves; ++i)
    detail::setMeasured(edit, "display.response", names[i], c.response.light[i], c.lightSigma[i], k,
                        "relative light at each level");
  detail::setMeasured(edit, "display.response", "backlight",
                      std::vector<double>(c.response.backlight.begin(), c.response.backlight.end()),
                      std::vector<double>(c.backlightSigma.begin(), c.backlightSigma.end()), k,
                      "B = b0 + b1 x + b2 y + b3 x^2 + b4 x y + b5 y^2, x, y in mm from the panel's centre");
}

std::string panelCalibrationRecord(const PanelCalibration& c, const BenchFile& bench, const std::string& stampUtc,
                                   const std::string& cameraDescription) {
  const double k = c.coverageFactor;
  nlohmann::json curves = nlohmann::json::array();
  for (std::size_t i = 0; i < c.response.light.size(); ++i) {
    nlohmann::json points = nlohmann::json::array();
    for (std::size_t j = 0; j < c.response.levels.size(); ++j)
      points.push_back({{"level", c.response.levels[j]},
                        {"light", detail::measured(c.response.light[i][j], c.lightSigma[i][j], k, "relative")}});
    curves.push_back({{"name", c.response.light.size() == 1 ? "light"
                               : i == 0                     ? "red"
                               : i == 1                     ? "green"
                                                            : "blue"},
                      {"points", points}});
  }
  nlohmann::json backlight = nlohmann::json::array();
  for (std::size_t j = 0; j < 6; ++j)
    backlight.push_back(detail::measured(c.response.backlight[j], c.backlightSigma[j], k, "relative per mm^n"));
  const nlohmann::json record = {
      {"format", "lfi-calibration-record"},
      {"version", 1},
      {"what", "panel"},
      {"time_utc", stampUtc},
      {"bench", bench.file.string()},
      {"units", "drive levels 0..255; light relative to full drive at the panel's centre; x, y in mm from it"},
      {"method",
       "the panel uniform at each level through the camera, nothing in view; the backlight fitted to the all-white "
       "image at each pixel's display point (docs/calibration.md)"},
      {"coverage_factor", k},
      {"display", {{"uri", bench.displayUri.text()}, {"device", c.display.deviceId}, {"model", c.display.model}}},
      {"camera", {{"uri", bench.cameraUri.text()}, {"device", cameraDescription}}},
      {"pixels", c.pixels},
      {"dark_clipped_fraction", c.darkClipped},
      {"mean_noise_dn", c.meanNoise_dn},
      {"full_light_dn", c.fullLight_dn},
      {"curves", curves},
      {"backlight",
       {{"terms", "1, x, y, x^2, x y, y^2"},
        {"coefficients", backlight},
        {"residual_rms_relative", c.backlightResidual}}},
      {"frames", c.frames},
      {"seconds", c.seconds},
  };
  return record.dump(2) + "\n";
}

}  // namespace lfi
