#pragma once
// Defects an image shows against the golden model (golden_model.h), without
// ground truth. The difference d = image - ideal is smoothed with a Gaussian
// matched to the smallest defect of interest; a pixel is off where
// |smoothed d| > max(a, b · variation · s), s the factor by which the smoothing
// lowers independent pixel noise (s = 1 unsmoothed); off pixels are joined by a
// morphological closing, kept inside the part's mask, and grouped into
// 8-connected regions; regions smaller than the minimum area are dropped.
//
//   setting       units  meaning
//   absolute_dn   DN     a: the least difference that counts, whatever the variation
//   relative      -      b: the threshold in units of the (smoothed) variation
//   smoothing_px  px     the Gaussian's standard deviation; 0 = none
//   closing_px    px     radius of the closing that joins a defect's fragments; 0 = none
//   minArea_px    px²    the smallest region reported
//
// Units: pixels of the camera image (row 0 at the top); contrasts relative to
// the ideal image ((image - ideal) / ideal: -1 is black, 0 as the intact part),
// of the image itself, not of the smoothed difference.
//
// Cost: one pass over the frame and the model on OpenCV's threads, only within
// 2 · closing_px of the mask; the closing and the labelling only around off
// pixels (none on a good part). Figures: docs/performance.md (lfi-inspect-bench).

#include "lfi/core/geometry.h"
#include "lfi/inspection/golden_model.h"

#include <opencv2/core.hpp>

#include <vector>

namespace lfi {

struct DetectionSettings {
  double absolute_dn = 0;
  double relative = 6;
  double smoothing_px = 0;
  int closing_px = 0;
  int minArea_px = 1;
};

struct Defect {
  Vec2 centroid_px;         // (column, row) of the region's centre of area
  double area_px = 0;       // pixels in the region
  cv::Rect bounds_px;       // the region's bounding box
  double peakContrast = 0;  // the largest |contrast| in the region, with its sign
  double meanContrast = 0;  // the mean contrast over the region
  bool dark = false;        // the region's mean difference is negative
};

// The defects of `image` against `model`, largest first. `mask` (CV_8UC1, the
// image's size; nonzero = the part) may be empty for the whole image. Throws
// Errc::InvalidArgument naming the sizes or types for an image or mask that
// does not match the model, or a setting out of range.
std::vector<Defect> findDefects(const cv::Mat& image, const GoldenModel& model, const cv::Mat& mask,
                                const DetectionSettings& settings);

}  // namespace lfi
