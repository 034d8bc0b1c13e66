// SPDX-License-Identifier: Apache-2.0
// The blind detector in the study (docs/study.md, "Blind detector"): the
// golden model of the intact lens under one illumination, the declared
// detection settings, and what the defect finder finds in each scene's frame,
// scored against the ground truth.

#include "lfi/study/blind_scoring.h"

#include "lfi/core/error.h"
#include "lfi/inspection/defects.h"
#include "lfi/inspection/golden_model.h"

#include "study_internal.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>

namespace lfi::study {

BlindScore scoreBlindDetection(const std::vector<lfi::Defect>& found, const std::vector<TrueDefect>& truth,
                               double objectPixel_mm) {
  if (!(objectPixel_mm > 0) || !std::isfinite(objectPixel_mm))
    fail(Errc::InvalidArgument, "blind scoring: the object-space pixel {} mm must be > 0", objectPixel_mm);
  for (const TrueDefect& t : truth)
    if (t.mask.type() != CV_8UC1 || t.mask.size() != truth.front().mask.size())
      fail(Errc::InvalidArgument,
           "blind scoring: a defect's mask ({} x {}, type {}) is not an 8-bit image of the "
           "first mask's size",
           t.mask.cols, t.mask.rows, t.mask.type());

  // Every (region, defect) pair that matches, nearest first.
  struct Match {
    double distance_px;
    size_t region, defect;
  };
  std::vector<Match> matches;
  std::vector<char> onDefect(found.size(), 0);
  for (size_t r = 0; r < found.size(); ++r) {
    const Vec2& c = found[r].centroid_px;
    const cv::Point pixel(static_cast<int>(std::lround(c.x)), static_cast<int>(std::lround(c.y)));
    for (size_t d = 0; d < truth.size(); ++d) {
      const double distance = (c - truth[d].centre_px).length();
      const bool inMask =
          pixel.inside(cv::Rect(0, 0, truth[d].mask.cols, truth[d].mask.rows)) && truth[d].mask.at<uchar>(pixel) != 0;
      if (inMask || distance <= 1.0) {
        matches.push_back({distance, r, d});
        onDefect[r] = 1;
      }
    }
  }
  std::stable_sort(matches.begin(), matches.end(),
                   [](const Match& a, const Match& b) { return a.distance_px < b.distance_px; });

  BlindScore score;
  score.regionOf.assign(truth.size(), -1);
  score.positionError_mm.assign(truth.size(), std::nullopt);
  std::vector<char> taken(found.size(), 0);
  for (const Match& m : matches) {
    if (score.regionOf[m.defect] >= 0 || taken[m.region]) continue;
    score.regionOf[m.defect] = static_cast<int>(m.region);
    score.positionError_mm[m.defect] = m.distance_px * objectPixel_mm;
    taken[m.region] = 1;
    ++score.hits;
  }
  score.misses = static_cast<int>(truth.size()) - score.hits;
  for (size_t r = 0; r < found.size(); ++r) {
    if (taken[r]) continue;
    if (onDefect[r])
      ++score.extraRegions;
    else
      score.falseAlarmRegions.push_back(static_cast<int>(r));
  }
  score.falseAlarms = static_cast<int>(score.falseAlarmRegions.size());
  return score;
}

namespace detail {

GoldenModel trainGoldenModel(const cv::Mat& intactRadiance, const sim::CameraSensorModel& sensor, std::uint64_t seed,
                             int threads) {
  GoldenModelTrainer trainer;
  for (int k = 0; k < kGoldenFrames; ++k)
    trainer.add(sensor.capture(intactRadiance, seed + static_cast<std::uint64_t>(k), threads));
  // The floor is the sensor model's own noise: read noise and quantisation
  // (noiseDn(0)) and shot noise at DN per electron.
  const double dnPerElectron = sensor.gain / sensor.fullWell_e * sensor.maxDigitalNumber();
  return trainer.model({sensor.noiseDn(0), dnPerElectron});
}

DetectionSettings blindSettings(const Bench& bench, const sim::TelecentricCamera& camera) {
  const double radius_px = bench.defects.inclusionRadius_mm / camera.objectPixel_mm();
  DetectionSettings s;
  s.absolute_dn = kBlindAbsoluteDn;
  s.relative = kBlindRelative;
  s.smoothing_px = std::min(100.0, kMatchedSigmaPerRadius * radius_px);
  s.closing_px = std::clamp(static_cast<int>(std::lround(kClosingPerRadius * radius_px)), 1, 100);
  s.minArea_px = kBlindMinArea_px;
  return s;
}

nlohmann::ordered_json blindDetectorJson(const DetectionSettings& s, const sim::TelecentricCamera& camera) {
  return {{"detector", "lfi::DefectFinder (golden-template comparison, no ground truth)"},
          {"golden_model",
           "per illumination: mean and sample deviation of training_frames camera frames of the "
           "intact lens's rendering (independent noise draws), the camera's noise "
           "(read, quantisation, shot) as the deviation's floor"},
          {"training_frames", kGoldenFrames},
          {"mask", "the intact lens's footprint on the camera (its geometry, as a bench knows it from its design)"},
          {"settings",
           {{"absolute_dn", s.absolute_dn},
            {"relative", s.relative},
            {"smoothing_px", s.smoothing_px},
            {"closing_px", s.closing_px},
            {"min_area_px", s.minArea_px}}},
          {"object_pixel_mm", camera.objectPixel_mm()},
          {"hit",
           "a found region whose centroid lies in a defect's (dilated) ground-truth mask or within one "
           "pixel of where the defect's centre appears; one region per defect, nearest first"},
          {"extra_regions", "further regions on a defect that is already hit (fragments)"},
          {"false_alarms",
           "found regions on no defect; secondary: those whose bounding box lies within the "
           "smoothing's reach (3 smoothing_px) of a pixel where the rendered radiance differs from "
           "the intact lens's"},
          {"position_error_mm",
           "distance, in object space, between the hit region's centroid and where the "
           "defect's centre appears"}};
}

nlohmann::ordered_json blindFindings(const cv::Mat& frame, const DefectFinder& finder,
                                     const DetectionSettings& settings, const SceneSpec& spec,
                                     const std::vector<cv::Mat>& masks, const std::vector<Vec2>& centres,
                                     const cv::Mat& changed, double objectPixel_mm) {
  const std::vector<lfi::Defect> found = finder.find(frame);
  std::vector<TrueDefect> truth;
  for (size_t k = 0; k < masks.size(); ++k) truth.push_back({masks[k], centres[k]});
  const BlindScore score = scoreBlindDetection(found, truth, objectPixel_mm);
  // A false alarm is secondary when light the defect changed lies within the
  // smoothing's reach (3 sigma) of its bounding box: the smoothed difference
  // spreads a change that far.
  cv::Mat nearChange = changed;
  if (const int reach = static_cast<int>(std::ceil(3 * settings.smoothing_px)); reach > 0)
    cv::dilate(changed, nearChange, cv::getStructuringElement(cv::MORPH_ELLIPSE, {2 * reach + 1, 2 * reach + 1}));
  int secondary = 0;
  for (const int r : score.falseAlarmRegions)
    if (cv::countNonZero(nearChange(found[static_cast<size_t>(r)].bounds_px)) > 0) ++secondary;
  nlohmann::ordered_json out = {{"regions", found.size()},
                                {"hits", score.hits},
                                {"misses", score.misses},
                                {"false_alarms", score.falseAlarms},
                                {"secondary_false_alarms", secondary},
                                {"extra_regions", score.extraRegions},
                                {"defects", nlohmann::ordered_json::object()}};
  // Every region, with the defect it hit (null: a false alarm or an extra region).
  out["found"] = nlohmann::ordered_json::array();
  for (size_t r = 0; r < found.size(); ++r) {
    const auto hit = std::find(score.regionOf.begin(), score.regionOf.end(), static_cast<int>(r));
    out["found"].push_back(
        {{"centroid_px", {found[r].centroid_px.x, found[r].centroid_px.y}},
         {"area_px", found[r].area_px},
         {"dark", found[r].dark},
         {"defect",
          hit == score.regionOf.end()
              ? nlohmann::ordered_json(nullptr)
              : nlohmann::ordered_json(spec.defects[static_cast<size_t>(hit - score.regionOf.begin())].name)}});
  }
  for (size_t k = 0; k < spec.defects.size(); ++k) {
    const std::optional<double>& error = score.positionError_mm[k];
    out["defects"][spec.defects[k].name] = {{"found", error.has_value()},
                                            {"position_error_mm", error ? nlohmann::ordered_json(*error) : nullptr}};
  }
  return out;
}

}  // namespace detail

}  // namespace lfi::study
