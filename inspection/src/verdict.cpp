// SPDX-License-Identifier: Apache-2.0
#include "lfi/inspection/verdict.h"

#include "lfi/core/error.h"

#include <fmt/format.h>

#include <cmath>

namespace lfi {

PartVerdict judgePart(const std::vector<Defect>& defects, const PartFrame& frame, const PassRules& rules) {
  const cv::Matx22d& a = frame.perPixel_mm;
  const double det = cv::determinant(a);
  if (!(std::abs(det) > 0) || !std::isfinite(det) || !std::isfinite(frame.origin_px.x) ||
      !std::isfinite(frame.origin_px.y))
    fail(Errc::InvalidArgument,
         "verdict: the part's frame (per pixel [{}, {}, {}, {}] mm, origin ({}, {}) px) is not finite or maps the "
         "image onto a line",
         a(0, 0), a(0, 1), a(1, 0), a(1, 1), frame.origin_px.x, frame.origin_px.y);
  if (rules.maxDefects < 0 || (rules.maxDefectArea_mm2 && !(*rules.maxDefectArea_mm2 >= 0)) ||
      (rules.maxTotalArea_mm2 && !(*rules.maxTotalArea_mm2 >= 0)))
    fail(Errc::InvalidArgument, "verdict: pass/fail limits must be >= 0");
  PartVerdict verdict;
  double total_mm2 = 0;
  for (const Defect& d : defects) {
    PartDefect p{d, frame.toPart(d.centroid_px), frame.area_mm2(d.area_px), frame.toPartU(d.centroid_px)};
    total_mm2 += p.area_mm2;
    verdict.defects.push_back(p);
  }
  const auto count = static_cast<long>(defects.size());
  if (count > rules.maxDefects)
    verdict.reasons.push_back(
        fmt::format("{} defect{} (at most {} allowed)", count, count == 1 ? "" : "s", rules.maxDefects));
  if (rules.maxDefectArea_mm2)
    for (const PartDefect& p : verdict.defects)
      if (p.area_mm2 > *rules.maxDefectArea_mm2)
        verdict.reasons.push_back(
            fmt::format("a defect of {:.3g} mm² at ({:.2f}, {:.2f}) mm (at most {:.3g} mm² "
                        "allowed)",
                        p.area_mm2, p.centroid_mm.x, p.centroid_mm.y, *rules.maxDefectArea_mm2));
  if (rules.maxTotalArea_mm2 && total_mm2 > *rules.maxTotalArea_mm2)
    verdict.reasons.push_back(
        fmt::format("defects of {:.3g} mm² in all (at most {:.3g} mm² allowed)", total_mm2, *rules.maxTotalArea_mm2));
  verdict.pass = verdict.reasons.empty();
  return verdict;
}

}  // namespace lfi
