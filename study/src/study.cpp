// SPDX-License-Identifier: Apache-2.0
// The study driver: the five setups over the seven scenes, then the
// detection limits, the display-quality sweep and the display classes, each
// step's results gathered into study.json and the report as it goes.

#include "lfi/study/study.h"

#include "lfi/core/atomic_file.h"
#include "lfi/core/error.h"
#include "lfi/core/exr_io.h"
#include "lfi/core/output_folder.h"
#include "lfi/sim/render.h"

#include "study_internal.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>

namespace lfi::study {

namespace fs = std::filesystem;
using namespace detail;

namespace {

const std::vector<std::string> kSetups = {"parallel", "area", "schlieren", "inverse_schlieren", "display"};

}  // namespace

namespace detail {

QualitySettings settingsFor(Quality q) {
  switch (q) {
    case Quality::Quick:
      return {4, 8, 16};
    case Quality::Default:
      return {2, 32, 256};
    case Quality::High:
      return {1, 128, 1024};
  }
  return {2, 32, 256};
}

sim::TelecentricCamera binnedCamera(const Bench& bench, int binning) {
  sim::TelecentricCamera c = bench.telecentricCamera();
  c.width = std::max(8, c.width / binning);
  c.height = std::max(8, c.height / binning);
  c.pixelPitch_mm *= binning;
  return c;
}

sim::TelecentricCamera setupCamera(const Bench& bench, sim::TelecentricCamera camera, const std::string& setup) {
  if (setup == "schlieren") camera.knifeEdge = bench.schlieren.knifeEdge;
  return camera;
}

Illumination setupLight(const Bench& bench, const std::string& setup, std::shared_ptr<const LightField> shown) {
  Illumination light{setup, std::move(shown), bench.inverseSchlieren.lookup, 0, nullptr};
  if (setup == "display") light.panel = displayPanel(bench, bench.display.optics, *light.lightField);
  return light;
}

nlohmann::ordered_json cnrByDefect(const Evaluation& e) {
  nlohmann::ordered_json out = nlohmann::ordered_json::object();
  for (const auto& [scene, result] : e.scenes.items())
    for (const auto& [defect, cell] : result["defects"].items()) out[scene + "/" + defect] = cell["cnr"];
  return out;
}

}  // namespace detail

namespace {

nlohmann::ordered_json uniformityJson(const Uniformity& u) {
  return {{"lit_share", u.litShare}, {"cv", u.cv}};
}

nlohmann::ordered_json driveJson(const Bench& bench) {
  if (bench.inverseSchlieren.drive == Bench::InverseSchlieren::Drive::Captured) return {{"kind", "captured"}};
  return {{"kind", "binary"}, {"threshold", bench.inverseSchlieren.binaryThreshold}};
}

}  // namespace

Quality parseQuality(const std::string& name) {
  if (name == "quick") return Quality::Quick;
  if (name == "default") return Quality::Default;
  if (name == "high") return Quality::High;
  fail(Errc::InvalidArgument, "unknown quality '{}' (quick, default, high)", name);
}

Uniformity intactUniformity(const Bench& bench, const std::string& setup, Quality quality, std::uint64_t seed,
                            int threads) {
  if (std::find(kSetups.begin(), kSetups.end(), setup) == kSetups.end())
    fail(Errc::InvalidArgument, "unknown setup '{}' ({})", setup, fmt::join(kSetups, ", "));
  const QualitySettings q = settingsFor(quality);
  std::shared_ptr<const LightField> shown;
  if (setup == "inverse_schlieren" || setup == "display")
    shown = std::make_shared<const LightField>(
        bench.displayed(captureLightField(bench, bench.lightFieldGeometry(), q.captureSamples, seed, threads, {})));
  const Illumination light = setupLight(bench, setup, shown);
  std::vector<sim::Object> objects = partObjects(bench, sceneSpecs(bench).front());
  objects.push_back(backlight(bench, light));
  const sim::TelecentricCamera camera = setupCamera(bench, binnedCamera(bench, q.binning), setup);
  sim::RenderOptions ro;
  ro.samplesPerPixel = q.samplesPerPixel;
  ro.threads = threads;
  ro.seed = seed;
  return uniformityOf(sim::render(sim::Scene(std::move(objects)), camera, ro), bench, camera);
}

// Runs one step of the study; an lfi::Error from it says which step (a setup,
// a sweep point) and keeps its code.
template <typename Step>
auto namingTheStep(const std::string& step, Step run) {
  try {
    return run();
  } catch (const Error& e) {
    throw Error(e.code(), fmt::format("study, {}: {}", step, e.what()));
  }
}

namespace {

// The output folder before any work: an earlier study's files are refused
// (any of them: an interrupted run leaves some without study.json) or, with
// overwrite, removed first, so that a run that fails leaves no study.json of
// other inputs beside its own files; both folders must take files.
void prepareOutput(const fs::path& outDir, const StudyOptions& options) {
  const Overwrite overwrite = options.overwrite ? Overwrite::Allow : Overwrite::Refuse;
  refuseExisting({outDir / "study.json", outDir / "report.html", outDir / "lightfield.exr"}, overwrite, "study");
  if (std::error_code ec;
      !options.overwrite && fs::is_directory(outDir / "images", ec) && !fs::is_empty(outDir / "images", ec))
    fail(Errc::Exists, "'{}' already holds a study's images; use --force to replace them", outDir.string());
  requireOutputFolder(outDir, "study", "its results");
  requireOutputFolder(outDir / "images", "study", "its images");
  if (options.overwrite)
    for (const fs::path& file : {outDir / "study.json", outDir / "report.html"})
      if (std::error_code ec; !fs::remove(resolvedTarget(file), ec) && ec)
        fail(Errc::Io, "cannot remove the earlier study's '{}': {}", file.string(), ec.message());
}

// One study run, its steps in the order runStudy takes them.
class StudyRun {
 public:
  StudyRun(const Bench& bench, const fs::path& outDir, const StudyOptions& options)
      : bench_(bench),
        outDir_(outDir),
        options_(options),
        overwrite_(options.overwrite ? Overwrite::Allow : Overwrite::Refuse),
        sweep_(sweepVariants(
            bench, options.sweep ? *options.sweep
                                 : (options.quality == Quality::Quick ? std::vector<SweepPoint>{} : defaultSweep()))),
        limits_(options.limits ? *options.limits
                               : (options.quality == Quality::Quick ? std::vector<LimitPoint>{} : defaultLimits())),
        limitSpecs_(limitScenes(bench, limits_)),  // (checked before the work)
        q_(settingsFor(options.quality)),
        // The sweep runs the inverse schlieren setup only, at the quick camera
        // resolution, so that its many variants fit the time budget; its light
        // fields are captured with a quarter of the study's samples (which angular
        // pixels a capture finds lit decides which lens regions its display
        // lights: docs/study.md, "The reference's drive").
        sweepQuality_([&] {
          QualitySettings s = settingsFor(Quality::Quick);
          s.captureSamples = std::max(s.captureSamples, q_.captureSamples / 4);
          return s;
        }()),
        camera_(binnedCamera(bench, q_.binning)),
        sweepCamera_(binnedCamera(bench, sweepQuality_.binning)),  // (and the limits')
        specs_(sceneSpecs(bench)),
        // The display classes run with the sweep, at its camera.
        classCases_(sweep_.empty() ? std::vector<DisplayClass>{} : displayClasses(bench)),
        progress_(options, progressUnits()) {}

