// SPDX-License-Identifier: Apache-2.0
// A sweep's points computed (grid_sweep.h): the whole grid into a sweep's
// folder, or one shard's points into a shard's folder.

#include "lfi/study/grid_sweep.h"

#include "study_internal.h"
#include "sweep_results.h"

#include "lfi/core/error.h"
#include "lfi/core/output_folder.h"

#include <fmt/format.h>

#include <charconv>

namespace lfi::study {

namespace fs = std::filesystem;
using namespace detail;

namespace {

// The study's seeds of its setups (study.cpp: seed * 1000 + 100 × the setup's place among the five).
std::uint64_t setupSeed(std::uint64_t seed, const std::string& setup) {
  return seed * 1000 + (setup == "inverse_schlieren" ? 300 : 400);
}

// One point: the bench at its numbers, its light field captured, each scene rendered in each setup and judged.
nlohmann::ordered_json computePoint(const SweepFile& sweep, std::size_t index, const fs::path& imagesRoot, int threads,
                                    Overwrite overwrite, Progress& progress) {
  const Bench bench = sweepBench(sweep, index);
  const QualitySettings q = settingsFor(sweep.quality);
  const sim::TelecentricCamera camera = binnedCamera(bench, q.binning);
  const std::vector<SceneSpec> specs = sceneSpecs(bench);
  const std::string label = fmt::format("sweep point {}", index);
  const LightField captured = captureLightField(bench, bench.lightFieldGeometry(), q.captureSamples, sweep.seed,
                                                threads, progress.step(label + ": capture", 0.25));
  const auto shown = std::make_shared<const LightField>(bench.displayed(captured));
  const GroundTruth truth = traceGroundTruth(bench, specs, camera);
  const fs::path imagesDir = imagesRoot / pointFolder(index);
  requireOutputFolder(imagesDir, "sweep", "a point's images");

  nlohmann::ordered_json entry;
  entry["index"] = index;
  for (const ConfigTable::Override& v : sweep.point(index)) entry["values"][v.key] = v.value;
  entry["camera"] = {{"width", camera.width}, {"height", camera.height}, {"object_pixel_mm", camera.objectPixel_mm()}};
  const LightFieldGeometry& g = captured.geometry();
  entry["light_field"] = {{"spatial", g.spatialX},
                          {"angular", g.angular},
                          {"pixel_pitch_mm", g.pixelPitch_mm},
                          {"element_mm", g.elementPitch_mm()},
                          {"distance_mm", g.distance_mm}};
  sim::RenderOptions ro;
  ro.samplesPerPixel = q.samplesPerPixel;
  ro.threads = threads;
  for (const std::string& setup : sweep.setups) {
    Evaluation e;
    try {
      e = evaluate(bench, setupLight(bench, setup, shown), specs, truth, setupCamera(bench, camera, setup),
                   bench.sensorModel(), ro, setupSeed(sweep.seed, setup), progress, 1.0, false, &imagesDir, overwrite);
    } catch (const Error& error) {
      throw Error(error.code(), fmt::format("{}, setup '{}': {}", label, setup, error.what()));
    }
    const nlohmann::ordered_json cnr = cnrByDefect(e);
    nlohmann::ordered_json verdicts = nlohmann::ordered_json::object();
    for (const auto& [defect, value] : cnr.items())
      verdicts[defect] = value.is_number() ? verdictOf(value.get<double>()) : "missed";
    entry["setups"][setup] = {{"cnr", cnr},
                              {"verdicts", verdicts},
                              {"false_positives", e.scenes["intact"]["false_positives"]},
                              {"intact_lit_fraction", e.intactLitFraction}};
  }
  return entry;
}

// Refuses a folder that holds a run's files, unless asked to replace them, and makes it.
void prepareFolder(const fs::path& out, bool overwrite) {
  refuseExisting({out / "study.json", out / "report.html", out / "shard.json"},
                 overwrite ? Overwrite::Allow : Overwrite::Refuse, "sweep");
  if (std::error_code ec; !overwrite && fs::is_directory(out / "images", ec) && !fs::is_empty(out / "images", ec))
    fail(Errc::Exists, "'{}' already holds a sweep's images; use --force to replace them", out.string());
  requireOutputFolder(out / "images", "sweep", "its images");
}

}  // namespace

SweepShard parseShard(const std::string& text) {
  SweepShard s;
  const auto slash = text.find('/');
  const auto number = [&](std::string_view part, int& value) {
    const auto [end, error] = std::from_chars(part.data(), part.data() + part.size(), value);
    return error == std::errc() && end == part.data() + part.size();
  };
  if (slash == std::string::npos || !number(std::string_view(text).substr(0, slash), s.index) ||
      !number(std::string_view(text).substr(slash + 1), s.count) || s.count < 1 || s.count > 100000 || s.index < 1 ||
      s.index > s.count)
    fail(Errc::InvalidArgument, "shard '{}' is not i/N with 1 <= i <= N <= 100000", text);
  return s;
}

std::vector<std::size_t> shardPoints(std::size_t points, const SweepShard& shard) {
  std::vector<std::size_t> mine;
  for (std::size_t k = static_cast<std::size_t>(shard.index - 1); k < points;
       k += static_cast<std::size_t>(shard.count))
    mine.push_back(k);
  return mine;
}

const char* lfiVersion() {
  return LFI_VERSION;
}

nlohmann::ordered_json runSweep(const SweepFile& sweep, const fs::path& out, const SweepOptions& options) {
  const SweepShard shard = options.shard.value_or(SweepShard{});
  const std::vector<std::size_t> points = shardPoints(sweep.pointCount(), shard);
  prepareFolder(out, options.overwrite);
  const Overwrite overwrite = options.overwrite ? Overwrite::Allow : Overwrite::Refuse;
  StudyOptions progressOptions;
  progressOptions.progress = options.progress;
  const double scenes = static_cast<double>(sceneSpecs(sweepBench(sweep, 0)).size());
  Progress progress(progressOptions,
                    static_cast<double>(points.size()) * (0.25 + scenes * static_cast<double>(sweep.setups.size())));
  nlohmann::ordered_json entries = nlohmann::ordered_json::array();
  for (const std::size_t k : points)
    entries.push_back(computePoint(sweep, k, out / "images", options.threads, overwrite, progress));
  const nlohmann::ordered_json header = sweepHeader(sweep);
  if (!options.shard) {
    const nlohmann::ordered_json results = sweepResults(header, entries);
    writeSweepResults(out, overwrite, results);
    return results;
  }
  const nlohmann::ordered_json record = shardRecord(header, shard, sweep.pointCount(), entries);
  writeShardRecord(out, overwrite, record);
  return record;
}

}  // namespace lfi::study
