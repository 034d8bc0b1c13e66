// SPDX-License-Identifier: Apache-2.0
#pragma once
// The display calibration's class-specific steps after the Gray code
// (display_calibration.h): a lens or pinhole array's lattice and spots
// (display_calibration.cpp), a lenticular sheet's or line barrier's axes,
// stripes and slit (display_calibration_axes.cpp).

#include "gray_code_view.h"

#include "lfi/controller/display_calibration.h"
#include "lfi/core/error.h"

#include <string>

namespace lfi::detail {

// What a fit throws, with the display named.
template <typename Fit>
auto named(const std::string& display, Fit&& fit) {
  try {
    return fit();
  } catch (const Error& e) {
    fail(e.code(), "display calibration of display '{}': {}", display, e.what());
  }
}

// The frames the axes' steps take after the Gray code: s stripe frames, and a
// line barrier's slit frame.
int axesFrames(const DisplayInfo& info, const DisplayCalibrationSettings& settings);

// Fills `out` (axes, camera, optics, slit, spots) from the Gray code `view`
// and the frames it takes; the time spent computing added to `compute`.
void measureAxes(DisplayCalibration& out, FrameTaker& take, const GrayCodeView& view, const DisplayInfo& info,
                 const DisplayCalibrationSettings& settings, Clock::duration& compute);

}  // namespace lfi::detail