  nlohmann::ordered_json operator()() {
    prepareOutput(outDir_, options_);
    captureAndDescribe();
    evaluateSetups();
    // The setups' results are kept before the longer runs (written again after each); "complete" says which.
    writeResults(overwrite_, sweep_.empty() && limits_.empty());
    if (!limits_.empty()) {
      detectionLimits();
      writeResults(Overwrite::Allow, sweep_.empty());  // (this run's own, written above)
    }
    if (!sweep_.empty()) {
      displaySweep();
      displayClassesAtTheBenchsPanel();
      writeResults(Overwrite::Allow, true);
    }
    return study_;
  }

 private:
  static constexpr int kMostClassSamples = 1024;
  // Progress units: one full-quality render each; the sweep's renders are
  // smaller (quick camera) and count a tenth, in proportion to their samples.
  static constexpr double kSweepRender = 0.1;

  int classSamples(const DisplayClass& c) const {
    return std::min(kMostClassSamples, static_cast<int>(std::ceil(sweepQuality_.samplesPerPixel / c.openShare)));
  }
  double limitRender() const { return kSweepRender * q_.samplesPerPixel / sweepQuality_.samplesPerPixel; }

  double progressUnits() const {
    const double rendersPerSetup = static_cast<double>(specs_.size());
    double classUnits = 0;
    for (const DisplayClass& c : classCases_)
      classUnits += rendersPerSetup * kSweepRender * classSamples(c) / sweepQuality_.samplesPerPixel;
    return 4 + kSetups.size() * 2 * rendersPerSetup +
           kSetups.size() * 2 * static_cast<double>(limitSpecs_.size()) * limitRender() +
           static_cast<double>(sweep_.size()) * (0.25 + 2 * rendersPerSetup * kSweepRender) + classUnits;
  }

