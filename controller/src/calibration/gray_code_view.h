#pragma once
// What the calibrations through the bench share: all white, all black and the
// Gray code patterns shown and taken, decoded per camera pixel, with the
// refusals every one of them makes (the display not in view, too few pixels
// decoded).

#include "lfi/calib/coded_patterns.h"
#include "lfi/drivers/display.h"

#include <opencv2/core.hpp>

#include <functional>
#include <string>

namespace lfi::detail {

struct GrayCodeView {
  cv::Mat white, black;  // CV_32FC1, DN
  cv::Mat light;         // white − black, at least 0
  calib::PanelCorrespondence correspondence;
  double decodeSeconds = 0;
};

// `take(levels, what)` shows a panel and returns the camera's image (CV_32FC1);
// `fullScale_dn` is the camera's. `who` names the calibration in messages
// ("display calibration"). Errc::Device naming the display for a display out
// of the camera's view and for fewer than `minDecoded` of the lit pixels
// decoded (`why` says what to look at then).
GrayCodeView takeGrayCode(const std::function<cv::Mat(const cv::Mat&, const char*)>& take, const DisplayInfo& info,
                          double fullScale_dn, double secondShare, double minDecoded, const char* who, const char* why);

// A panel pixel's centre in the display frame (display.h), mm.
inline Vec2 panelPixelCentre(const DisplayInfo& d, double col, double row) {
  return {(col + 0.5 - 0.5 * d.panelWidth_px) * d.pixelPitch_mm,
          (0.5 * d.panelHeight_px - row - 0.5) * d.pixelPitch_mm};
}

}  // namespace lfi::detail
