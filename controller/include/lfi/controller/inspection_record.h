// SPDX-License-Identifier: Apache-2.0
#pragma once
// The record of one part's inspection, as `lfi inspect` writes it (one JSON
// file) and `lfi run` appends it (one line of a JSON Lines file), and the
// overlay image that shows its defects. docs/inspection.md gives the format:
//
//   key            meaning
//   format         "lfi-inspection-record", version 1
//   part           the part's number in its run (1 for `lfi inspect`)
//   time_utc       ISO 8601, when the part's image was in hand
//   bench          the bench file and its reference hash; reference: the package's folder
//   status         "inspected", or "error" (the part could not be inspected: `error` says why)
//   verdict        "pass" | "fail" | null (status "error"); reasons: the rules the part broke
//   defects        per defect: centroid_mm [x, y] in the part's frame (verdict.h),
//                  centroid_px [column, row], area_mm2, area_px, bounds_px [x, y, w, h],
//                  peak_contrast, mean_contrast, dark
//   images         the files written for the part, relative to the record's folder
//   analysis_ms    from the image in hand to the verdict

#include "lfi/inspection/verdict.h"

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include <cstdint>
#include <map>
#include <optional>
#include <string>

namespace lfi {

struct InspectionRecord {
  std::uint64_t part = 1;
  std::string time_utc;
  std::string benchFile, benchHash, reference;
  std::optional<PartVerdict> verdict;  // none: status "error"
  std::string error;
  std::map<std::string, std::string> images;  // role ("image", "overlay") → file
  double analysis_ms = 0;
  double coverageFactor = 2;             // k of the defects' centroid_u_mm (the bench file's)
  std::optional<double> insideDepth_mm;  // the depth of the defects' inside_mm (with the part's model)
};

nlohmann::ordered_json recordJson(const InspectionRecord& record);
// The record as JSON text: on one line (indent < 0, for JSON Lines) or
// indented; strings that are not UTF-8 (a path, a device's name) with U+FFFD.
std::string recordText(const InspectionRecord& record, int indent);

// What a run's summary needs of a record read back (records the run wrote, or
// another version's: only these keys are read). Throws Errc::InvalidFile
// naming `where` for a record without them.
struct RecordSummary {
  std::uint64_t part = 0;
  std::string time_utc;
  std::string status;   // "inspected" or "error"
  std::string verdict;  // "pass", "fail", or empty
  std::vector<Vec2> defects_mm;
};
RecordSummary readRecordSummary(const nlohmann::json& record, const std::string& where);

// The image scaled to 8 bits (its 99.9th percentile white) in grey, the
// mask's edge in blue, each defect's bounds outlined (dark defects red,
// bright ones yellow) with its number: CV_8UC3, BGR, the image's size.
cv::Mat overlayImage(const cv::Mat& image, const PartVerdict& verdict, const cv::Mat& mask);

// The current time, ISO 8601 UTC to the millisecond.
std::string utcNow();

}  // namespace lfi
