// SPDX-License-Identifier: Apache-2.0
// The Aravis backend's configure(): each CameraSettings field applied to the device
// within its bounds, the settings read back, and the wire pixel formats behind
// each PixelFormat.

#include "aravis_camera_impl.h"

#include <fmt/ranges.h>
#include <spdlog/spdlog.h>

#include <algorithm>

namespace lfi::detail {

std::vector<WireFormat> wireFormats(PixelFormat format) {
  switch (format) {
    case PixelFormat::Mono8:
      return {{"Mono8", ARV_PIXEL_FORMAT_MONO_8}};
    case PixelFormat::Mono12:
      return {{"Mono12", ARV_PIXEL_FORMAT_MONO_12},
              {"Mono12p", kPixelFormatMono12p},
              {"Mono12Packed", ARV_PIXEL_FORMAT_MONO_12_PACKED}};
    case PixelFormat::Mono16:
      return {{"Mono16", ARV_PIXEL_FORMAT_MONO_16}};
  }
  return {};
}
std::vector<std::string> wireFormatNames(PixelFormat format) {
  std::vector<std::string> names;
  for (const WireFormat& w : wireFormats(format)) names.emplace_back(w.name);
  return names;
}

void AravisCamera::configure(const CameraSettings& s) {
  requireCameraState(state_, {State::Open, State::Configured}, "configure", name());
  state_ = State::Open;  // until every field is applied
  requireSaneSettings(s, name());
  onDevice([&] { apply(s); });
  settings_ = s;
  state_ = State::Configured;
}

// Sets every field of `s` on the device (configure()).
void AravisCamera::apply(const CameraSettings& s) {
  applyPixelFormat(s.pixelFormat);
  applyBinning(s.binning);
  applyRegion(s);
  // SFNC leaves open how ExposureTime and AcquisitionFrameRate bound each
  // other; many devices keep the exposure within the frame period and the
  // rate under 1 / exposure. An exposure past what the current period allows
  // needs the new rate first; otherwise the exposure goes first, which opens
  // the higher rates.
  if (s.trigger != TriggerMode::FreeRun)
    setFrameRateCap(false);
  else if (setsFrameRate(s))
    setFrameRateCap(true);
  const bool rateFirst = setsFrameRate(s) && s.exposure_us > exposureBounds().second;
  if (rateFirst) applyFrameRate(s);
  applyExposureAndGain(s);
  if (!rateFirst) applyFrameRate(s);
  applyTrigger(s);
}

CameraSettings AravisCamera::settings() const {
  requireCameraState(state_, {State::Configured, State::Streaming}, "settings", name());
  if (state_ == State::Streaming && streamSettings_) return *streamSettings_;
  CameraSettings s = settings_;
  GError* error = nullptr;
  s.exposure_us = arv_camera_get_exposure_time(camera_, &error);
  check(error, name(), "arv_camera_get_exposure_time");
  if (arv_camera_is_gain_available(camera_, nullptr)) {
    s.gain = arv_camera_get_gain(camera_, &error);
    check(error, name(), "arv_camera_get_gain");
  }
  int dx = 1, dy = 1;
  if (arv_camera_is_binning_available(camera_, nullptr)) {
    arv_camera_get_binning(camera_, &dx, &dy, &error);
    check(error, name(), "arv_camera_get_binning");
  }
  s.binning = dx;
  arv_camera_get_region(camera_, &s.roiX_px, &s.roiY_px, &s.roiWidth_px, &s.roiHeight_px, &error);
  check(error, name(), "arv_camera_get_region");
  if (s.trigger == TriggerMode::FreeRun && arv_camera_is_frame_rate_available(camera_, nullptr)) {
    s.frameRate_hz = arv_camera_get_frame_rate(camera_, &error);
    check(error, name(), "arv_camera_get_frame_rate");
  }
  // What the device says must be settings at all (the controller sizes its waits by the exposure).
  try {
    requireSaneSettings(s, name());
  } catch (const Error& e) {
    fail(Errc::Device, "{} (as the device reports it)", e.what());
  }
  if (state_ == State::Streaming) streamSettings_ = s;
  return s;
}

std::vector<std::string> AravisCamera::availablePixelFormats() const {
  GError* error = nullptr;
  guint count = 0;
  const char** formats = arv_camera_dup_available_pixel_formats_as_strings(camera_, &count, &error);
  check(error, name(), "arv_camera_dup_available_pixel_formats_as_strings");
  std::vector<std::string> result;
  for (guint i = 0; i < count; ++i) result.push_back(orEmpty(formats[i]));
  g_free(formats);
  return result;
}

void AravisCamera::applyPixelFormat(PixelFormat format) {
  const std::vector<std::string> candidates = wireFormatNames(format);
  const std::vector<std::string> available = availablePixelFormats();
  for (const std::string& candidate : candidates) {
    if (std::find(available.begin(), available.end(), candidate) == available.end()) continue;
    GError* error = nullptr;
    arv_camera_set_pixel_format_from_string(camera_, candidate.c_str(), &error);
    check(error, name(), fmt::format("arv_camera_set_pixel_format_from_string('{}')", candidate));
    return;
  }
  fail(Errc::InvalidArgument, "camera '{}': pixelFormat {} needs one of {} on the wire; the device offers {}", name(),
       toString(format), fmt::join(candidates, ", "), fmt::join(available, ", "));
}

void AravisCamera::applyBinning(int binning) {
  GError* error = nullptr;
  if (!arv_camera_is_binning_available(camera_, nullptr)) {
    if (binning != 1)
      fail(Errc::InvalidArgument, "camera '{}': binning {} asked, the device has no binning", name(), binning);
    return;
  }
  int min = 1, max = 1;
  arv_camera_get_x_binning_bounds(camera_, &min, &max, &error);
  check(error, name(), "arv_camera_get_x_binning_bounds");
  if (binning < min || binning > max)
    fail(Errc::InvalidArgument, "camera '{}': binning {} is outside the device's {}..{}", name(), binning, min, max);
  arv_camera_set_binning(camera_, binning, binning, &error);
  check(error, name(), fmt::format("arv_camera_set_binning({})", binning));
}

void AravisCamera::checkIncrement(const char* field, int value, int increment, int min, int max) const {
  if (value < min || value > max)
    fail(Errc::InvalidArgument, "camera '{}': {} {} is outside the device's {}..{}", name(), field, value, min, max);
  if (increment > 1 && (value - min) % increment != 0)
    fail(Errc::InvalidArgument, "camera '{}': {} {} is not {} + a multiple of the device's increment {}", name(), field,
         value, min, increment);
}

void AravisCamera::applyRegion(const CameraSettings& s) {
  GError* error = nullptr;
  // Offsets to 0 first so the full width/height range is open.
  if (arv_camera_is_region_offset_available(camera_, nullptr)) {
    arv_camera_set_integer(camera_, "OffsetX", 0, &error);
    check(error, name(), "setting OffsetX to 0");
    arv_camera_set_integer(camera_, "OffsetY", 0, &error);
    check(error, name(), "setting OffsetY to 0");
  } else if (s.roiX_px != 0 || s.roiY_px != 0) {
    fail(Errc::InvalidArgument, "camera '{}': ROI offset ({}, {}) asked, the device has no offsets", name(), s.roiX_px,
         s.roiY_px);
  }
  int wMin = 0, wMax = 0, hMin = 0, hMax = 0;
  arv_camera_get_width_bounds(camera_, &wMin, &wMax, &error);
  check(error, name(), "arv_camera_get_width_bounds");
  arv_camera_get_height_bounds(camera_, &hMin, &hMax, &error);
  check(error, name(), "arv_camera_get_height_bounds");
  // Binned, the image is at most the sensor over the binning: Aravis's fake camera (and some devices) keep the
  // Width and Height bounds of the unbinned sensor, so that "to the end" asked for more than there is.
  if (s.binning > 1 && info_.sensorWidth_px > 0 && info_.sensorHeight_px > 0) {
    wMax = std::min(wMax, info_.sensorWidth_px / s.binning);
    hMax = std::min(hMax, info_.sensorHeight_px / s.binning);
  }
  if (s.roiX_px >= wMax || s.roiY_px >= hMax)  // (before the sizes: a width past the sensor is the offset's fault)
    fail(Errc::InvalidArgument, "camera '{}': ROI offset ({}, {}) lies outside the {} x {} (binned) sensor", name(),
         s.roiX_px, s.roiY_px, wMax, hMax);
  const int width = s.roiWidth_px > 0 ? s.roiWidth_px : wMax - s.roiX_px;
  const int height = s.roiHeight_px > 0 ? s.roiHeight_px : hMax - s.roiY_px;
  checkIncrement("roiWidth_px", width, arv_camera_get_width_increment(camera_, nullptr), wMin, wMax);
  checkIncrement("roiHeight_px", height, arv_camera_get_height_increment(camera_, nullptr), hMin, hMax);
  if (std::int64_t{s.roiX_px} + width > wMax || std::int64_t{s.roiY_px} + height > hMax)
    fail(Errc::InvalidArgument, "camera '{}': ROI ({}, {}, {} x {}) does not fit the {} x {} (binned) sensor", name(),
         s.roiX_px, s.roiY_px, width, height, wMax, hMax);
  arv_camera_set_region(camera_, s.roiX_px, s.roiY_px, width, height, &error);
  check(error, name(), fmt::format("arv_camera_set_region({}, {}, {}, {})", s.roiX_px, s.roiY_px, width, height));
}

std::pair<double, double> AravisCamera::exposureBounds() const {
  GError* error = nullptr;
  double min = 0, max = 0;
  arv_camera_get_exposure_time_bounds(camera_, &min, &max, &error);
  check(error, name(), "arv_camera_get_exposure_time_bounds");
  return {min, max};
}

void AravisCamera::applyExposureAndGain(const CameraSettings& s) {
  GError* error = nullptr;
  if (arv_camera_is_exposure_auto_available(camera_, nullptr)) {
    arv_camera_set_exposure_time_auto(camera_, ARV_AUTO_OFF, &error);
    check(error, name(), "arv_camera_set_exposure_time_auto(Off)");
  }
  const auto [shortest, longest] = exposureBounds();
  if (s.exposure_us < shortest || s.exposure_us > longest) {
    std::string rate;  // (the bound may be the frame period's)
    if (arv_camera_is_frame_rate_available(camera_, nullptr)) {
      const double hz = arv_camera_get_frame_rate(camera_, &error);
      if (error == nullptr) rate = fmt::format(" at {} Hz", hz);
      g_clear_error(&error);
    }
    fail(Errc::InvalidArgument, "camera '{}': exposure_us {} is outside the device's {}..{} us{}", name(),
         s.exposure_us, shortest, longest, rate);
  }
  arv_camera_set_exposure_time(camera_, s.exposure_us, &error);
  check(error, name(), fmt::format("arv_camera_set_exposure_time({} us)", s.exposure_us));

  double min = 0, max = 0;
  if (!arv_camera_is_gain_available(camera_, nullptr)) {
    if (s.gain != 0) fail(Errc::InvalidArgument, "camera '{}': gain {} asked, the device has no gain", name(), s.gain);
    return;
  }
  if (arv_camera_is_gain_auto_available(camera_, nullptr)) {
    arv_camera_set_gain_auto(camera_, ARV_AUTO_OFF, &error);
    check(error, name(), "arv_camera_set_gain_auto(Off)");
  }
  arv_camera_get_gain_bounds(camera_, &min, &max, &error);
  check(error, name(), "arv_camera_get_gain_bounds");
  if (s.gain < min || s.gain > max)
    fail(Errc::InvalidArgument, "camera '{}': gain {} is outside the device's {}..{}", name(), s.gain, min, max);
  arv_camera_set_gain(camera_, s.gain, &error);
  check(error, name(), fmt::format("arv_camera_set_gain({})", s.gain));
}

// SFNC's frame-rate cap (AcquisitionFrameRateEnable), where the device has
// it: on for a free run at a set rate (a rate does not apply without it), off
// in a triggered mode, where the triggers set the pace. Left on from an
// earlier free run, it would keep a triggered exposure within that rate's
// period and drop triggers that come faster. (A device that will not change
// it keeps it; the exposure's check then names the bound in force.)
void AravisCamera::setFrameRateCap(bool on) {
  static constexpr const char* kFeature = "AcquisitionFrameRateEnable";
  GError* error = nullptr;
  if (arv_camera_is_feature_available(camera_, kFeature, &error) && error == nullptr &&
      (arv_camera_get_boolean(camera_, kFeature, &error) != FALSE) != on && error == nullptr)
    arv_camera_set_boolean(camera_, kFeature, on ? TRUE : FALSE, &error);
  if (error != nullptr) {
    spdlog::warn("camera '{}': {} could not be set to {}: {}", name(), kFeature, on, error->message);
    g_clear_error(&error);
  }
}

// (Before applyTrigger: arv_camera_set_frame_rate switches triggers off.)
void AravisCamera::applyFrameRate(const CameraSettings& s) {
  if (!setsFrameRate(s)) return;
  if (!arv_camera_is_frame_rate_available(camera_, nullptr))
    fail(Errc::InvalidArgument, "camera '{}': frameRate_hz {} asked, the device has no frame rate control", name(),
         s.frameRate_hz);
  GError* error = nullptr;
  double min = 0, max = 0;
  arv_camera_get_frame_rate_bounds(camera_, &min, &max, &error);
  check(error, name(), "arv_camera_get_frame_rate_bounds");
  if (s.frameRate_hz < min || s.frameRate_hz > max)
    fail(Errc::InvalidArgument, "camera '{}': frameRate_hz {} is outside the device's {}..{} Hz", name(),
         s.frameRate_hz, min, max);
  arv_camera_set_frame_rate(camera_, s.frameRate_hz, &error);
  check(error, name(), fmt::format("arv_camera_set_frame_rate({} Hz)", s.frameRate_hz));
}

void AravisCamera::applyTrigger(const CameraSettings& s) {
  GError* error = nullptr;
  switch (s.trigger) {
    case TriggerMode::FreeRun:
      arv_camera_clear_triggers(camera_, &error);
      check(error, name(), "arv_camera_clear_triggers");
      break;
    case TriggerMode::Software:
      if (!arv_camera_is_software_trigger_supported(camera_, nullptr))
        fail(Errc::InvalidArgument, "camera '{}': TriggerMode::Software asked, the device has no software trigger",
             name());
      arv_camera_set_trigger(camera_, "Software", &error);
      check(error, name(), "arv_camera_set_trigger('Software')");
      break;
    case TriggerMode::Line:
      arv_camera_set_trigger(camera_, s.triggerLine.c_str(), &error);
      check(error, name(), fmt::format("arv_camera_set_trigger('{}')", s.triggerLine));
      break;
  }
}

}  // namespace lfi::detail
