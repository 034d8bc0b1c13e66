// SPDX-License-Identifier: Apache-2.0
#pragma once
// The regions of the off pixels that the banded pass of defects.cpp found:
// grouping, closing, masking and labelling in small windows around them.

#include "lfi/inspection/defects.h"

#include <opencv2/core.hpp>

#include <vector>

namespace lfi::detail {

// out[j] = image[begin + j] - ideal[begin + j] along one row, as float (the difference's definition).
using DifferenceRow = void (*)(const void* imageRow, const float* ideal, int begin, int end, float* out);

// Off pixels: columns [begin, end) of one row.
struct Run {
  int row, begin, end;
};

// The runs in groups that the closing cannot join (see defect_regions.cpp).
std::vector<std::vector<Run>> separateGroups(const std::vector<Run>& runs, cv::Size size, int closing);

// The window that holds a group's runs and what its closing can add, inside the image.
cv::Rect windowOf(const std::vector<Run>& runs, cv::Size size, int closing);

// The regions of one group, appended to `defects`; `difference` reads `values`' rows.
void addRegions(const std::vector<Run>& group, const cv::Mat& values, DifferenceRow difference,
                const GoldenModel& model, const cv::Mat& mask, const DetectionSettings& settings,
                std::vector<Defect>& defects);

}  // namespace lfi::detail
