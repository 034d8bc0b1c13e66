// SPDX-License-Identifier: Apache-2.0
// The inspection loop as a bench user runs it, on the simulated bench
// (data/benches/inspection_sim.toml): `lfi capture` takes the reference
// package, `lfi inspect` finds every defect of the study blind and places it
// on the part, the intact lens passes part after part with fresh camera noise,
// and bad bench files, references and arguments get errors that name them.

#include "lfi_process.h"
#include "record_defects.h"
#include "study_parts.h"
#include "test_folder.h"
#include "text_edit.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

namespace {

namespace fs = std::filesystem;
using lfi::testing_support::centroidsOf;
using lfi::testing_support::misplacedDefects;
using lfi::testing_support::readText;
using lfi::testing_support::replaceAll;
using lfi::testing_support::replaceOnce;
using lfi::testing_support::runLfi;
using lfi::testing_support::shellQuoted;

// The study's lens (data/scenes/inspection_bench.toml) as the bench sees it (study_parts.h).
constexpr double kPixel_mm = lfi::testing_support::kInspectionPixel_mm;
using lfi::testing_support::StudyPart;
using lfi::testing_support::studyPartScene;

class LfiInspectionCli : public testing::Test {
 protected:
  // The shipped bench file with its folders in the test's own.
  void SetUp() override {
    std::string text = readText(source_ / "data" / "benches" / benchName());
    replaceAll(text, "sim:../scenes/", "sim:" + (source_ / "data" / "scenes").string() + "/");
    replaceAll(text, "../../out/bench/", folder_.path().string() + "/");
    for (const std::string folder : {"reference", "inspections"})  // (one name whatever the bench calls them)
      if (const auto at = text.find("/coded_" + folder + "\""); at != std::string::npos)
        text.replace(at, folder.size() + 7, "/" + folder);
    benchText_ = text;
    bench_ = folder_.write("bench.toml", text);
  }

  // The shipped bench this test runs on: its reference from the simulated light field sensor.
  virtual std::string benchName() const { return "inspection_sim.toml"; }
  std::string bench() const { return shellQuoted(bench_.string()); }
  fs::path reference() const { return folder_ / "reference"; }

  void capture() {
    const auto r = runLfi("-q capture " + bench());
    ASSERT_EQ(r.status, 0) << r.output;
  }

  // The bench's scene with `edits` applied and `extra` appended (after the lens, the file's last object).
  fs::path partScene(const std::string& name, const std::vector<std::pair<std::string, std::string>>& edits,
                     const std::string& extra) {
    std::string text = readText(source_ / "data" / "scenes" / "inspection_bench.toml");
    for (const auto& [from, to] : edits) replaceAll(text, from, to);
    return folder_.write(name + ".toml", text + "\n" + extra + "\n");
  }

  // `lfi inspect --json` of a part: the exit status and the record.
  std::pair<int, nlohmann::json> inspect(const fs::path& part) {
    const auto r = runLfi("-q inspect " + bench() + " --json --part " + shellQuoted(part.string()), false);
    nlohmann::json record = nlohmann::json::parse(r.output, nullptr, false);
    EXPECT_FALSE(record.is_discarded()) << r.output;
    return {r.status, record};
  }

