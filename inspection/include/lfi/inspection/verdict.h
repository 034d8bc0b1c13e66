// SPDX-License-Identifier: Apache-2.0
#pragma once
// A part's verdict from the defects its image shows (defects.h): each defect
// placed in the part's frame in millimetres, and pass/fail by the bench's rules.
//
// The part's frame, seen through an object-side telecentric camera: origin at
// the image point `origin_px` (the part's nominal position), its axes the
// bench's (the display's x and y, world +z towards the camera), reached from
// the image by the camera's linear map A (`perPixel_mm`, the part's (x, y)
// per image column and row: its scale, rotation and mirroring, as `lfi
// calibrate display` measures them):
//   (x_mm, y_mm) = A · (column - origin.x, row - origin.y)
// An uncalibrated camera is taken to look down the axis with its rows along
// +x: A = [[p, 0], [0, -p]] for one camera pixel = p mm on the part (sensor
// pitch / magnification), x along the columns and y up the image
// (PartFrame::isotropic). Areas scale by |det A|. Pixel coordinates are
// OpenCV's: the top-left pixel's centre is (0, 0).
//
//   rule                 units  a part fails when
//   maxDefects           -      it shows more defects than this (0: any defect fails it)
//   maxDefectArea_mm2    mm²    one defect is larger than this (none: no such limit)
//   maxTotalArea_mm2     mm²    its defects together are larger than this (none: no such limit)

#include "lfi/core/geometry.h"
#include "lfi/inspection/defects.h"

#include <opencv2/core.hpp>

#include <cmath>

#include <optional>
#include <string>
#include <vector>

namespace lfi {

struct PartFrame {
  cv::Matx22d perPixel_mm = cv::Matx22d(1, 0, 0, -1);
  Vec2 origin_px;
  // Expanded uncertainties, at one coverage factor: of A's elements, of the
  // origin, and of a centroid on the image per axis (a region's centroid is
  // known to within its pixel: k / sqrt(12) px).
  cv::Matx22d perPixelU_mm = cv::Matx22d::zeros();
  Vec2 originU_px{0, 0};
  double centroidU_px = 0;

  static PartFrame isotropic(double pixel_mm, const Vec2& origin_px) {
    return {cv::Matx22d(pixel_mm, 0, 0, -pixel_mm), origin_px};
  }
  Vec2 toPart(const Vec2& px) const {
    const Vec2 d = px - origin_px;
    return {perPixel_mm(0, 0) * d.x + perPixel_mm(0, 1) * d.y, perPixel_mm(1, 0) * d.x + perPixel_mm(1, 1) * d.y};
  }
  // The expanded uncertainty of toPart(px) per axis: A's, the origin's and
  // the centroid's, independent and propagated linearly.
  Vec2 toPartU(const Vec2& px) const {
    const Vec2 d = px - origin_px;
    const cv::Matx22d &a = perPixel_mm, &ua = perPixelU_mm;
    const auto axis = [&](int i) {
      const double fromA = std::hypot(d.x * ua(i, 0), d.y * ua(i, 1));
      const double fromOrigin = std::hypot(a(i, 0) * originU_px.x, a(i, 1) * originU_px.y);
      const double fromCentroid = std::hypot(a(i, 0), a(i, 1)) * centroidU_px;
      return std::sqrt(fromA * fromA + fromOrigin * fromOrigin + fromCentroid * fromCentroid);
    };
    return {axis(0), axis(1)};
  }

  double area_mm2(double area_px) const {
    const cv::Matx22d& a = perPixel_mm;
    return std::abs(area_px * a(0, 0) * a(1, 1) - area_px * a(0, 1) * a(1, 0));
  }
};

struct PassRules {
  int maxDefects = 0;
  std::optional<double> maxDefectArea_mm2;
  std::optional<double> maxTotalArea_mm2;
};

struct PartDefect {
  Defect image;      // in camera pixels
  Vec2 centroid_mm;  // in the part's frame
  double area_mm2 = 0;
  Vec2 centroidU_mm;  // its expanded uncertainty per axis (PartFrame::toPartU)
  // Where the defect is inside the part, at the bench's defect depth, traced
  // back through the part's surfaces (controller/inspector.h); none without
  // the part's model, or where the camera's ray does not reach that depth.
  std::optional<Vec2> inside_mm;
};

struct PartVerdict {
  bool pass = true;
  std::vector<PartDefect> defects;   // largest first, as found
  std::vector<std::string> reasons;  // one line per rule the part broke; empty when it passes
};

// Throws Errc::InvalidArgument for a frame or rule out of range.
PartVerdict judgePart(const std::vector<Defect>& defects, const PartFrame& frame, const PassRules& rules);

}  // namespace lfi
