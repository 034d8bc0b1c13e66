// SPDX-License-Identifier: Apache-2.0
#pragma once
// How a display's panel turns drive levels into light, as `lfi calibrate
// panel` measures it through the camera (docs/calibration.md), and the drive
// that makes the light the bench means to emit.
//
//   levels      drive levels the light was measured at: 0 first, 255 last, increasing
//   light[c]    per subpixel colour c (one curve for a mono panel, or red,
//               green and blue), the relative light at each level: R_c(0) = 0,
//               R_c(255) = 1, non-decreasing; linear between the levels
//   backlight   B(x, y) = b0 + b1 x + b2 y + b3 x^2 + b4 x y + b5 y^2, the
//               relative light of a pixel at (x, y) mm from the panel's centre
//               (display frame: x along the columns, y up), B(0, 0) = 1
//
// drive(L, c, x, y) is the level whose light is L · Bmin / B(x, y) of full
// drive: of the 256 levels, the one whose R_c is nearest. Bmin is B's least
// over the panel (on a 65 x 65 grid over it, edges included), so every pixel
// emits L times the dimmest pixel's full light: the fall-off is compensated
// within the panel's range, at the cost of the brightest pixels' headroom.

#include "lfi/drivers/display.h"

#include <opencv2/core.hpp>

#include <array>
#include <cstdint>
#include <vector>

namespace lfi {

struct PanelResponseParams {
  std::vector<double> levels;
  std::vector<std::vector<double>> light;  // one curve, or red, green, blue
  std::array<double, 6> backlight{1, 0, 0, 0, 0, 0};
};

class PanelResponse {
 public:
  // Throws Errc::InvalidArgument naming what is wrong: levels not 0 .. 255
  // increasing, a curve of another length, not 0 at 0 and 1 at 255, or
  // falling ("is not monotonic"), a backlight not 1 at the centre or not
  // positive over a panel of `info`'s size, curves that are neither one nor
  // one per colour of `info`'s subpixels.
  PanelResponse(PanelResponseParams params, const DisplayInfo& info);
  // The checks that need no panel (all but the backlight's sign and the
  // curves' count against the subpixels); Errc::InvalidArgument as above.
  static void validate(const PanelResponseParams& params);

  const PanelResponseParams& params() const { return params_; }
  // The relative light of level `level` of curve c (0 .. 1).
  double light(double level, int curve) const;
  // The backlight at panel pixel (col, row), relative to the centre's.
  double backlight(int col, int row) const;
  // The least backlight over the panel.
  double leastBacklight() const { return leastBacklight_; }

  // The panel image (info's panel type) that emits `light` (CV_32FC1, the
  // panel's size, every subpixel of a pixel alike; or CV_32FC(subpixels),
  // channels in subpixel order): relative light in [0, 1] of the dimmest
  // pixel's full light. Errc::InvalidArgument for another size or type, or
  // light outside [0, 1].
  cv::Mat drive(const cv::Mat& light) const;

  // The drive level that emits `light` (0 .. 1) on subpixel `subpixel` of
  // panel pixel (col, row), the inverse lookup alone (for callers that
  // sample light per subpixel, encodeLightField).
  std::uint8_t driveLevel(double light, int col, int row, int subpixel) const;

 private:
  PanelResponseParams params_;
  DisplayInfo info_;
  int curveOf_[3] = {0, 0, 0};  // curve of each subpixel position
  double leastBacklight_ = 1;
  std::vector<std::array<double, 256>> lightOfLevel_;  // per curve, R at every level
};

}  // namespace lfi
