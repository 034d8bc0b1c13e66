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

struct QualitySettings {
  int binning;          // extra binning of the bench camera (fewer, larger pixels)
  int samplesPerPixel;  // camera images
  int captureSamples;   // light field capture, per sensor pixel
};

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

// The bench's camera binned a further `binning` times (fewer, larger pixels).
sim::TelecentricCamera binnedCamera(const Bench& bench, int binning) {
  sim::TelecentricCamera c = bench.telecentricCamera();
  c.width = std::max(8, c.width / binning);
  c.height = std::max(8, c.height / binning);
  c.pixelPitch_mm *= binning;
  return c;
}

// The camera of one setup: conventional schlieren's has the knife edge in its stop.
sim::TelecentricCamera setupCamera(const Bench& bench, sim::TelecentricCamera camera, const std::string& setup) {
  if (setup == "schlieren") camera.knifeEdge = bench.schlieren.knifeEdge;
  return camera;
}

// The light of one setup; the light field setups show `shown` (the bench's drive).
Illumination setupLight(const Bench& bench, const std::string& setup, std::shared_ptr<const LightField> shown) {
  Illumination light{setup, std::move(shown), bench.inverseSchlieren.lookup, 0, nullptr};
  if (setup == "display") light.panel = displayPanel(bench, bench.display.optics, *light.lightField);
  return light;
}

nlohmann::ordered_json uniformityJson(const Uniformity& u) {
  return {{"lit_share", u.litShare}, {"cv", u.cv}};
}

