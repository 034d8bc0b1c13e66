// SPDX-License-Identifier: Apache-2.0
#include "lfi/controller/inspection_record.h"

#include "lfi/core/error.h"
#include "lfi/core/image.h"

#include <fmt/chrono.h>
#include <opencv2/imgproc.hpp>

#include <chrono>

namespace lfi {

using nlohmann::ordered_json;

nlohmann::ordered_json recordJson(const InspectionRecord& r) {
  ordered_json j;
  j["format"] = "lfi-inspection-record";
  j["version"] = 1;
  j["part"] = r.part;
  j["time_utc"] = r.time_utc;
  j["bench"] = {{"file", r.benchFile}, {"reference_hash", r.benchHash}};
  j["reference"] = r.reference;
  j["status"] = r.verdict ? "inspected" : "error";
  if (!r.verdict) j["error"] = r.error;
  j["verdict"] = r.verdict ? ordered_json(r.verdict->pass ? "pass" : "fail") : ordered_json(nullptr);
  j["reasons"] = r.verdict ? r.verdict->reasons : std::vector<std::string>{};
  j["coverage_factor"] = r.coverageFactor;
  j["inside_depth_mm"] = r.insideDepth_mm ? ordered_json(*r.insideDepth_mm) : ordered_json();
  ordered_json defects = ordered_json::array();
  if (r.verdict)
    for (const PartDefect& d : r.verdict->defects) {
      const Defect& px = d.image;
      defects.push_back({{"centroid_mm", {d.centroid_mm.x, d.centroid_mm.y}},
                         {"centroid_u_mm", {d.centroidU_mm.x, d.centroidU_mm.y}},
                         {"inside_mm", d.inside_mm ? ordered_json{d.inside_mm->x, d.inside_mm->y} : ordered_json()},
                         {"centroid_px", {px.centroid_px.x, px.centroid_px.y}},
                         {"area_mm2", d.area_mm2},
                         {"area_px", px.area_px},
                         {"bounds_px", {px.bounds_px.x, px.bounds_px.y, px.bounds_px.width, px.bounds_px.height}},
                         {"peak_contrast", px.peakContrast},
                         {"mean_contrast", px.meanContrast},
                         {"dark", px.dark}});
    }
  j["defects"] = defects;
  j["images"] = r.images;
  j["analysis_ms"] = r.analysis_ms;
  j["units"] =
      "lengths mm, areas mm², pixels of the camera image (OpenCV's: the top-left pixel's centre is (0, 0)); "
      "the part's frame: x along columns, y up the image, origin at the bench's part_centre_px";
  return j;
}

std::string recordText(const InspectionRecord& record, int indent) {
  return recordJson(record).dump(indent, ' ', false, ordered_json::error_handler_t::replace);
}

RecordSummary readRecordSummary(const nlohmann::json& j, const std::string& where) {
  RecordSummary s;
  try {
    // (A number that is not a non-negative integer would convert with undefined behaviour: 1e50, -1, 2.5.)
    if (!j.at("part").is_number_unsigned())
      fail(Errc::InvalidFile, "{}: not an inspection record: its part is {}, not a part number", where,
           j.at("part").dump());
    s.part = j.at("part").get<std::uint64_t>();
    s.time_utc = j.at("time_utc");
    s.status = j.at("status");
    if (!j.at("verdict").is_null()) s.verdict = j.at("verdict");
    for (const auto& d : j.at("defects")) {
      const auto& c = d.at("centroid_mm");
      s.defects_mm.emplace_back(c.at(0).get<double>(), c.at(1).get<double>());
    }
  } catch (const nlohmann::json::exception& e) {
    fail(Errc::InvalidFile, "{}: not an inspection record: {}", where, e.what());
  }
  return s;
}

cv::Mat overlayImage(const cv::Mat& image, const PartVerdict& verdict, const cv::Mat& mask) {
  cv::Mat values;
  image.convertTo(values, CV_32F);
  const double white = percentile(values, 0.999);
  cv::Mat grey, out;
  values.convertTo(grey, CV_8U, white > 0 ? 255.0 / white : 1.0);
  cv::cvtColor(grey, out, cv::COLOR_GRAY2BGR);
  if (!mask.empty()) {
    cv::Mat edge;
    cv::morphologyEx(mask, edge, cv::MORPH_GRADIENT, cv::Mat::ones(3, 3, CV_8U));
    out.setTo(cv::Scalar(255, 128, 0), edge & mask);
  }
  // Outlines one pixel outside each region, so that the defect's own pixels stay visible.
  const double scale = std::max(0.3, std::min(out.cols, out.rows) / 1500.0);
  int number = 0;
  for (const PartDefect& d : verdict.defects) {
    const cv::Rect r = d.image.bounds_px;
    const cv::Scalar colour = d.image.dark ? cv::Scalar(0, 0, 255) : cv::Scalar(0, 255, 255);
    cv::rectangle(out, cv::Point(r.x - 1, r.y - 1), cv::Point(r.x + r.width, r.y + r.height), colour, 1);
    cv::putText(out, std::to_string(++number), cv::Point(r.x + r.width + 2, std::max(r.y, 8)), cv::FONT_HERSHEY_PLAIN,
                scale, colour, 1);
  }
  return out;
}

std::string utcNow() {
  const auto now = std::chrono::system_clock::now();
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(now.time_since_epoch()).count() % 1000;
  return fmt::format("{:%Y-%m-%dT%H:%M:%S}.{:03d}Z", fmt::gmtime(std::chrono::system_clock::to_time_t(now)), ms);
}

}  // namespace lfi