  sim::RenderOptions renderOptions(int samplesPerPixel) const {
    sim::RenderOptions ro;
    ro.samplesPerPixel = samplesPerPixel;
    ro.threads = options_.threads;
    return ro;
  }

  void writeResults(Overwrite mode, bool complete) {
    study_["complete"] = complete;
    writeReport(outDir_, mode, study_);
  }

  // The reference light field (kept as lightfield.exr), each setup's light, and what the study is.
  void captureAndDescribe() {
    const LightField captured = captureLightField(bench_, bench_.lightFieldGeometry(), q_.captureSamples, options_.seed,
                                                  options_.threads, progress_.step("light field capture", 4));
    writeLightFieldExr(outDir_ / "lightfield.exr", captured, overwrite_);
    lightField_ = std::make_shared<const LightField>(bench_.displayed(captured));
    for (const std::string& setup : kSetups) lights_.push_back(setupLight(bench_, setup, lightField_));

    study_["format"] = "lfi-study";
    study_["version"] = 1;
    study_["units"] = "lengths mm, angles rad; images and noise in the camera's digital numbers (DN)";
    study_["setups"] = kSetups;
    study_["quality"] = options_.quality == Quality::Quick  ? "quick"
                        : options_.quality == Quality::High ? "high"
                                                            : "default";
    study_["provenance"] = {{"bench", bench_.source}, {"seed", options_.seed}};  // (results do not depend on threads)
    study_["camera"] = {{"width", camera_.width},
                        {"height", camera_.height},
                        {"object_pixel_mm", camera_.objectPixel_mm()},
                        {"acceptance_half_angle_rad", camera_.acceptanceHalfAngle_rad()},
                        {"samples_per_pixel", q_.samplesPerPixel},
                        {"bit_depth", bench_.sensorModel().bitDepth}};
    study_["light_field"] = {{"spatial", lightField_->geometry().spatialX},
                             {"angular", lightField_->geometry().angular},
                             {"pixel_pitch_mm", lightField_->geometry().pixelPitch_mm},
                             {"distance_mm", lightField_->geometry().distance_mm},
                             {"capture_samples_per_pixel", q_.captureSamples},
                             {"capture_half_angle_rad", bench_.inverseSchlieren.captureHalfAngle_rad},
                             {"drive", driveJson(bench_)}};
    study_["criterion"] = criterionJson();
    blind_ = blindSettings(bench_, camera_);
    study_["blind_detector"] = blindDetectorJson(blind_, camera_);
  }

