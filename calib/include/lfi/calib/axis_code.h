// SPDX-License-Identifier: Apache-2.0
#pragma once
// A Gray code across the lens axes of a lenticular sheet or line barrier:
// which band of panel pixels parallel to the axes each camera pixel's light
// comes from. Along an axis a sheet does nothing to the light, so a camera
// focused elsewhere (on the part, with the display far below it) sees the
// panel blurred along the axes by its aperture: a code that varies along them
// (coded_patterns.h) no longer decodes there, one constant along them does.
//
// The band of a panel pixel with centre (x, y) (pixels from the panel's
// centre, y up: display.h's frame in pixels) is ⌊ξ − ξ0⌋ with ξ = x − y tan s,
// s the axes' slant: ξ is where the line through the pixel parallel to the
// axes crosses the panel's centre row, the coordinate lenticular_optics.h
// counts lens pitches and offsets in. Patterns: all white, all black, and for
// each bit of the bands' Gray code the pattern and its inverse (2 + 2·bits
// frames, bits = ⌈log2 bands⌉); CV_8UC1 at 0 or 255.
//
// Decoding per camera pixel: lit where white − black ≥ minLit; each bit from
// the sign of pattern − inverse, refused (the pixel undecoded) where any
// bit's |pattern − inverse| is below minContrast or minContrastFraction of
// white − black (DecodeSettings; secondShare is not used); confidence the
// smallest bit's |pattern − inverse| over white − black.

#include "lfi/calib/coded_patterns.h"

#include <opencv2/core.hpp>

#include <vector>

namespace lfi::calib {

struct AxisCodeSet {
  cv::Mat white, black;
  std::vector<cv::Mat> patterns;  // bit 0 (most significant) pattern, its inverse, bit 1 …
  double slant_rad = 0;
  double xi0_px = 0;  // ξ of band 0's lower edge
  int bands = 0, bits = 0;
};

// Errc::InvalidArgument for an empty panel or |slant| ≥ π/4.
AxisCodeSet axisCodePatterns(int width_px, int height_px, double slant_rad);

struct AxisCorrespondence {
  cv::Mat xi;          // CV_32FC1, camera size: ξ of the decoded band's middle, px; NaN where undecoded
  cv::Mat confidence;  // CV_32FC1, 0 where undecoded
  int lit = 0, decoded = 0;
};

// `frames`: the camera's frames of set.patterns in order; `white`, `black`
// its frames of the white and black panel; single-channel, one size, any
// depth (converted to float). Errc::InvalidArgument naming what: a wrong
// frame count, an empty frame or one of another size.
AxisCorrespondence decodeAxisCode(const std::vector<cv::Mat>& frames, const cv::Mat& white, const cv::Mat& black,
                                  const AxisCodeSet& set, const DecodeSettings& settings = {});

}  // namespace lfi::calib
