// SPDX-License-Identifier: Apache-2.0
// Detection: where each defect is on the camera (ground truth from the
// geometry), and the declared criterion that judges a scene's frame against
// the intact lens's (contrast-to-noise per defect, verdicts, flagged regions).

#include "study_internal.h"

#include "lfi/core/error.h"
#include "lfi/sim/render.h"

#include <opencv2/imgproc.hpp>

#include <cmath>
#include <optional>

namespace lfi::study::detail {

namespace fs = std::filesystem;
using sim::Object;
using sim::Solid;

namespace {

cv::Mat defectMask(const sim::Scene& scene, const sim::TelecentricCamera& camera, const Solid& marker) {
  cv::Mat mask(camera.height, camera.width, CV_8UC1, cv::Scalar(0));
  sim::IntervalList list;
  for (int j = 0; j < camera.height; ++j)
    for (int i = 0; i < camera.width; ++i) {
      const auto path = sim::refractionPath(scene, camera.ray(i, j, {0.5, 0.5}, {0, 0}));
      for (size_t k = 0; k + 1 < path.size() && !mask.at<uchar>(j, i); ++k) {
        const Vec3 seg = path[k + 1] - path[k];
        const double len = seg.length();
        if (len <= 0) continue;
        marker.intervals({path[k], seg / len}, list);
        // A path that ends on the defect (an absorber) or turns on its surface
        // (total internal reflection off a bubble) touches it only at a
        // segment's end, where rounding decides: a touch within the tracer's
        // own step off a surface counts.
        constexpr double kTouch = sim::Scene::kTMin;
        for (int m = 0; m < list.size(); ++m)
          if (list[m].exit.t > -kTouch && list[m].enter.t < len + kTouch) mask.at<uchar>(j, i) = 255;
      }
    }
  return mask;
}

// Where a world point appears in the frame: the sensor position whose chief
// ray, refracted by `part`, passes through it, found by moving the sensor
// position by the lateral miss (the camera maps object-space x, y linearly
// onto the sensor, so a few steps converge). Continuous pixel coordinates
// (pixel i spans [i, i + 1)).
Vec2 apparentPosition(const sim::Scene& part, const sim::TelecentricCamera& camera, const Vec3& point) {
  const Vec2 target = camera.project(point);
  Vec2 p = target;
  for (int step = 0; step < 32; ++step) {
    const double i = std::floor(p.x), j = std::floor(p.y);
    const auto path =
        sim::refractionPath(part, camera.ray(static_cast<int>(i), static_cast<int>(j), {p.x - i, p.y - j}, {0, 0}));
    // The path's point nearest `point`.
    Vec3 nearest = path.front();
    for (size_t k = 0; k + 1 < path.size(); ++k) {
      const Vec3 seg = path[k + 1] - path[k];
      const double len2 = seg.length2();
      const double t = len2 > 0 ? std::clamp((point - path[k]).dot(seg) / len2, 0.0, 1.0) : 0.0;
      const Vec3 q = path[k] + seg * t;
      if ((q - point).length2() < (nearest - point).length2()) nearest = q;
    }
    const Vec2 miss = target - camera.project(nearest);
    p += miss;
    if (miss.length() < 1e-6) break;
  }
  return p;
}

}  // namespace

GroundTruth traceGroundTruth(const Bench& bench, const std::vector<SceneSpec>& specs,
                             const sim::TelecentricCamera& camera) {
  GroundTruth truth;
  for (const SceneSpec& spec : specs) {
    const std::vector<Object> part = partObjects(bench, spec);
    if (spec.name == "intact")
      truth.lens = defectMask(sim::Scene(part), camera, *std::get<std::shared_ptr<const Solid>>(part[0].shape));
    const sim::Scene scene(part);
    cv::Mat all = cv::Mat::zeros(camera.height, camera.width, CV_8UC1);
    std::vector<cv::Mat> masks;
    // The scene's lens as it is (moved, its index changed) without its
    // defects: what the defects' centres are seen through.
    SceneSpec lensOnly = spec;
    lensOnly.cuts.clear();
    lensOnly.inclusions.clear();
    const sim::Scene lens(partObjects(bench, lensOnly));
    std::vector<Vec2> centres;
    for (const Defect& defect : spec.defects) {
      const sim::Bounds b = defect.marker->bounds();
      const Vec3 centre = (b.lo + b.hi) * 0.5;
      centres.push_back(apparentPosition(lens, camera, centre) - Vec2(0.5, 0.5));
      cv::Mat m = defectMask(scene, camera, *defect.marker);
      if (cv::countNonZero(m) == 0) {
        const Vec2 p = camera.project(centre);
        const cv::Point px(static_cast<int>(p.x), static_cast<int>(p.y));
        if (px.inside(cv::Rect(0, 0, m.cols, m.rows))) m.at<uchar>(px) = 255;
      }
      cv::dilate(m, m, cv::Mat::ones(3, 3, CV_8U));
      masks.push_back(m);
      all |= m;
    }
    truth.masks.push_back(std::move(masks));
    truth.centres.push_back(std::move(centres));
    truth.allDefects.push_back(all);
  }
  return truth;
}

namespace {

double robustSigma(const cv::Mat& values, const cv::Mat& exclude) {
  std::vector<float> v;
  for (int r = 0; r < values.rows; ++r)
    for (int c = 0; c < values.cols; ++c)
      if (exclude.empty() || !exclude.at<uchar>(r, c)) v.push_back(values.at<float>(r, c));
  if (v.size() < 16) return 0;
  auto median = [](std::vector<float> x) {
    std::nth_element(x.begin(), x.begin() + x.size() / 2, x.end());
    return static_cast<double>(x[x.size() / 2]);
  };
  const double m = median(v);
  for (float& x : v) x = static_cast<float>(std::abs(x - m));
  return 1.4826 * median(v);
}

// Flagged regions (3x3 mean of z above kFlagSigma of its own spread) away from the defects'
// masks, split by cause. With common random numbers a pixel's rendered
// radiance is bit-identical to the intact lens's unless some light path of it
// touched the defect: a flagged region where nothing changed is a false
// positive (the camera's noise alone); one where the radiance changed is a
// secondary image of the defect (light that met the defect and landed
// elsewhere, e.g. after internal reflection), real but away from it.
struct FlaggedRegions {
  int falsePositives = 0;
  int secondary = 0;
};

FlaggedRegions flaggedRegions(const cv::Mat& z, double sigma, const cv::Mat& defects, const cv::Mat& changed) {
  // The mean over the 3x3 neighbours inside the frame (9, 6 at an edge, 4 in a
  // corner): its sigma is sigma / sqrt(n). A reflected border would count
  // pixels twice and raise the spread of edge means above the threshold's
  // assumption (many more false positives along the frame's edge).
  cv::Mat sum3, count3;
  cv::boxFilter(z, sum3, CV_32F, {3, 3}, {-1, -1}, false, cv::BORDER_CONSTANT);
  cv::boxFilter(cv::Mat::ones(z.size(), CV_32F), count3, CV_32F, {3, 3}, {-1, -1}, false, cv::BORDER_CONSTANT);
  cv::Mat standardised;
  cv::sqrt(count3, count3);
  cv::divide(sum3, count3, standardised);  // (n mean) / sqrt(n) = mean / (1 / sqrt(n)), unit variance
  const cv::Mat flagged = cv::abs(standardised) > kFlagSigma * sigma;
  cv::Mat labels;
  const int n = cv::connectedComponents(flagged, labels, 8, CV_32S);
  std::vector<char> onDefect(static_cast<size_t>(n), 0), onChange(static_cast<size_t>(n), 0);
  for (int r = 0; r < labels.rows; ++r)
    for (int c = 0; c < labels.cols; ++c) {
      const auto l = static_cast<size_t>(labels.at<int>(r, c));
      onDefect[l] |= defects.at<uchar>(r, c) ? 1 : 0;
      onChange[l] |= changed.at<uchar>(r, c) ? 1 : 0;
    }
  FlaggedRegions out;
  for (size_t l = 1; l < static_cast<size_t>(n); ++l) {
    if (onDefect[l]) continue;
    (onChange[l] ? out.secondary : out.falsePositives) += 1;
  }
  return out;
}

cv::Mat toFloat(const cv::Mat& frame) {
  cv::Mat f;
  frame.convertTo(f, CV_32F);
  return f;
}

}  // namespace

Uniformity uniformityOf(const cv::Mat& intact, const Bench& bench, const sim::TelecentricCamera& camera) {
  const double inner_px = 0.9 * 0.5 * bench.lens.diameter_mm / camera.objectPixel_mm();
  const Vec2 axis = camera.project({0, 0, 0});  // (pixel centres at + 0.5)
  std::vector<float> values;
  for (int r = 0; r < intact.rows; ++r)
    for (int c = 0; c < intact.cols; ++c)
      if (std::hypot(c + 0.5 - axis.x, r + 0.5 - axis.y) < inner_px) values.push_back(intact.at<float>(r, c));
  if (values.empty()) fail(Errc::Config, "{}: the camera sees none of the lens", bench.source);
  const double brightest = *std::max_element(values.begin(), values.end());
  double mean = 0, lit = 0;
  for (const float v : values) mean += v, lit += v > 0.25 * brightest ? 1 : 0;
  mean /= static_cast<double>(values.size());
  double var = 0;
  for (const float v : values) var += (v - mean) * (v - mean);
  var /= static_cast<double>(values.size());
  return {lit / static_cast<double>(values.size()), mean > 0 ? std::sqrt(var) / mean : 0};
}

Evaluation evaluate(const Bench& bench, const Illumination& light, const std::vector<SceneSpec>& specs,
                    const GroundTruth& truth, const sim::TelecentricCamera& camera, sim::CameraSensorModel sensor,
                    sim::RenderOptions ro, std::uint64_t seed, Progress& progress, double renderUnits,
                    bool secondRendering, const fs::path* imagesDir, Overwrite overwrite,
                    const DetectionSettings* blind) {
  auto renderScene = [&](const SceneSpec& spec, std::uint64_t mcSeed, const std::string& label) {
    std::vector<Object> objects = partObjects(bench, spec);
    objects.push_back(backlight(bench, light));
    const sim::Scene scene(std::move(objects));
    ro.seed = mcSeed;
    ro.progress = progress.step(light.setup + ": " + label, renderUnits);
    return sim::render(scene, camera, ro);
  };
  // Common random numbers: every scene of an illumination is rendered with the
  // same seed, so paths that never touch a defect are identical and the Monte
  // Carlo noise of the simulation cancels in every difference; what remains
  // is the camera's own noise, drawn independently for every frame, as on a
  // real bench. The intact reference sets the exposure; the same radiance
  // with a second noise draw is the false-positive control.
  const cv::Mat intact = renderScene(specs[0], seed, "intact");
  cv::Mat smooth;
  cv::blur(intact, smooth, {3, 3});
  double brightest = 0;
  cv::minMaxLoc(smooth, nullptr, &brightest);
  sensor.exposeFor(brightest, bench.camera.exposureFill);
  const cv::Mat intactFrame = toFloat(sensor.capture(intact, seed * 7919 + 1, ro.threads));
  const cv::Mat controlFrame = toFloat(sensor.capture(intact, seed * 7919 + 2, ro.threads));
  // The blind detector's golden model: frames of the intact lens with noise
  // draws of their own (none of them is a frame it inspects).
  std::optional<DefectFinder> finder;
  if (blind) finder.emplace(trainGoldenModel(intact, sensor, seed * 7919 + 1000, ro.threads), truth.lens, *blind);

  // Per-pixel noise expected from the sensor model for a difference of two
  // frames; differences are judged in units of it (z).
  const double dnPerUnit = sensor.electronsPerUnit * sensor.gain / sensor.fullWell_e * sensor.maxDigitalNumber();
  // (Against the intact lens's frame of the same rendering: its radiance and frame.)
  auto zScoreAgainst = [&](const cv::Mat& frame, const cv::Mat& radiance, const cv::Mat& reference,
                           const cv::Mat& referenceFrame) {
    cv::Mat z(frame.size(), CV_32FC1);
    for (int r = 0; r < z.rows; ++r)
      for (int c = 0; c < z.cols; ++c) {
        const double a = sensor.noiseDn(reference.at<float>(r, c) * dnPerUnit);
        const double b = sensor.noiseDn(radiance.at<float>(r, c) * dnPerUnit);
        z.at<float>(r, c) =
            static_cast<float>((frame.at<float>(r, c) - referenceFrame.at<float>(r, c)) / std::sqrt(a * a + b * b));
      }
    return z;
  };
  auto zScore = [&](const cv::Mat& frame, const cv::Mat& radiance) {
    return zScoreAgainst(frame, radiance, intact, intactFrame);
  };
  Evaluation out;
  {
    const cv::Mat bright = smooth > 0.25 * brightest;
    out.intactLitFraction =
        static_cast<double>(cv::countNonZero(bright & truth.lens)) / std::max(1, cv::countNonZero(truth.lens));
  }
  out.intactUniformity = uniformityOf(intact, bench, camera);
  // The second rendering of every scene with independent random numbers and
  // its own camera noise: a second, independent estimate of every difference.
  const std::uint64_t independentSeed = seed + 99;
  cv::Mat independent, independentFrame;
  if (secondRendering) {
    independent = renderScene(specs[0], independentSeed, "intact (independent)");
    independentFrame = toFloat(sensor.capture(independent, seed * 7919 + 3, ro.threads));
    // How large the Monte Carlo noise of one rendering is against the camera's
    // noise, both in DN, where the intact lens is lit.
    const cv::Mat lit = intact > 0.05 * brightest;
    const double mcSigma = robustSigma(cv::Mat((independent - intact) * dnPerUnit), ~lit) / std::sqrt(2.0);
    const double litMean = cv::mean(intact, lit)[0] * dnPerUnit;
    out.noise = {{"monte_carlo_dn", mcSigma},
                 {"sensor_dn", sensor.noiseDn(litMean)},
                 {"mean_lit_signal_dn", litMean},
                 {"common_random_numbers", true}};
  }

  for (const SceneSpec& spec : specs) {
    const bool isIntact = spec.name == "intact";
    const cv::Mat radiance = isIntact ? intact : renderScene(spec, seed, spec.name);
    const auto index = static_cast<std::uint64_t>(&spec - specs.data());
    const cv::Mat frame =
        isIntact ? controlFrame : toFloat(sensor.capture(radiance, seed * 7919 + 100 * (index + 1), ro.threads));
    const cv::Mat diff = zScore(frame, radiance);
    // The same difference from the independent rendering and camera noise:
    // the product of the two has the signal's square as its mean, without
    // the noise of either (docs/study.md, "Monte Carlo noise").
    cv::Mat second;
    if (!independent.empty()) {
      const cv::Mat again = isIntact ? independent : renderScene(spec, independentSeed, spec.name + " (independent)");
      const cv::Mat againFrame = toFloat(sensor.capture(again, seed * 7919 + 100 * (index + 1) + 50, ro.threads));
      second = zScoreAgainst(againFrame, again, independent, independentFrame);
    }
    const std::vector<cv::Mat>& masks = truth.masks[index];
    const cv::Mat& allDefects = truth.allDefects[index];
    // z has unit variance where the camera's noise is all there is; a larger
    // spread raises the bar accordingly.
    const double sigma = std::max(1.0, robustSigma(diff, allDefects));
    auto& sceneOut = out.scenes[spec.name];
    sceneOut["defects"] = nlohmann::ordered_json::object();
    for (size_t k = 0; k < spec.defects.size(); ++k) {
      const double meanSq = cv::mean(diff.mul(diff), masks[k])[0];
      const double oneRendering = std::sqrt(std::max(0.0, meanSq - sigma * sigma)) / sigma;
      const double cnr =
          second.empty() ? oneRendering : std::sqrt(std::max(0.0, cv::mean(diff.mul(second), masks[k])[0])) / sigma;
      auto& cell = sceneOut["defects"][spec.defects[k].name];
      cell = {{"verdict", verdictOf(cnr)}, {"cnr", cnr}, {"pixels", cv::countNonZero(masks[k])}};
      if (!second.empty()) cell["cnr_one_rendering"] = oneRendering;
    }
    cv::Mat changed = radiance != intact;
    cv::dilate(changed, changed, cv::Mat::ones(3, 3, CV_8U));
    const FlaggedRegions regions = flaggedRegions(diff, sigma, allDefects, changed);
    sceneOut["false_positives"] = regions.falsePositives;
    sceneOut["secondary_regions"] = regions.secondary;
    if (blind)
      sceneOut["blind"] =
          blindFindings(frame, *finder, *blind, spec, masks, truth.centres[index], changed, camera.objectPixel_mm());

    if (imagesDir) writeSceneImages(*imagesDir, spec, light, camera, sensor, frame, diff, overwrite);
  }
  return out;
}

nlohmann::ordered_json criterionJson() {
  return {{"cnr",
           "sqrt(max(0, mean over the defect mask of z z')) / s; z = (frame - intact frame) / per-pixel "
           "sensor noise of that difference, z' the same from a second rendering of both scenes with "
           "independent random numbers and camera noise; s = robust std of z outside the masks, at least "
           "1. The sweep renders once: there, and in cnr_one_rendering, z z' is z^2 - s^2"},
          {"detected_at_least", kDetectedCnr},
          {"weak_at_least", kWeakCnr},
          {"flag_sigma", kFlagSigma},
          {"false_positives",
           "flagged regions (mean of z over the n <= 9 pixels of the 3x3 "
           "neighbourhood inside the frame > flag_sigma s / sqrt(n)) away from "
           "the masks where the rendered radiance equals the intact lens's "
           "(common random numbers): the camera's noise alone"},
          {"secondary_regions",
           "flagged regions away from the masks where light that touched the "
           "defect lands (e.g. after internal reflection)"}};
}

}  // namespace lfi::study::detail