  // Every scene in every setup at the study's quality, images kept.
  void evaluateSetups() {
    const sim::RenderOptions ro = renderOptions(q_.samplesPerPixel);
    const fs::path imagesDir = outDir_ / "images";
    truth_ = traceGroundTruth(bench_, specs_, camera_);
    for (size_t si = 0; si < kSetups.size(); ++si) {
      const Evaluation e = namingTheStep(fmt::format("setup '{}' of '{}'", kSetups[si], bench_.source), [&] {
        return evaluate(bench_, lights_[si], specs_, truth_, setupCamera(bench_, camera_, kSetups[si]),
                        bench_.sensorModel(), ro, options_.seed * 1000 + si * 100, progress_, 1.0, true, &imagesDir,
                        overwrite_, &blind_);
      });
      study_["noise"][kSetups[si]] = e.noise;
      study_["intact_uniformity"][kSetups[si]] = uniformityJson(e.intactUniformity);
      for (const auto& [scene, result] : e.scenes.items()) {
        auto& out = study_["scenes"][scene];
        if (!out.contains("defects")) out["defects"] = nlohmann::ordered_json::object();
        for (const auto& [defect, cell] : result["defects"].items()) out["defects"][defect][kSetups[si]] = cell;
        out["false_positives"][kSetups[si]] = result["false_positives"];
        out["secondary_regions"][kSetups[si]] = result["secondary_regions"];
        out["blind"][kSetups[si]] = result["blind"];
      }
    }
  }

  // The detection limits: each kind of defect at a ladder of sizes in every
  // setup, at the sweep's camera with the study's samples, every scene
  // rendered twice (the Monte Carlo noise out of the CNR).
  void detectionLimits() {
    const GroundTruth limitTruth = traceGroundTruth(bench_, limitSpecs_, sweepCamera_);
    const sim::RenderOptions lro = renderOptions(q_.samplesPerPixel);
    std::vector<std::vector<double>> cnr(limits_.size(), std::vector<double>(kSetups.size()));
    for (size_t si = 0; si < kSetups.size(); ++si) {
      const Evaluation e = namingTheStep(fmt::format("detection limits, setup '{}'", kSetups[si]), [&] {
        return evaluate(bench_, lights_[si], limitSpecs_, limitTruth, setupCamera(bench_, sweepCamera_, kSetups[si]),
                        bench_.sensorModel(), lro, options_.seed * 1000 + 500 + si, progress_, limitRender(), true,
                        nullptr, overwrite_);
      });
      for (size_t i = 0; i < limits_.size(); ++i)
        cnr[i][si] = e.scenes[limitSpecs_[i + 1].name]["defects"].begin().value()["cnr"].get<double>();
    }
    auto& out = study_["detection_limits"];
    out["camera"] = {{"width", sweepCamera_.width},
                     {"height", sweepCamera_.height},
                     {"object_pixel_mm", sweepCamera_.objectPixel_mm()},
                     {"samples_per_pixel", lro.samplesPerPixel},
                     {"renderings", 2}};
    out["camera_noise"] = {{"full_well_e", bench_.camera.fullWell_e},
                           {"read_noise_e", bench_.camera.readNoise_e},
                           {"bit_depth", bench_.camera.bitDepth},
                           {"exposure_fill", bench_.camera.exposureFill},
                           {"frames_averaged", 1}};
    out["kinds"] = limitCurves(limits_, kSetups, cnr);
  }

