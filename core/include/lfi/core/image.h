// SPDX-License-Identifier: Apache-2.0
#pragma once
// The stack's image type is cv::Mat. Pixel formats used at library boundaries:
//
//   kind                   cv type    units / meaning
//   radiance image         CV_32FC1   linear radiance, relative (emitter radiance 1 = 1.0)
//   camera frame Mono8     CV_8UC1    digital numbers 0..255
//   camera frame Mono12/16 CV_16UC1   digital numbers; Mono12 uses the low 12 bits
//   light field (lenslet)  CV_32FC1   linear radiance, see light_field.h
//   panel image            CV_8UC1/3  display drive levels
//
// Row 0 is the top of the image; for camera images the top is world +y and
// columns run along world +x (the camera model makes the image upright).

#include "lfi/core/atomic_file.h"

#include <opencv2/core.hpp>

#include <filesystem>
#include <optional>
#include <string>

namespace lfi {

// Throws Errc::InvalidArgument naming `what` unless `image` has type `cvType`
// and is not empty.
void requireImageType(const cv::Mat& image, int cvType, const std::string& what);

// The first pixel (x = column, y = row, in row order) of a CV_32FC1 image
// that is NaN or infinite; nullopt when every pixel is finite.
std::optional<cv::Point> firstNonFinite(const cv::Mat& image);

// The first pixel (as firstNonFinite) of a CV_32FC1 image below 0 (negative
// radiance, which no light field holds); nullopt when there is none.
std::optional<cv::Point> firstNegative(const cv::Mat& image);

// The value below which `fraction` (0..1) of a CV_32FC1 image's pixels lie
// (nearest rank). Throws Errc::InvalidArgument for an empty image.
double percentile(const cv::Mat& image, double fraction);

// Encodes an 8-bit image as PNG and writes it atomically (atomic_file.h).
void writePngAtomically(const std::filesystem::path& path, const cv::Mat& image8, Overwrite overwrite);

// Tone-maps a linear radiance image to 8 bits for people: divides by `white`
// (<= 0: the 99.9th percentile), clamps, applies the sRGB transfer curve.
cv::Mat toneMapForDisplay(const cv::Mat& radiance, double white = 0);

}  // namespace lfi
