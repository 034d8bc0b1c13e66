// SPDX-License-Identifier: Apache-2.0
// Dark and flat frames and the correction they make (frame_correction.h).

#include "lfi/controller/frame_correction.h"

#include "lfi/core/error.h"
#include "lfi/core/exr_io.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <vector>

namespace lfi {

namespace fs = std::filesystem;

namespace {

double fullScale(PixelFormat format) {
  return (1 << significantBits(format)) - 1;
}

// The median of a CV_32FC1 image's values.
double median(const cv::Mat& image) {
  std::vector<float> v = image.isContinuous()
                             ? std::vector<float>(image.ptr<float>(), image.ptr<float>() + image.total())
                             : std::vector<float>(image.begin<float>(), image.end<float>());
  const auto middle = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), middle, v.end());
  return *middle;
}

// The first pixel where `mask` is set, as "(x, y)".
std::string firstPixel(const cv::Mat& mask) {
  std::vector<cv::Point> points;
  cv::findNonZero(mask, points);
  return points.empty() ? "none" : fmt::format("({}, {})", points.front().x, points.front().y);
}

std::string settingText(double value) {
  return fmt::format("{:.17g}", value);
}

const std::string& setting(const std::map<std::string, std::string>& settings, const fs::path& file,
                           const std::string& key) {
  const auto it = settings.find(key);
  if (it == settings.end())
    fail(Errc::InvalidFile, "'{}': attribute 'lfi.settings.{}' is missing: not a dark or flat frame of lfi's",
         file.string(), key);
  return it->second;
}

template <typename T>
T numberSetting(const std::map<std::string, std::string>& settings, const fs::path& file, const std::string& key) {
  const std::string& text = setting(settings, file, key);
  T value{};
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec != std::errc() || end != text.data() + text.size())
    fail(Errc::InvalidFile, "'{}': attribute 'lfi.settings.{}' = '{}' is not a number", file.string(), key,
         shown(text));
  return value;
}

}  // namespace

const char* toString(CalibrationFrameKind kind) {
  return kind == CalibrationFrameKind::Dark ? "dark" : "flat";
}

std::string CalibrationFrame::name() const {
  return file.empty() ? fmt::format("{} frame", toString(kind))
                      : fmt::format("{} frame '{}'", toString(kind), file.string());
}

CalibrationFrame takeCalibrationFrame(BenchProbe& bench, CalibrationFrameKind kind, const std::string& camera,
                                      const CameraSettings& settings, int frames) {
  const DisplayInfo display = bench.display();
  const cv::Mat panel(display.panelHeight_px, display.panelWidth_px, CV_8UC1,
                      cv::Scalar(kind == CalibrationFrameKind::Dark ? 0 : 255));
  CalibrationFrame f;
  f.kind = kind;
  f.image = bench.take(panel);
  f.camera = camera;
  f.settings = settings;
  f.frames = frames;
  return f;
}

void writeCalibrationFrame(const fs::path& file, const CalibrationFrame& f) {
  RadianceImageInfo info;
  info.pixelUnit = kCameraDigitalNumbers;
  info.description = fmt::format("{} frame of camera {}: the mean of {} frames", toString(f.kind), f.camera, f.frames);
  info.settings = {{"kind", toString(f.kind)},
                   {"camera", f.camera},
                   {"exposure_us", settingText(f.settings.exposure_us)},
                   {"gain", settingText(f.settings.gain)},
                   {"pixel_format", toString(f.settings.pixelFormat)},
                   {"binning", std::to_string(f.settings.binning)},
                   {"width", std::to_string(f.image.cols)},
                   {"height", std::to_string(f.image.rows)},
                   {"frames", std::to_string(f.frames)}};
  writeRadianceExr(file, f.image, info, Overwrite::Refuse);
}

