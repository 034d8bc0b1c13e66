#include "lfi/drivers/camera.h"

#include "lfi/core/error.h"

#include <fmt/format.h>

#include <algorithm>
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

std::chrono::milliseconds checkedGrabTimeout(std::chrono::milliseconds timeout, const std::string& device) {
  if (timeout.count() < 0) fail(Errc::InvalidArgument, "camera '{}': grab timeout {} ms", device, timeout.count());
  return std::min(timeout, std::chrono::milliseconds(std::chrono::hours(24 * 365)));
}

}  // namespace lfi