  // How good must the display be? Each variant captures its own light field
  // (only as large as the lens's footprint on the display plane needs) and
  // renders the inverse schlieren setup with both lookups.
  void displaySweep() {
    // The quick quality's camera is the sweep's: its ground truth is traced already.
    sweepTruth_ = sweepQuality_.binning == q_.binning ? truth_ : traceGroundTruth(bench_, specs_, sweepCamera_);
    const sim::RenderOptions sro = renderOptions(sweepQuality_.samplesPerPixel);
    const LightFieldGeometry reference = bench_.lightFieldGeometry();
    auto& out = study_["sweep"];
    out["setup"] = "inverse_schlieren";
    out["camera"] = {
        {"width", sweepCamera_.width}, {"height", sweepCamera_.height}, {"samples_per_pixel", sro.samplesPerPixel}};
    out["capture_samples_per_pixel"] = sweepQuality_.captureSamples;
    out["reference"] = {{"angular", reference.angular},
                        {"element_mm", reference.elementPitch_mm()},
                        {"distance_mm", reference.distance_mm}};
    for (const auto& [point, g, displayError] : sweep_) {
      const std::string label = fmt::format("sweep {}={}", point.series, point.value);
      const auto lf = std::make_shared<const LightField>(
          bench_.displayed(captureLightField(bench_, g, sweepQuality_.captureSamples, options_.seed, options_.threads,
                                             progress_.step(label + ": capture", 0.25))));
      nlohmann::ordered_json entry = {{"series", point.series}, {"value", point.value},
                                      {"angular", g.angular},   {"element_mm", g.elementPitch_mm()},
                                      {"spatial", g.spatialX},  {"display_error_mm", displayError}};
      const std::vector<std::pair<std::string, LightFieldLookup>> lookups = {
          {"nearest", LightFieldLookup::Nearest}, {"interpolated", LightFieldLookup::Interpolated}};
      for (const auto& [name, lookup] : lookups) {
        // (the bindings by name: clang 14, the fuzz build's compiler, captures no structured binding)
        const Evaluation e =
            namingTheStep(fmt::format("{}, {} lookup", label, name), [&, lookup = lookup, displayError = displayError] {
              return evaluate(bench_, Illumination{"inverse_schlieren", lf, lookup, displayError}, specs_, sweepTruth_,
                              sweepCamera_, bench_.sensorModel(), sro, options_.seed * 1000 + 777, progress_,
                              kSweepRender, false, nullptr, overwrite_);
            });
        entry["cnr"][name] = cnrByDefect(e);
        entry["false_positives"][name] = e.scenes["intact"]["false_positives"];
        entry["intact_lit_fraction"][name] = e.intactLitFraction;
      }
      out["points"].push_back(entry);
    }
    study_["sweep"]["answers"] = sweepAnswers(study_["sweep"]);
  }

  // The display classes at the bench's panel, each showing the bench's light
  // field, at the sweep's camera; a class that passes a share s of the
  // display plane gets 1/s of the samples, so that as many reach the panel.
  // (A new member may move the others: no reference into study is kept across it.)
  void displayClassesAtTheBenchsPanel() {
    const sim::RenderOptions sro = renderOptions(sweepQuality_.samplesPerPixel);
    auto& classes = study_["display_classes"];
    classes["camera"] = {{"width", sweepCamera_.width}, {"height", sweepCamera_.height}};
    for (const DisplayClass& c : classCases_) {
      sim::RenderOptions cro = sro;
      cro.samplesPerPixel = classSamples(c);
      const Illumination light{"display", lightField_, bench_.inverseSchlieren.lookup, 0,
                               displayPanel(bench_, c.optics, *lightField_)};
      const Evaluation e = namingTheStep(fmt::format("display class {}", c.name), [&] {
        return evaluate(bench_, light, specs_, sweepTruth_, sweepCamera_, bench_.sensorModel(), cro,
                        options_.seed * 1000 + 888, progress_, kSweepRender * cro.samplesPerPixel / sro.samplesPerPixel,
                        false, nullptr, overwrite_);
      });
      nlohmann::ordered_json entry = {{"class", c.name},
                                      {"open_share", c.openShare},
                                      {"samples_per_pixel", cro.samplesPerPixel},
                                      {"intact_lit_fraction", e.intactLitFraction},
                                      {"intact_uniformity", uniformityJson(e.intactUniformity)},
                                      {"false_positives", e.scenes["intact"]["false_positives"]}};
      entry["cnr"] = cnrByDefect(e);
      classes["classes"].push_back(entry);
    }
  }

  const Bench& bench_;
  const fs::path outDir_;
  const StudyOptions& options_;
  const Overwrite overwrite_;
  const std::vector<SweepVariant> sweep_;
  const std::vector<LimitPoint> limits_;
  const std::vector<SceneSpec> limitSpecs_;
  const QualitySettings q_, sweepQuality_;
  const sim::TelecentricCamera camera_, sweepCamera_;
  const std::vector<SceneSpec> specs_;
  const std::vector<DisplayClass> classCases_;
  Progress progress_;
  std::shared_ptr<const LightField> lightField_;
  std::vector<Illumination> lights_;  // per setup (the display's panel encoded once)
  DetectionSettings blind_;
  GroundTruth truth_, sweepTruth_;
  nlohmann::ordered_json study_;
};

}  // namespace

nlohmann::ordered_json runStudy(const Bench& bench, const fs::path& outDir, const StudyOptions& options) {
  return StudyRun(bench, outDir, options)();
}

}  // namespace lfi::study