CalibrationFrame readCalibrationFrame(const fs::path& file, CalibrationFrameKind kind) {
  RadianceImageInfo info;
  CalibrationFrame f;
  f.image = readRadianceExr(file, &info);
  f.file = file;
  f.kind = kind;
  const auto& s = info.settings;
  if (info.pixelUnit != kCameraDigitalNumbers)
    fail(Errc::InvalidFile, "'{}': its pixels are '{}', not '{}': not a camera's {} frame", file.string(),
         info.pixelUnit, kCameraDigitalNumbers, toString(kind));
  if (const std::string& k = setting(s, file, "kind"); k != toString(kind))
    fail(Errc::InvalidFile, "'{}': a {} frame (lfi.settings.kind), where a {} frame belongs", file.string(), shown(k),
         toString(kind));
  f.camera = setting(s, file, "camera");
  f.settings.exposure_us = numberSetting<double>(s, file, "exposure_us");
  f.settings.gain = numberSetting<double>(s, file, "gain");
  const std::string& format = setting(s, file, "pixel_format");
  bool known = false;
  for (const PixelFormat p : {PixelFormat::Mono8, PixelFormat::Mono12, PixelFormat::Mono16})
    if (format == toString(p)) {
      f.settings.pixelFormat = p;
      known = true;
    }
  if (!known)
    fail(Errc::InvalidFile, "'{}': attribute 'lfi.settings.pixel_format' = '{}' is not Mono8, Mono12 or Mono16",
         file.string(), shown(format));
  f.settings.binning = numberSetting<int>(s, file, "binning");
  f.frames = numberSetting<int>(s, file, "frames");
  if (numberSetting<int>(s, file, "width") != f.image.cols || numberSetting<int>(s, file, "height") != f.image.rows)
    fail(Errc::InvalidFile, "'{}': the image is {} x {}, its settings say {} x {}", file.string(), f.image.cols,
         f.image.rows, setting(s, file, "width"), setting(s, file, "height"));
  return f;
}

namespace {

// The first of the settings a frame depends on that differs, as "key: a against b"; empty when none does.
std::string settingsDifference(const CameraSettings& a, const CameraSettings& b) {
  if (a.exposure_us != b.exposure_us) return fmt::format("exposure_us {:g} against {:g}", a.exposure_us, b.exposure_us);
  if (a.gain != b.gain) return fmt::format("gain {:g} against {:g}", a.gain, b.gain);
  if (a.pixelFormat != b.pixelFormat)
    return fmt::format("pixel_format {} against {}", toString(a.pixelFormat), toString(b.pixelFormat));
  if (a.binning != b.binning) return fmt::format("binning {} against {}", a.binning, b.binning);
  return {};
}

}  // namespace

FrameCorrection::FrameCorrection(CalibrationFrame dark, std::optional<CalibrationFrame> flat)
    : dark_(std::move(dark)), flat_(std::move(flat)) {
  fullScale_dn_ = static_cast<float>(fullScale(dark_.settings.pixelFormat));
  if (!flat_) {
    gain_ = cv::Mat(dark_.image.size(), CV_32FC1, cv::Scalar(1));
    return;
  }
  const CalibrationFrame& f = *flat_;
  if (const std::string d = settingsDifference(f.settings, dark_.settings); !d.empty())
    fail(Errc::Config, "the {} and the {} were taken at other settings ({}): take them again at the bench's", f.name(),
         dark_.name(), d);
  if (f.image.size() != dark_.image.size())
    fail(Errc::Config, "the {} is {} x {}, the {} {} x {}: take them again at the bench's settings", f.name(),
         f.image.cols, f.image.rows, dark_.name(), dark_.image.cols, dark_.image.rows);
  const cv::Mat saturated = f.image >= fullScale_dn_ - 0.5f;
  if (const int n = cv::countNonZero(saturated); n > 0)
    fail(Errc::Config,
         "the {} has {} saturated pixels (at {:g} DN, the first at {}): lower the exposure or the light, and take it "
         "again",
         f.name(), n, fullScale_dn_, firstPixel(saturated));
  const cv::Mat response = f.image - dark_.image;
  const double typical = median(response);
  // The dark and the flat frame are means of many frames: a flat that rises by
  // less than a DN over the dark saw no light.
  if (!(typical >= 1))
    fail(Errc::Config,
         "the {} is no brighter than the {} (their median difference is {:.3g} DN): was the light on for the flat "
         "frame, and off for the dark one?",
         f.name(), dark_.name(), typical);
  const cv::Mat weak = response < kLeastRelativeResponse * typical;
  if (const int n = cv::countNonZero(weak); n > 0)
    fail(Errc::Config,
         "the {} has {} pixels that respond less than {:g} of the median pixel ({:.4g} DN over the dark frame; the "
         "first at {}): dead pixels, dust, or a source that does not fill the view",
         f.name(), n, kLeastRelativeResponse, typical, firstPixel(weak));
  cv::divide(typical, response, gain_);
}

