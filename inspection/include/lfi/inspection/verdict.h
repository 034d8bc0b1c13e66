// SPDX-License-Identifier: Apache-2.0
#pragma once
// A part's verdict from the defects its image shows (defects.h): each defect
// placed in the part's frame in millimetres, and pass/fail by the bench's rules.
//
// The part's frame, seen through an object-side telecentric camera: origin at
// the image point `origin_px` (the part's nominal position), x along the
// image's columns, y against its rows (up in the image), one camera pixel =
// `pixel_mm` on the part (sensor pitch / magnification):
//   x_mm = (column - origin.x) · pixel_mm,   y_mm = -(row - origin.y) · pixel_mm
// Pixel coordinates are OpenCV's: the top-left pixel's centre is (0, 0).
//
//   rule                 units  a part fails when
//   maxDefects           -      it shows more defects than this (0: any defect fails it)
//   maxDefectArea_mm2    mm²    one defect is larger than this (none: no such limit)
//   maxTotalArea_mm2     mm²    its defects together are larger than this (none: no such limit)

#include "lfi/core/geometry.h"
#include "lfi/inspection/defects.h"

#include <optional>
#include <string>
#include <vector>

namespace lfi {

struct PartFrame {
  double pixel_mm = 1;
  Vec2 origin_px;

  Vec2 toPart(const Vec2& px) const { return {(px.x - origin_px.x) * pixel_mm, -(px.y - origin_px.y) * pixel_mm}; }
  double area_mm2(double area_px) const { return area_px * pixel_mm * pixel_mm; }
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
};

struct PartVerdict {
  bool pass = true;
  std::vector<PartDefect> defects;   // largest first, as found
  std::vector<std::string> reasons;  // one line per rule the part broke; empty when it passes
};

// Throws Errc::InvalidArgument for a frame or rule out of range.
PartVerdict judgePart(const std::vector<Defect>& defects, const PartFrame& frame, const PassRules& rules);

}  // namespace lfi
