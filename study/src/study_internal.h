// SPDX-License-Identifier: Apache-2.0
#pragma once
// Internal to lfi_study: what its parts share — the declared detection
// criterion, the scenes and illuminations, one evaluation of them, the blind
// detector's settings, the sweep's variants, the display classes, the
// detection limits' scenes, the report's writers and the study's progress.

#include "lfi/core/atomic_file.h"
#include "lfi/core/light_field.h"
#include "lfi/inspection/defects.h"
#include "lfi/inspection/golden_model.h"
#include "lfi/sim/render.h"
#include "lfi/study/study.h"

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace lfi::study::detail {

// The declared detection criterion (docs/study.md).
inline constexpr double kDetectedCnr = 3.0;  // RMS excess signal per defect pixel >= 3 sigma
inline constexpr double kWeakCnr = 1.5;
inline constexpr double kFlagSigma = 5.0;  // false-positive flag: |3x3 mean of the difference| > 5 sigma_mean
inline const char* verdictOf(double cnr) {
  return cnr >= kDetectedCnr ? "detected" : cnr >= kWeakCnr ? "weak" : "missed";
}

// Overall progress of a study made of weighted steps.
class Progress {
 public:
  Progress(const StudyOptions& options, double totalUnits) : options_(options), total_(totalUnits) {}
  std::function<void(double)> step(const std::string& label, double units) {
    const double start = done_;
    done_ += units;
    return [this, label, start, units](double f) {
      if (options_.progress) options_.progress(label, std::min(1.0, (start + f * units) / total_));
    };
  }

 private:
  const StudyOptions& options_;
  double total_;
  double done_ = 0;
};

// ---- The scenes and illuminations (scenes.cpp) ---------------------------

struct Defect {
  std::string name;
  std::shared_ptr<const sim::Solid> marker;  // world frame: pixels whose chief path touches it show the defect
};

struct SceneSpec {
  std::string name;
  double iorFactor = 1;
  double lensShift_mm = 0;                          // along z
  std::vector<std::pair<Vec3, double>> cuts;        // centre (lens frame), radius
  std::vector<std::pair<Vec3, double>> inclusions;  // centre (world), radius
  bool bubbles = false;
  std::vector<Defect> defects;
};

// The seven scenes, the intact lens first.
std::vector<SceneSpec> sceneSpecs(const Bench& bench);
// The part of one scene: the lens (cut, shifted, its index changed) and its inclusions.
std::vector<sim::Object> partObjects(const Bench& bench, const SceneSpec& spec);

// One illumination of the part: which back light, and for the light field
// display, which light field, lookup and where the display actually sits.
struct Illumination {
  std::string setup;
  std::shared_ptr<const LightField> lightField;
  LightFieldLookup lookup = LightFieldLookup::Nearest;
  double displayError_mm = 0;  // display plane moved away from the lens (Δ error)
  // The "display" setup: the panel and optics that show the light field.
  std::shared_ptr<const sim::PanelEmission> panel;
};

// The bench's display with `optics` showing `shown` (drive levels from each
// panel pixel's chief ray into the light field, the bench's lookup).
std::shared_ptr<const sim::PanelEmission> displayPanel(const Bench& bench, const DisplayOpticsParams& optics,
                                                       const LightField& shown);

sim::Object backlight(const Bench& bench, const Illumination& light);

LightField captureLightField(const Bench& bench, const LightFieldGeometry& geometry, int samples, std::uint64_t seed,
                             int threads, const std::function<void(double)>& progress);

// ---- Detection (detection.cpp) --------------------------------------------

// Ground truth from the geometry, per scene: each defect's pixels (chief rays
// followed through the part by refraction touch it; a defect smaller than a
// pixel gets the pixel its centre projects to; dilated by one pixel for the
// depth-of-field blur), and the intact lens's pixels. It depends on the part
// and the camera only, not on the illumination, so it is traced once per camera.
struct GroundTruth {
  std::vector<std::vector<cv::Mat>> masks;  // [scene][defect]
  // [scene][defect]: where the defect's centre appears (the pixel position whose
  // chief ray, refracted by the scene's lens without its defects, passes through
  // it), (column, row) with pixel centres at whole numbers.
  std::vector<std::vector<Vec2>> centres;
  std::vector<cv::Mat> allDefects;  // [scene]
  cv::Mat lens;                     // the intact lens
};

GroundTruth traceGroundTruth(const Bench& bench, const std::vector<SceneSpec>& specs,
                             const sim::TelecentricCamera& camera);

struct Evaluation {
  // scene -> {defects: {defect: {verdict, cnr, pixels}}, false_positives, secondary_regions}
  nlohmann::ordered_json scenes;
  nlohmann::ordered_json noise;
  double intactLitFraction = 0;  // lens pixels of the intact frame above a quarter of the brightest
  Uniformity intactUniformity;   // of the intact lens's rendering
};

// The uniformity of an intact lens's rendering (study.h, Uniformity).
Uniformity uniformityOf(const cv::Mat& intact, const Bench& bench, const sim::TelecentricCamera& camera);

// Renders every scene under one illumination, passes each through the camera,
// and judges it against the intact lens by the declared criterion. With
// `secondRendering`, renders every scene a second time with independent
// random numbers and takes the Monte Carlo noise of each difference out of
// its CNR (docs/study.md, "Monte Carlo noise"). Writes the frames and
// difference images to imagesDir when it is given. With `blind`, also runs
// the blind detector on every frame (scenes -> scene -> "blind").
Evaluation evaluate(const Bench& bench, const Illumination& light, const std::vector<SceneSpec>& specs,
                    const GroundTruth& truth, const sim::TelecentricCamera& camera, sim::CameraSensorModel sensor,
                    sim::RenderOptions ro, std::uint64_t seed, Progress& progress, double renderUnits,
                    bool secondRendering, const std::filesystem::path* imagesDir, Overwrite overwrite,
                    const DetectionSettings* blind = nullptr);

// The declared criterion as study.json states it.
nlohmann::ordered_json criterionJson();

// ---- The blind detector (blind.cpp) -----------------------------------------

// Its declared settings (docs/study.md, "Blind detector").
inline constexpr int kGoldenFrames = 16;                // frames of the intact lens the golden model is trained from
inline constexpr double kBlindAbsoluteDn = 0;           // a: the variation holds all the study's frames vary by
inline constexpr double kBlindRelative = 5;             // b: 5 sigma of the smoothed difference
inline constexpr double kMatchedSigmaPerRadius = 0.63;  // Gaussian that best finds a disc of radius R: 0.63 R
inline constexpr double kClosingPerRadius = 1.0;        // closing radius, per inclusion radius
inline constexpr int kBlindMinArea_px = 1;

// The golden model of the intact lens under one illumination: kGoldenFrames
// camera frames of its rendering, each with its own noise draw (seeds seed,
// seed + 1, ...), and the camera's noise as the variation's floor.
GoldenModel trainGoldenModel(const cv::Mat& intactRadiance, const sim::CameraSensorModel& sensor, std::uint64_t seed,
                             int threads);
// The declared settings for the camera: smoothing and closing scale with the
// inclusion radius in its pixels.
DetectionSettings blindSettings(const Bench& bench, const sim::TelecentricCamera& camera);
// The detector, its settings and its scoring as study.json states them.
nlohmann::ordered_json blindDetectorJson(const DetectionSettings& settings, const sim::TelecentricCamera& camera);
// The detector (golden model, part mask, settings) on one scene's frame, scored against its ground truth:
// {regions, hits, misses, false_alarms, secondary_false_alarms, extra_regions,
//  found: [{centroid_px, area_px, dark, defect}], defects: {name: {found,
//  position_error_mm}}}. `changed`: pixels whose rendered radiance differs
// from the intact lens's (dilated).
nlohmann::ordered_json blindFindings(const cv::Mat& frame, const DefectFinder& finder,
                                     const DetectionSettings& settings, const SceneSpec& spec,
                                     const std::vector<cv::Mat>& masks, const std::vector<Vec2>& centres,
                                     const cv::Mat& changed, double objectPixel_mm);

// ---- What the study's runs share (study.cpp) --------------------------------

// A file's bytes; Errc::NotFound naming it when it cannot be read (sweep_file.cpp).
std::string fileBytes(const std::filesystem::path& file);

struct QualitySettings {
  int binning;          // extra binning of the bench camera (fewer, larger pixels)
  int samplesPerPixel;  // camera images
  int captureSamples;   // light field capture, per sensor pixel
};
QualitySettings settingsFor(Quality q);
// The bench's camera binned a further `binning` times (fewer, larger pixels).
sim::TelecentricCamera binnedCamera(const Bench& bench, int binning);
// The camera of one setup: conventional schlieren's has the knife edge in its stop.
sim::TelecentricCamera setupCamera(const Bench& bench, sim::TelecentricCamera camera, const std::string& setup);
// The light of one setup; the light field setups show `shown` (the bench's drive).
Illumination setupLight(const Bench& bench, const std::string& setup, std::shared_ptr<const LightField> shown);
// Every defect's CNR in one evaluation, keyed "scene/defect".
nlohmann::ordered_json cnrByDefect(const Evaluation& e);

// ---- The display-quality sweep (sweep.cpp) --------------------------------

struct SweepVariant {
  SweepPoint point;
  LightFieldGeometry geometry;
  double displayError_mm = 0;
};

// The sweep's light field variants, each captured only as large as the
// lens's footprint on the display plane needs. Every point is checked before
// the study starts: a known series, a light field that can be made, a display
// that stays below the lens.
std::vector<SweepVariant> sweepVariants(const Bench& bench, const std::vector<SweepPoint>& sweep);

// The display classes the study compares at the bench's panel (docs/study.md):
// the bench's display, a pinhole array and a lenticular sheet, each with the
// bench's pitch, gap and lens positions, and the share of the display plane
// that lets light through (the camera's samples needed grow with its inverse).
struct DisplayClass {
  std::string name;
  DisplayOpticsParams optics;
  double openShare;
};
std::vector<DisplayClass> displayClasses(const Bench& bench);

// ---- The detection limits (limits.cpp) ------------------------------------

// The scene of one limit point (its one defect named after its kind). Throws
// Errc::InvalidArgument naming the point for an unknown kind or a size the
// bench cannot make (a sphere that leaves the glass, a cut past the lens, an
// index outside [1, 5], a shift that meets a back light's plane).
SceneSpec limitScene(const Bench& bench, const LimitPoint& point);
// The intact lens, then every point's scene (none without points); also
// refuses a kind whose sizes are not ascending.
std::vector<SceneSpec> limitScenes(const Bench& bench, const std::vector<LimitPoint>& points);
// Per kind: its sizes, its unit, and per setup the CNRs and the limit (the
// smallest size from which every larger size is detected; null if the
// largest is not).
nlohmann::ordered_json limitCurves(const std::vector<LimitPoint>& points, const std::vector<std::string>& setups,
                                   const std::vector<std::vector<double>>& cnr);

// ---- The report (report.cpp) ----------------------------------------------

// One scene's camera frame under one illumination (EXR in DN, PNG) and its
// difference with the intact lens (PNG), in imagesDir.
void writeSceneImages(const std::filesystem::path& imagesDir, const SceneSpec& spec, const Illumination& light,
                      const sim::TelecentricCamera& camera, const sim::CameraSensorModel& sensor, const cv::Mat& frame,
                      const cv::Mat& diff, Overwrite overwrite);

// OUTDIR/report.html and OUTDIR/study.json from the study's document.
void writeReport(const std::filesystem::path& outDir, Overwrite mode, const nlohmann::ordered_json& study);

}  // namespace lfi::study::detail