void FrameCorrection::requireSettings(const CameraSettings& settings, const std::string& where) const {
  // (The flat frame's settings are the dark one's: the constructor checked.)
  if (const std::string d = settingsDifference(dark_.settings, settings); !d.empty())
    fail(Errc::Config, "{}: the {} was taken at other camera settings ({} in the bench): take it again", where,
         dark_.name(), d);
}

void FrameCorrection::apply(cv::Mat& image) const {
  if (image.size() != dark_.image.size())
    fail(Errc::Config,
         "the camera's image is {} x {}, the {} {} x {}: take the dark and flat frames again at the "
         "camera's region and binning",
         image.cols, image.rows, dark_.name(), dark_.image.cols, dark_.image.rows);
  const float full = fullScale_dn_ - 0.5f;
  for (int r = 0; r < image.rows; ++r) {
    auto* p = image.ptr<float>(r);
    const float* d = dark_.image.ptr<float>(r);
    const float* g = gain_.ptr<float>(r);
    for (int c = 0; c < image.cols; ++c) p[c] = p[c] >= full ? fullScale_dn_ : (p[c] - d[c]) * g[c];
  }
}

void setCalibrationFrame(BenchFileEdit& edit, CalibrationFrameKind kind, const fs::path& file,
                         const std::string& stampUtc) {
  const fs::path relative = file.lexically_relative(edit.file().parent_path());
  edit.set("camera", fmt::format("{}_frame", toString(kind)),
           tomlString((relative.empty() ? file : relative).generic_string()),
           fmt::format("lfi calibrate camera --{}, {}", toString(kind), stampUtc));
}

std::string calibrationFrameRecord(const FrameCorrection& correction, CalibrationFrameKind kind, const BenchFile& bench,
                                   const std::string& stampUtc, const std::string& cameraDescription) {
  const CalibrationFrame& f = kind == CalibrationFrameKind::Dark ? correction.dark() : *correction.flat();
  const auto statistics = [](const cv::Mat& image) {
    cv::Scalar mean, sigma;
    cv::meanStdDev(image, mean, sigma);
    double least = 0, most = 0;
    cv::minMaxLoc(image, &least, &most);
    return nlohmann::json{{"mean", mean[0]}, {"sigma", sigma[0]}, {"min", least}, {"max", most}};
  };
  nlohmann::json record = {
      {"format", "lfi-calibration-record"},
      {"version", 1},
      {"what", toString(kind)},
      {"time_utc", stampUtc},
      {"bench", bench.file.string()},
      {"units", "camera digital numbers (DN) of the pixel format; the response relative to the median pixel's"},
      {"method", kind == CalibrationFrameKind::Dark
                     ? "the mean of the camera's frames with the display dark (docs/calibration.md)"
                     : "the mean of the camera's frames of a uniform source filling the view, the display all white; "
                       "less the dark frame, over its median (docs/calibration.md)"},
      {"camera",
       {{"uri", bench.cameraUri.text()},
        {"device", cameraDescription},
        {"image_px", {f.image.cols, f.image.rows}},
        {"exposure_us", f.settings.exposure_us},
        {"gain", f.settings.gain},
        {"pixel_format", toString(f.settings.pixelFormat)},
        {"binning", f.settings.binning}}},
      {"frames", f.frames},
      {"frame_dn", statistics(f.image)},
  };
  if (kind == CalibrationFrameKind::Flat) {
    cv::Mat response;
    cv::divide(1.0, correction.gain(), response);
    record["relative_response"] = statistics(response);
  }
  return record.dump(2) + "\n";
}

std::shared_ptr<const FrameCorrection> loadFrameCorrection(const BenchFile& bench) {
  if (bench.darkFrame.empty()) return nullptr;
  CalibrationFrame dark = readCalibrationFrame(bench.darkFrame, CalibrationFrameKind::Dark);
  std::optional<CalibrationFrame> flat;
  if (!bench.flatFrame.empty()) flat = readCalibrationFrame(bench.flatFrame, CalibrationFrameKind::Flat);
  try {
    auto correction = std::make_shared<const FrameCorrection>(std::move(dark), std::move(flat));
    correction->requireSettings(bench.camera, "[camera]");
    return correction;
  } catch (const Error& e) {
    fail(Errc::Config, "{}: {}", bench.file.string(), e.what());
  }
}

}  // namespace lfi
