// SPDX-License-Identifier: Apache-2.0
#pragma once
// What the calibrations through the bench share: frames taken and counted,
// all white, all black and the Gray code patterns (or the code across a
// sheet's or barrier's axes) shown and decoded per camera pixel with the
// refusals every one of them makes (the display not in view, too few pixels
// decoded), and small helpers.

#include "lfi/calib/axis_code.h"
#include "lfi/calib/coded_patterns.h"
#include "lfi/drivers/display.h"
#include "lfi/drivers/light_field_capture.h"

#include <opencv2/core.hpp>

#include <algorithm>
#include <chrono>
#include <functional>
#include <string>
#include <vector>

namespace lfi::detail {

// Shows panels through the bench and takes the camera's images, counting them:
// `progress` gets the frames taken over `total`, an error names the frame, what
// it showed and the display. `who` names the calibration in messages.
class FrameTaker {
 public:
  FrameTaker(BenchProbe& bench, const char* who, std::string display, int total, std::function<void(double)> progress)
      : bench_(bench), who_(who), display_(std::move(display)), total_(total), progress_(std::move(progress)) {}
  cv::Mat operator()(const cv::Mat& levels, const char* what);
  int frames() const { return frames_; }

 private:
  BenchProbe& bench_;
  const char* who_;
  std::string display_;
  int total_ = 0, frames_ = 0;
  std::function<void(double)> progress_;
};

struct GrayCodeView {
  cv::Mat white, black;  // CV_32FC1, DN
  cv::Mat light;         // white − black, at least 0
  calib::PanelCorrespondence correspondence;
  double decodeSeconds = 0;
};

// `take` shows the panels; `fullScale_dn` is the camera's. `who` names the calibration in messages
// ("display calibration"). Errc::Device naming the display for a display out
// of the camera's view and for fewer than `minDecoded` of the lit pixels
// decoded (`why` says what to look at then).
GrayCodeView takeGrayCode(FrameTaker& take, const DisplayInfo& info, double fullScale_dn, double secondShare,
                          double minDecoded, const char* who, const char* why);

// The code across a lenticular sheet's or line barrier's axes (calib/axis_code.h), shown and decoded with the
// same refusals as takeGrayCode's.
struct AxisCodeView {
  cv::Mat white, black;  // CV_32FC1, DN
  calib::AxisCorrespondence correspondence;
  double decodeSeconds = 0;
};
AxisCodeView takeAxisCode(FrameTaker& take, const DisplayInfo& info, double fullScale_dn, double minDecoded,
                          const char* who, const char* why);

using Clock = std::chrono::steady_clock;
inline double seconds(Clock::duration d) {
  return std::chrono::duration<double>(d).count();
}

// The median of `values` (the upper one of an even count); `values` not empty.
inline double median(std::vector<double> values) {
  const auto mid = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  return *mid;
}

// A panel pixel's centre in the display frame (display.h), mm.
inline Vec2 panelPixelCentre(const DisplayInfo& d, double col, double row) {
  return {(col + 0.5 - 0.5 * d.panelWidth_px) * d.pixelPitch_mm,
          (0.5 * d.panelHeight_px - row - 0.5) * d.pixelPitch_mm};
}

}  // namespace lfi::detail
