// SPDX-License-Identifier: Apache-2.0
#pragma once
// The blind detector's findings (lfi/inspection/defects.h: golden-template
// comparison, no ground truth) scored against the study's ground truth
// (docs/study.md, "Blind detector").
//
// A found region hits a true defect when its centroid lies in the defect's
// (dilated) mask or within one pixel (one object-space pixel) of the
// defect's centre as the camera sees it; each defect takes at most one
// region, and each region at most one defect, nearest pairs first. A region
// that hits nothing but lies on a defect another region has already taken is
// an extra region (a fragment), not a false alarm; a region on no defect is a
// false alarm.
//
// Frame: camera pixels, (column, row), pixel centres at whole numbers (as
// findDefects' centroids); lengths in object space: mm = pixels × the camera's
// object-space pixel (pixel pitch / magnification).

#include "lfi/core/geometry.h"
#include "lfi/inspection/defects.h"

#include <opencv2/core.hpp>

#include <optional>
#include <vector>

namespace lfi::study {

struct TrueDefect {
  cv::Mat mask;    // CV_8UC1, the frame's size; nonzero = the defect's pixels
  Vec2 centre_px;  // where the defect's centre appears in the frame
};

struct BlindScore {
  int hits = 0;
  int misses = 0;
  int falseAlarms = 0;
  int extraRegions = 0;                                 // regions on a defect already hit by a nearer region
  std::vector<int> regionOf;                            // per true defect: the found region that hit it, or -1
  std::vector<std::optional<double>> positionError_mm;  // per true defect: |centroid - centre|, empty when missed
  std::vector<int> falseAlarmRegions;                   // indices into the found regions
};

// Throws Errc::InvalidArgument for a mask that is not CV_8UC1, masks of
// different sizes, or an object-space pixel that is not > 0.
BlindScore scoreBlindDetection(const std::vector<lfi::Defect>& found, const std::vector<TrueDefect>& truth,
                               double objectPixel_mm);

}  // namespace lfi::study
