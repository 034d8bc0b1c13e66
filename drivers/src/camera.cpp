// SPDX-License-Identifier: Apache-2.0
#include "lfi/drivers/camera.h"

#include "lfi/core/error.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <string>

namespace lfi {

const char* toString(PixelFormat format) {
  switch (format) {
    case PixelFormat::Mono8:
      return "Mono8";
    case PixelFormat::Mono12:
      return "Mono12";
    case PixelFormat::Mono16:
      return "Mono16";
  }
  return "unknown";
}

int significantBits(PixelFormat format) {
  switch (format) {
    case PixelFormat::Mono8:
      return 8;
    case PixelFormat::Mono12:
      return 12;
    case PixelFormat::Mono16:
      return 16;
  }
  return 16;
}

const char* toString(TriggerMode mode) {
  switch (mode) {
    case TriggerMode::FreeRun:
      return "FreeRun";
    case TriggerMode::Software:
      return "Software";
    case TriggerMode::Line:
      return "Line";
  }
  return "unknown";
}

const char* toString(FrameStatus status) {
  switch (status) {
    case FrameStatus::Complete:
      return "Complete";
    case FrameStatus::Incomplete:
      return "Incomplete";
    case FrameStatus::Timeout:
      return "Timeout";
  }
  return "unknown";
}

const char* toString(Camera::State state) {
  switch (state) {
    case Camera::State::Closed:
      return "Closed";
    case Camera::State::Open:
      return "Open";
    case Camera::State::Configured:
      return "Configured";
    case Camera::State::Streaming:
      return "Streaming";
  }
  return "unknown";
}

void requireCameraState(Camera::State current, std::initializer_list<Camera::State> allowed, const char* method,
                        const std::string& device) {
  if (std::find(allowed.begin(), allowed.end(), current) != allowed.end()) return;
  std::string names;
  for (Camera::State state : allowed) names += fmt::format("{}{}", names.empty() ? "" : ", ", toString(state));
  fail(Errc::InvalidArgument, "camera '{}': {}() is not allowed in state {} (allowed in: {})", device, method,
       toString(current), names);
}

void requireSaneSettings(const CameraSettings& s, const std::string& device) {
  if (!(s.exposure_us > 0) || !std::isfinite(s.exposure_us))
    fail(Errc::InvalidArgument, "camera '{}': exposure_us {} must be finite and > 0", device, s.exposure_us);
  if (!std::isfinite(s.gain)) fail(Errc::InvalidArgument, "camera '{}': gain {} must be finite", device, s.gain);
  if (s.binning < 1) fail(Errc::InvalidArgument, "camera '{}': binning {} must be >= 1", device, s.binning);
  if (s.roiX_px < 0 || s.roiY_px < 0 || s.roiWidth_px < 0 || s.roiHeight_px < 0)
    fail(Errc::InvalidArgument, "camera '{}': ROI ({}, {}, {} x {}) has a negative value", device, s.roiX_px, s.roiY_px,
         s.roiWidth_px, s.roiHeight_px);
  if (!(s.frameRate_hz >= 0) || !std::isfinite(s.frameRate_hz))
    fail(Errc::InvalidArgument, "camera '{}': frameRate_hz {} must be finite and >= 0", device, s.frameRate_hz);
  if (s.trigger == TriggerMode::Line && s.triggerLine.empty())
    fail(Errc::InvalidArgument, "camera '{}': TriggerMode::Line needs triggerLine", device);
}

std::chrono::milliseconds checkedGrabTimeout(std::chrono::milliseconds timeout, const std::string& device) {
  if (timeout.count() < 0) fail(Errc::InvalidArgument, "camera '{}': grab timeout {} ms", device, timeout.count());
  return std::min(timeout, std::chrono::milliseconds(std::chrono::hours(24 * 365)));
}

}  // namespace lfi
