// SPDX-License-Identifier: Apache-2.0
#pragma once
// Defects an image shows against the golden model (golden_model.h), without
// ground truth. The difference d = image - ideal is smoothed with a Gaussian
// matched to the smallest defect of interest; a pixel is off where
// |smoothed d| > max(a, b · σ), σ the standard deviation the smoothed
// difference of a good part has there: sqrt(Σ k² · variation² · (1 + 1/n))
// over the kernel's weights k, so the variation of every pixel the smoothing
// takes in counts (on the dark side of a lit edge, the bright side's noise is
// most of it), and so does the ideal's own noise, the mean of the model's n
// images (σ = variation · sqrt(1 + 1/n) unsmoothed); off pixels are joined by a morphological
// closing, kept inside the part's mask, and grouped into 8-connected regions;
// regions smaller than the minimum area are dropped.
//
//   setting       units  meaning
//   absolute_dn   DN     a: the least difference that counts, whatever the variation
//   relative      -      b: the threshold in units of σ
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

// The defects of image after image against one model: σ, which depends on
// the model and the settings only, is computed once. `mask` (CV_8UC1, the
// model's size; nonzero = the part) may be empty for the whole image. Throws
// Errc::InvalidArgument for a model or mask that do not match or a setting
// out of range.
class DefectFinder {
 public:
  DefectFinder(const GoldenModel& model, const cv::Mat& mask, const DetectionSettings& settings);
  // The defects of `image`, largest first. Throws Errc::InvalidArgument naming
  // the sizes or types for an image that does not match the model.
  std::vector<Defect> find(const cv::Mat& image) const;
  // σ per pixel (DN, CV_32FC1).
  const cv::Mat& sigma() const { return threshold_.variation; }

 private:
  GoldenModel threshold_;  // the ideal, and σ in place of the variation
  cv::Mat mask_;
  DetectionSettings settings_;
};

// DefectFinder(model, mask, settings).find(image), for one image.
std::vector<Defect> findDefects(const cv::Mat& image, const GoldenModel& model, const cv::Mat& mask,
                                const DetectionSettings& settings);

}  // namespace lfi