// Every defect's CNR in one evaluation, keyed "scene/defect".
nlohmann::ordered_json cnrByDefect(const Evaluation& e) {
  nlohmann::ordered_json out = nlohmann::ordered_json::object();
  for (const auto& [scene, result] : e.scenes.items())
    for (const auto& [defect, cell] : result["defects"].items()) out[scene + "/" + defect] = cell["cnr"];
  return out;
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

nlohmann::ordered_json runStudy(const Bench& bench, const fs::path& outDir, const StudyOptions& options) {
  const Overwrite overwrite = options.overwrite ? Overwrite::Allow : Overwrite::Refuse;
  const std::vector<SweepVariant> sweep = sweepVariants(
      bench, options.sweep ? *options.sweep
                           : (options.quality == Quality::Quick ? std::vector<SweepPoint>{} : defaultSweep()));
  const std::vector<LimitPoint> limits =
      options.limits ? *options.limits
                     : (options.quality == Quality::Quick ? std::vector<LimitPoint>{} : defaultLimits());
  const std::vector<SceneSpec> limitSpecs = limitScenes(bench, limits);  // (checked before the work)
  // Any of the study's files (an interrupted run leaves some without study.json) stops it before the work.
  refuseExisting({outDir / "study.json", outDir / "report.html", outDir / "lightfield.exr"}, overwrite, "study");
  if (std::error_code ec;
      !options.overwrite && fs::is_directory(outDir / "images", ec) && !fs::is_empty(outDir / "images", ec))
    fail(Errc::Exists, "'{}' already holds a study's images; use --force to replace them", outDir.string());
  // Both folders must take files before the work, not after it (they may have been there, read-only).
  requireOutputFolder(outDir, "study", "its results");
  requireOutputFolder(outDir / "images", "study", "its images");
  // Replacing an earlier study: its results go first, so that a run that fails
  // leaves no study.json of other inputs beside this run's files.
  if (options.overwrite)
    for (const fs::path& file : {outDir / "study.json", outDir / "report.html"})
      if (std::error_code ec; !fs::remove(resolvedTarget(file), ec) && ec)
        fail(Errc::Io, "cannot remove the earlier study's '{}': {}", file.string(), ec.message());

  const QualitySettings q = settingsFor(options.quality);
  const sim::TelecentricCamera camera = binnedCamera(bench, q.binning);
  const auto specs = sceneSpecs(bench);

  // The sweep runs the inverse schlieren setup only, at the quick camera
  // resolution, so that its many variants fit the time budget; its light
  // fields are captured with a quarter of the study's samples (which angular
  // pixels a capture finds lit decides which lens regions its display
  // lights: docs/study.md, "The reference's drive").
  const QualitySettings sweepQuality = [&] {
    QualitySettings s = settingsFor(Quality::Quick);
    s.captureSamples = std::max(s.captureSamples, q.captureSamples / 4);
    return s;
  }();
  const double rendersPerSetup = static_cast<double>(specs.size());
  // The display classes run with the sweep, at its camera.
  const std::vector<DisplayClass> classCases = sweep.empty() ? std::vector<DisplayClass>{} : displayClasses(bench);
  constexpr int kMostClassSamples = 1024;
  auto classSamples = [&](const DisplayClass& c) {
    return std::min(kMostClassSamples, static_cast<int>(std::ceil(sweepQuality.samplesPerPixel / c.openShare)));
  };
  // Progress units: one full-quality render each; the sweep's renders are
  // smaller (quick camera) and count a tenth, in proportion to their samples.
  constexpr double kSweepRender = 0.1;
  const double limitRender = kSweepRender * q.samplesPerPixel / sweepQuality.samplesPerPixel;
  double classUnits = 0;
  for (const DisplayClass& c : classCases)
    classUnits += rendersPerSetup * kSweepRender * classSamples(c) / sweepQuality.samplesPerPixel;
  Progress progress(options, 4 + kSetups.size() * 2 * rendersPerSetup +
                                 kSetups.size() * 2 * static_cast<double>(limitSpecs.size()) * limitRender +
                                 static_cast<double>(sweep.size()) * (0.25 + 2 * rendersPerSetup * kSweepRender) +
                                 classUnits);

  const LightField captured = captureLightField(bench, bench.lightFieldGeometry(), q.captureSamples, options.seed,
                                                options.threads, progress.step("light field capture", 4));
  writeLightFieldExr(outDir / "lightfield.exr", captured, overwrite);
  const auto lightField = std::make_shared<const LightField>(bench.displayed(captured));
  std::vector<Illumination> lights;  // per setup (the display's panel encoded once)
  for (const std::string& setup : kSetups) lights.push_back(setupLight(bench, setup, lightField));

  nlohmann::ordered_json study;
  study["format"] = "lfi-study";
  study["version"] = 1;
  study["units"] = "lengths mm, angles rad; images and noise in the camera's digital numbers (DN)";
  study["setups"] = kSetups;
  study["quality"] = options.quality == Quality::Quick  ? "quick"
                     : options.quality == Quality::High ? "high"
                                                        : "default";
  study["provenance"] = {{"bench", bench.source}, {"seed", options.seed}};  // (results do not depend on threads)
  study["camera"] = {{"width", camera.width},
                     {"height", camera.height},
                     {"object_pixel_mm", camera.objectPixel_mm()},
                     {"acceptance_half_angle_rad", camera.acceptanceHalfAngle_rad()},
                     {"samples_per_pixel", q.samplesPerPixel},
                     {"bit_depth", bench.sensorModel().bitDepth}};
  study["light_field"] = {{"spatial", lightField->geometry().spatialX},
                          {"angular", lightField->geometry().angular},
                          {"pixel_pitch_mm", lightField->geometry().pixelPitch_mm},
                          {"distance_mm", lightField->geometry().distance_mm},
                          {"capture_samples_per_pixel", q.captureSamples},
                          {"capture_half_angle_rad", bench.inverseSchlieren.captureHalfAngle_rad},
                          {"drive", driveJson(bench)}};
  study["criterion"] = criterionJson();
  const DetectionSettings blind = blindSettings(bench, camera);
  study["blind_detector"] = blindDetectorJson(blind, camera);

  sim::RenderOptions ro;
  ro.samplesPerPixel = q.samplesPerPixel;
  ro.threads = options.threads;
  const fs::path imagesDir = outDir / "images";
  const GroundTruth truth = traceGroundTruth(bench, specs, camera);
  for (size_t si = 0; si < kSetups.size(); ++si) {
    const Evaluation e = namingTheStep(fmt::format("setup '{}' of '{}'", kSetups[si], bench.source), [&] {
      return evaluate(bench, lights[si], specs, truth, setupCamera(bench, camera, kSetups[si]), bench.sensorModel(), ro,
                      options.seed * 1000 + si * 100, progress, 1.0, true, &imagesDir, overwrite, &blind);
    });
    study["noise"][kSetups[si]] = e.noise;
    study["intact_uniformity"][kSetups[si]] = uniformityJson(e.intactUniformity);
    for (const auto& [scene, result] : e.scenes.items()) {
      auto& out = study["scenes"][scene];
      if (!out.contains("defects")) out["defects"] = nlohmann::ordered_json::object();
      for (const auto& [defect, cell] : result["defects"].items()) out["defects"][defect][kSetups[si]] = cell;
      out["false_positives"][kSetups[si]] = result["false_positives"];
      out["secondary_regions"][kSetups[si]] = result["secondary_regions"];
      out["blind"][kSetups[si]] = result["blind"];
    }
  }

  // The setups' results are kept before the longer runs (written again after each); "complete" says which.
  auto writeResults = [&](Overwrite mode, bool complete) {
    study["complete"] = complete;
    writeReport(outDir, mode, study);
  };
  writeResults(overwrite, sweep.empty() && limits.empty());
  const sim::TelecentricCamera sweepCamera = binnedCamera(bench, sweepQuality.binning);  // (and the limits')
  if (!limits.empty()) {
    // The detection limits: each kind of defect at a ladder of sizes in every
    // setup, at the sweep's camera with the study's samples, every scene
    // rendered twice (the Monte Carlo noise out of the CNR).
    const GroundTruth limitTruth = traceGroundTruth(bench, limitSpecs, sweepCamera);
    sim::RenderOptions lro;
    lro.samplesPerPixel = q.samplesPerPixel;
    lro.threads = options.threads;
    std::vector<std::vector<double>> cnr(limits.size(), std::vector<double>(kSetups.size()));
    for (size_t si = 0; si < kSetups.size(); ++si) {
      const Evaluation e = namingTheStep(fmt::format("detection limits, setup '{}'", kSetups[si]), [&] {
        return evaluate(bench, lights[si], limitSpecs, limitTruth, setupCamera(bench, sweepCamera, kSetups[si]),
                        bench.sensorModel(), lro, options.seed * 1000 + 500 + si, progress, limitRender, true, nullptr,
                        overwrite);
      });
      for (size_t i = 0; i < limits.size(); ++i)
        cnr[i][si] = e.scenes[limitSpecs[i + 1].name]["defects"].begin().value()["cnr"].get<double>();
    }
    auto& out = study["detection_limits"];
    out["camera"] = {{"width", sweepCamera.width},
                     {"height", sweepCamera.height},
                     {"object_pixel_mm", sweepCamera.objectPixel_mm()},
                     {"samples_per_pixel", lro.samplesPerPixel},
                     {"renderings", 2}};
    out["camera_noise"] = {{"full_well_e", bench.camera.fullWell_e},
                           {"read_noise_e", bench.camera.readNoise_e},
                           {"bit_depth", bench.camera.bitDepth},
                           {"exposure_fill", bench.camera.exposureFill},
                           {"frames_averaged", 1}};
    out["kinds"] = limitCurves(limits, kSetups, cnr);
    writeResults(Overwrite::Allow, sweep.empty());  // (this run's own, written above)
  }
  if (!sweep.empty()) {
    // How good must the display be? Each variant captures its own light field
    // (only as large as the lens's footprint on the display plane needs) and
    // renders the inverse schlieren setup with both lookups.
    // The quick quality's camera is the sweep's: its ground truth is traced already.
    const GroundTruth sweepTruth =
        sweepQuality.binning == q.binning ? truth : traceGroundTruth(bench, specs, sweepCamera);
    sim::RenderOptions sro;
    sro.samplesPerPixel = sweepQuality.samplesPerPixel;
    sro.threads = options.threads;
    const LightFieldGeometry reference = bench.lightFieldGeometry();
    auto& out = study["sweep"];
    out["setup"] = "inverse_schlieren";
    out["camera"] = {
        {"width", sweepCamera.width}, {"height", sweepCamera.height}, {"samples_per_pixel", sro.samplesPerPixel}};
    out["capture_samples_per_pixel"] = sweepQuality.captureSamples;
    out["reference"] = {{"angular", reference.angular},
                        {"element_mm", reference.elementPitch_mm()},
                        {"distance_mm", reference.distance_mm}};
    for (const auto& [point, g, displayError] : sweep) {
      const std::string label = fmt::format("sweep {}={}", point.series, point.value);
      const auto lf = std::make_shared<const LightField>(
          bench.displayed(captureLightField(bench, g, sweepQuality.captureSamples, options.seed, options.threads,
                                            progress.step(label + ": capture", 0.25))));
      nlohmann::ordered_json entry = {{"series", point.series}, {"value", point.value},
                                      {"angular", g.angular},   {"element_mm", g.elementPitch_mm()},
                                      {"spatial", g.spatialX},  {"display_error_mm", displayError}};
      const std::vector<std::pair<std::string, LightFieldLookup>> lookups = {
          {"nearest", LightFieldLookup::Nearest}, {"interpolated", LightFieldLookup::Interpolated}};
      for (const auto& [name, lookup] : lookups) {
        const Evaluation e = namingTheStep(fmt::format("{}, {} lookup", label, name), [&] {
          return evaluate(bench, Illumination{"inverse_schlieren", lf, lookup, displayError}, specs, sweepTruth,
                          sweepCamera, bench.sensorModel(), sro, options.seed * 1000 + 777, progress, kSweepRender,
                          false, nullptr, overwrite);
        });
        entry["cnr"][name] = cnrByDefect(e);
        entry["false_positives"][name] = e.scenes["intact"]["false_positives"];
        entry["intact_lit_fraction"][name] = e.intactLitFraction;
      }
      out["points"].push_back(entry);
    }
    study["sweep"]["answers"] = sweepAnswers(study["sweep"]);

    // The display classes at the bench's panel, each showing the bench's light
    // field, at the sweep's camera; a class that passes a share s of the
    // display plane gets 1/s of the samples, so that as many reach the panel.
    // (A new member may move the others: no reference into study is kept across it.)
    auto& classes = study["display_classes"];
    classes["camera"] = {{"width", sweepCamera.width}, {"height", sweepCamera.height}};
    for (const DisplayClass& c : classCases) {
      sim::RenderOptions cro = sro;
      cro.samplesPerPixel = classSamples(c);
      const Illumination light{"display", lightField, bench.inverseSchlieren.lookup, 0,
                               displayPanel(bench, c.optics, *lightField)};
      const Evaluation e = namingTheStep(fmt::format("display class {}", c.name), [&] {
        return evaluate(bench, light, specs, sweepTruth, sweepCamera, bench.sensorModel(), cro,
                        options.seed * 1000 + 888, progress, kSweepRender * cro.samplesPerPixel / sro.samplesPerPixel,
                        false, nullptr, overwrite);
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
    writeResults(Overwrite::Allow, true);  // (this run's own, written above)
  }
  return study;
}

}  // namespace lfi::study