  const fs::path source_ = LFI_SOURCE_DIR;
  lfi::testing_support::TestFolder folder_{"lfi-inspection-cli"};
  std::string benchText_;
  fs::path bench_;
};

// The same on each shipped simulated bench: its reference from the simulated light field sensor (sim:) or
// measured through the display and camera (coded:).
class LfiInspectionCliEachCapture : public LfiInspectionCli, public testing::WithParamInterface<std::string> {
 protected:
  std::string benchName() const override { return GetParam(); }
};

INSTANTIATE_TEST_SUITE_P(Benches, LfiInspectionCliEachCapture,
                         testing::Values("inspection_sim.toml", "inspection_coded_sim.toml"),
                         [](const testing::TestParamInfo<std::string>& param) {
                           return param.param == "inspection_sim.toml" ? std::string("Sim") : std::string("Coded");
                         });

double distance(const nlohmann::json& defect, double x, double y) {
  return std::hypot(defect["centroid_mm"][0].get<double>() - x, defect["centroid_mm"][1].get<double>() - y);
}

TEST_P(LfiInspectionCliEachCapture, TheIntactLensPassesAHundredTimesInARowWithFreshNoise) {
  capture();
  const fs::path run = folder_ / "run";
  const auto r = runLfi("-q run " + bench() + " --parts 100 --out " + shellQuoted(run.string()));
  ASSERT_EQ(r.status, 0) << r.output;
  std::ifstream records(run / "records.jsonl");
  int parts = 0;
  std::vector<std::uint64_t> numbers;
  for (std::string line; std::getline(records, line); ++parts) {
    const auto j = nlohmann::json::parse(line);
    EXPECT_EQ(j["status"], "inspected");
    EXPECT_EQ(j["verdict"], "pass") << line;
    EXPECT_TRUE(j["defects"].empty()) << line;
    numbers.push_back(j["part"]);
  }
  EXPECT_EQ(parts, 100);
  for (size_t i = 0; i < numbers.size(); ++i) EXPECT_EQ(numbers[i], i + 1);
  const std::string summary = readText(run / "summary.html");
  EXPECT_NE(summary.find("<td>100</td><td>100</td><td>0</td><td>0</td><td>100.0 %</td>"), std::string::npos);
  EXPECT_EQ(summary.find("http-equiv=\"refresh\""), std::string::npos) << "a finished run's page stops reloading";
  EXPECT_FALSE(fs::exists(run / "images" / "part-000001.exr")) << "save_images = \"failed\" keeps no passed part";
}

// The same run at b = 3 raises false alarms, and each frame's noise is its own. The finder smooths with a
// Gaussian of 0.5 px (smallest_defect_mm / 4 in 0.5 mm pixels), whose taps reach 2 px: smoothed pixels 5 px
// apart share no camera pixel and no model pixel, so their noise is independent. The 49 such pixels within
// 20 px (10 mm) of the centre, all well inside the lit lens, each exceed 3 σ with 2 Φ(-3) = 0.0027 or more
// (σ estimated from the reference's frames only widens the tails), so a part shows a region with
// 1 - (1 - 0.0027)^49 = 0.12 or more, and 100 parts show none with 0.88^100 = 1.8e-6 or less. Expected
// over the whole lens (about 1870 pixels), about 5 off pixels a part. A finder that put σ too high by a
// factor of two (b = 3 acting as 6) passes every part and fails this test.
TEST_P(LfiInspectionCliEachCapture, AtThreeSigmaTheSameRunRaisesFalseAlarmsFromFreshNoise) {
  std::string text = benchText_;
  replaceOnce(text, "relative = 6", "relative = 3");
  bench_ = folder_.write("three-sigma.toml", text);
  capture();
  const fs::path run = folder_ / "run";
  const auto r = runLfi("-q run " + bench() + " --parts 100 --out " + shellQuoted(run.string()));
  ASSERT_NE(r.status, 1) << r.output;
  std::ifstream records(run / "records.jsonl");
  int parts = 0, failed = 0;
  nlohmann::json previous;
  for (std::string line; std::getline(records, line); ++parts) {
    const auto j = nlohmann::json::parse(line);
    EXPECT_EQ(j["status"], "inspected");
    if (j["verdict"] == "pass") continue;
    ++failed;
    // Fresh noise: a failed part's false alarms are not the last failed part's, which one frame again would
    // be to the last bit of each region's peak contrast, a continuous quantity.
    EXPECT_NE(j["defects"], previous) << line;
    previous = j["defects"];
  }
  EXPECT_EQ(parts, 100);
  EXPECT_GE(failed, 1) << "no false alarm in 100 parts at b = 3";
  std::printf("[ info     ] %d of %d parts with false alarms at b = 3\n", failed, parts);
}

TEST_P(LfiInspectionCliEachCapture, EveryDefectOfTheStudyIsFoundBlindWhereItIs) {
  capture();
  // Each defect part fails with its defects found where they are and no region beside them (study_parts.h):
  // inclusions (r = 0.5 mm, two pixels across) at the centre and near the rim within a pixel of their centres,
  // a 2 mm cut wider than three pixels inside its outline, the index high or the lens moved as a whole.
  const std::string scene = readText(source_ / "data" / "scenes" / "inspection_bench.toml");
  for (const StudyPart& part : lfi::testing_support::studyParts()) {
    if (part.intact) continue;  // (TheIntactLensPassesAHundredTimesInARowWithFreshNoise)
    SCOPED_TRACE(part.name);
    const auto [status, record] = inspect(folder_.write(part.name + ".toml", studyPartScene(scene, part)));
    EXPECT_EQ(status, 3);
    EXPECT_EQ(record["verdict"], "fail");
    EXPECT_EQ(misplacedDefects(part, centroidsOf(record)), "") << record.dump(1);
  }
}

class LfiCodedBenchCli : public LfiInspectionCli {
 protected:
  std::string benchName() const override { return "inspection_coded_sim.toml"; }
};

TEST_F(LfiCodedBenchCli, ACodedReferenceTakesTheDisplayWhereItIs) {
  // The display 2 mm further from the lens than the bench file's 30 mm, or tilted by 0.5°: the coded reference
  // is measured through the display where it is, so the intact lens passes and two weak inclusions (Ø1 mm,
  // index 1.53 in the lens's 1.5168) are found where they are, as on the nominal bench.
  const std::string weak =
      "[[object]]\nname = \"a\"\nshape = \"sphere\"\nradius_mm = 0.5\nposition_mm = [3, 3, 0]\n"
      "material = \"dielectric\"\nior = 1.53\n[[object]]\nname = \"b\"\nshape = \"sphere\"\n"
      "radius_mm = 0.5\nposition_mm = [9, -4, 0]\nmaterial = \"dielectric\"\nior = 1.53\n";
  const std::string displayAt = "position_mm = [0, 0, -30]\noptics";
  for (const auto& [name, display] :
       {std::pair<std::string, std::string>{"further", "position_mm = [0, 0, -32]\noptics"},
        {"tilted", "position_mm = [0, 0, -30]\nrotation_deg = [0.5, 0, 0]\noptics"}}) {
    SCOPED_TRACE(name);
    const fs::path scene = partScene(name, {{displayAt, display}}, "");
    std::string text = benchText_;
    replaceAll(text, (source_ / "data" / "scenes" / "inspection_bench.toml").string(), scene.string());
    replaceAll(text, folder_.path().string() + "/reference", folder_.path().string() + "/reference-" + name);
    bench_ = folder_.write(name + "-bench.toml", text);
    capture();
    const fs::path run = folder_ / ("run-" + name);
    const auto r = runLfi("-q run " + bench() + " --parts 20 --out " + shellQuoted(run.string()));
    EXPECT_EQ(r.status, 0) << r.output;
    std::ifstream records(run / "records.jsonl");
    int passed = 0;
    for (std::string line; std::getline(records, line);) passed += nlohmann::json::parse(line)["verdict"] == "pass";
    EXPECT_EQ(passed, 20);
    const auto [status, record] = inspect(partScene(name + "-weak", {{displayAt, display}}, weak));
    EXPECT_EQ(status, 3);
    EXPECT_EQ(misplacedDefects({"weak", {}, weak, {{3, 3}, {9, -4}}, kPixel_mm}, centroidsOf(record)), "")
        << record.dump(1);
  }
}

TEST_F(LfiCodedBenchCli, APanelReferenceOnAnotherPanelIsRefused) {
  // The display at the bench's URI replaced by one with another panel: the reference's panel image no longer
  // fits it, and inspect says so instead of showing it.
  const fs::path scene = partScene("display", {}, "");
  std::string text = benchText_;
  replaceAll(text, (source_ / "data" / "scenes" / "inspection_bench.toml").string(), scene.string());
  bench_ = folder_.write("display-bench.toml", text);
  capture();
  partScene("display", {{"panel_width_px = 800", "panel_width_px = 640"}}, "");
  const auto r = runLfi("-q inspect " + bench());
  EXPECT_EQ(r.status, 1) << r.output;
  for (const char* fragment : {"panel image is 800 x 800", "640 x 800 panel", "lfi capture", "--force"})
    EXPECT_NE(r.output.find(fragment), std::string::npos) << fragment << "\n" << r.output;
}

TEST_F(LfiInspectionCli, AFailedPartKeepsItsRecordImageAndOverlay) {
  capture();
  const fs::path out = folder_ / "part";
  const fs::path scene = partScene("particle", {},
                                   "[[object]]\nname = \"p\"\nshape = \"sphere\"\nradius_mm = 0.5\n"
                                   "position_mm = [-4, 3, 0]\nmaterial = \"absorber\"");
  const auto r = runLfi("-q inspect " + bench() + " --part " + shellQuoted(scene.string()) + " --out " +
                        shellQuoted(out.string()));
  EXPECT_EQ(r.status, 3) << r.output;
  EXPECT_NE(r.output.find("FAIL"), std::string::npos) << r.output;
  const auto record = nlohmann::json::parse(readText(out / "record.json"));
  EXPECT_EQ(record["format"], "lfi-inspection-record");
  EXPECT_EQ(record["status"], "inspected");
  ASSERT_EQ(record["defects"].size(), 1u) << record.dump(1);
  const auto& d = record["defects"][0];
  EXPECT_LE(distance(d, -4, 3), kPixel_mm);
  EXPECT_TRUE(d["dark"].get<bool>());
  EXPECT_LT(d["peak_contrast"].get<double>(), -0.3) << "an opaque particle takes a pixel's light, or most of it";
  // The area in mm² is the pixel count times the pixel's area.
  EXPECT_DOUBLE_EQ(d["area_mm2"].get<double>(), d["area_px"].get<double>() * kPixel_mm * kPixel_mm);
  EXPECT_TRUE(fs::exists(out / record["images"]["image"].get<std::string>()));
  EXPECT_TRUE(fs::exists(out / record["images"]["overlay"].get<std::string>()));
  // Never written over: the same --out again is refused and the record stays.
  const auto again = runLfi("-q inspect " + bench() + " --out " + shellQuoted(out.string()));
  EXPECT_EQ(again.status, 1);
  EXPECT_NE(again.output.find("exists"), std::string::npos) << again.output;
  EXPECT_EQ(nlohmann::json::parse(readText(out / "record.json")), record);
}

TEST_P(LfiInspectionCliEachCapture, TrainingAddsImagesToTheReferenceWhichEmitShows) {
  capture();
  const auto r = runLfi("-q train " + bench() + " --images 3");
  ASSERT_EQ(r.status, 0) << r.output;
  const auto meta = nlohmann::json::parse(readText(reference() / "reference.json"));
  EXPECT_EQ(meta["image"]["images_trained"], 16 + 3);
  EXPECT_EQ(runLfi("-q inspect " + bench()).status, 0);
  const auto emit = runLfi("emit " + bench() + " --seconds 0.2");
  EXPECT_EQ(emit.status, 0) << emit.output;
  EXPECT_NE(emit.output.find("emit: showing on sim:"), std::string::npos) << emit.output;
  const bool coded = GetParam() == "inspection_coded_sim.toml";
  EXPECT_EQ(fs::exists(reference() / "panel.exr"), coded) << "a reference measured through the display keeps its panel";
  EXPECT_NE(emit.output.find(coded ? "the reference's panel image" : "the light field (white = "), std::string::npos)
      << emit.output;
}

TEST_F(LfiInspectionCli, BadBenchFilesAndReferencesAreNamedAndNothingIsWrittenOver) {
  {  // A misspelt key: the file, line and key.
    std::string text = benchText_;
    replaceAll(text, "exposure_us = 10000", "exposure_uss = 10000");
    const fs::path bad = folder_.write("misspelt.toml", text);
    const auto r = runLfi("-q capture " + shellQuoted(bad.string()));
    EXPECT_EQ(r.status, 1);
    EXPECT_NE(r.output.find("misspelt.toml:"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("exposure_uss"), std::string::npos) << r.output;
  }
  const auto none = runLfi("-q inspect " + bench());
  EXPECT_EQ(none.status, 1);
  EXPECT_NE(none.output.find("no reference package"), std::string::npos) << none.output;
  capture();
  const std::string before = readText(reference() / "reference.json");
  {  // Capture again without --force: refused, the package as it was.
    const auto r = runLfi("-q capture " + bench());
    EXPECT_EQ(r.status, 1);
    EXPECT_NE(r.output.find("exists"), std::string::npos) << r.output;
    EXPECT_EQ(readText(reference() / "reference.json"), before);
  }
  {  // The same reference folder from a bench with another exposure: another bench's reference.
    std::string text = benchText_;
    replaceAll(text, "exposure_us = 10000", "exposure_us = 12000");
    const fs::path other = folder_.write("other.toml", text);
    const auto r = runLfi("-q inspect " + shellQuoted(other.string()));
    EXPECT_EQ(r.status, 1);
    EXPECT_NE(r.output.find("another bench"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("lfi capture"), std::string::npos) << r.output;
  }
  {  // A damaged image in the package: the folder and file named.
    std::string ideal = readText(reference() / "ideal.exr");
    ideal.resize(ideal.size() / 2);
    std::ofstream(reference() / "ideal.exr", std::ios::binary | std::ios::trunc) << ideal;
    const auto r = runLfi("-q inspect " + bench());
    EXPECT_EQ(r.status, 1);
    EXPECT_NE(r.output.find("ideal.exr"), std::string::npos) << r.output;
  }
  {  // --part on a bench whose camera is not simulated.
    std::string text = benchText_;
    replaceAll(text, "uri = \"sim:" + (source_ / "data" / "scenes").string() + "/inspection_bench.toml\"\nexposure",
               "uri = \"aravis:Nothing-Here\"\nexposure");
    const fs::path physical = folder_.write("physical.toml", text);
    const auto r = runLfi("-q inspect " + shellQuoted(physical.string()) + " --part " + shellQuoted(bench_.string()));
    EXPECT_EQ(r.status, 1);
    EXPECT_NE(r.output.find("--part"), std::string::npos) << r.output;
  }
}

TEST_F(LfiInspectionCli, DevicesChecksWhatABenchNames) {
  capture();
  const auto sim = runLfi("devices " + bench());
  EXPECT_NE(sim.output.find("camera"), std::string::npos);
  EXPECT_NE(sim.output.find("taken"), std::string::npos) << "the reference package is there\n" << sim.output;
  EXPECT_EQ(sim.output.find("NOT AVAILABLE"), std::string::npos) << sim.output;
  // The physical template names devices this machine does not have: each one said, and the status says so.
  const auto physical =
      runLfi("devices " + shellQuoted((source_ / "data" / "benches" / "inspection_physical.toml").string()));
  EXPECT_EQ(physical.status, 1) << physical.output;
  EXPECT_NE(physical.output.find("camera    aravis:Basler"), std::string::npos) << physical.output;
  EXPECT_NE(physical.output.find("display   usb:1209:4c46  NOT AVAILABLE"), std::string::npos) << physical.output;
  // Its coded capture measures through those two: not there without them.
  EXPECT_NE(physical.output.find("capture   coded:  NOT AVAILABLE: it measures through the bench's "
                                 "display and camera, neither of which is available"),
            std::string::npos)
      << physical.output;
}

// A bench file named bare in its own folder, with bare folder names in it: their parent is the working folder.
TEST_F(LfiInspectionCli, ABenchInTheWorkingFolderKeepsItsReferenceThere) {
  std::string text = benchText_;
  replaceAll(text, "folder = \"" + folder_.path().string() + "/reference\"", "folder = \"reference\"");
  folder_.write("bare.toml", text);
  const auto r = runLfi("-q capture bare.toml", true, "cd " + shellQuoted(folder_.path().string()) + " && ");
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(fs::exists(folder_ / "reference" / "reference.json")) << r.output;
}

TEST_F(LfiInspectionCli, ARunInterruptedFromTheTerminalEndsWithEveryRecordAndItsSummary) {
  capture();
  const fs::path run = folder_ / "run";
  // SIGINT, as Ctrl-C, once the run has written its first record (whatever the machine's load: a fixed delay can
  // end it before its first part) and half a second more: the part in hand is finished, the run ends normally.
  // (The shell's $0 is the records file, "$@" the lfi command. `timeout --foreground` passes the one INT on to
  // lfi alone: without it, it also sends one to its process group, and a second INT ends lfi at once. A run with
  // no record in 120 s is signalled then; one that does not stop is killed at 300 s, and fails on its status.)
  const std::string signalAfterFirstRecord =
      "sh -c 'rec=$0; timeout --foreground --preserve-status --signal=KILL 300 \"$@\" & pid=$!; i=0; "
      "while [ ! -s \"$rec\" ] && [ $i -lt 1200 ]; do sleep 0.1; i=$((i+1)); done; sleep 0.5; kill -INT $pid; "
      "wait $pid' " +
      shellQuoted((run / "records.jsonl").string()) + " ";
  const auto r = runLfi("-q run " + bench() + " --out " + shellQuoted(run.string()), true, signalAfterFirstRecord);
  EXPECT_EQ(r.status, 0) << r.output;
  std::ifstream records(run / "records.jsonl");
  long parts = 0;
  for (std::string line; std::getline(records, line);) {
    EXPECT_FALSE(nlohmann::json::parse(line, nullptr, false).is_discarded()) << "a torn record: " << line;
    ++parts;
  }
  EXPECT_GT(parts, 0);
  EXPECT_NE(r.output.find(fmt::format("{} parts in", parts)), std::string::npos) << r.output;
  EXPECT_NE(readText(run / "summary.html").find(fmt::format("<td>{}</td>", parts)), std::string::npos);
}

TEST_F(LfiInspectionCli, ARunThatCannotWriteAPartsFilesStopsNamingThePartWithEveryRecordBefore) {
  capture();
  std::string text = benchText_;
  replaceAll(text, "save_images = \"failed\"", "save_images = \"all\"");
  const fs::path all = folder_.write("all.toml", text);
  // Part 3's image cannot be written: a folder is in its place (as a file system that refuses it).
  const fs::path run = folder_ / "run";
  fs::create_directories(run / "images" / "part-000003.exr");
  const auto r = runLfi("-q run " + shellQuoted(all.string()) + " --parts 10 --out " + shellQuoted(run.string()));
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("stopped at part 3"), std::string::npos) << r.output;
  std::ifstream records(run / "records.jsonl");
  std::vector<nlohmann::json> lines;
  for (std::string line; std::getline(records, line);) lines.push_back(nlohmann::json::parse(line));
  ASSERT_EQ(lines.size(), 3u);
  EXPECT_EQ(lines[0]["status"], "inspected");
  EXPECT_EQ(lines[1]["status"], "inspected");
  EXPECT_EQ(lines[2]["status"], "error");
  EXPECT_TRUE(fs::exists(run / "images" / "part-000002.exr"));
  EXPECT_NE(readText(run / "summary.html").find("<td>3</td><td>2</td><td>0</td><td>1</td>"), std::string::npos);
}

}  // namespace
