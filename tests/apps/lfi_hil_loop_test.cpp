// The inspection loop over the real drivers gives the answers it gives in
// process: capture → emit → inspect on the study's defect parts, once with the
// sim: devices in the `lfi` process (data/benches/inspection_sim.toml and
// inspection_coded_sim.toml) and once through the aravis: and usb: backends
// against `lfi sim-bench` (data/benches/inspection_hil.toml), for both ways of
// taking the reference: the simulated light field sensor and the coded
// capture through the display and camera. Under sim-bench one script takes the
// reference and inspects the parts one after another, putting each under the
// camera with `lfi bench-control part`, as a line would.

#include "gige_device_process.h"
#include "lfi_process.h"
#include "study_parts.h"
#include "test_folder.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

namespace {

namespace fs = std::filesystem;
using lfi::testing_support::runLfi;
using lfi::testing_support::shellQuoted;
using lfi::testing_support::StudyPart;
using lfi::testing_support::studyParts;

std::string readText(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

void replaceOnce(std::string& text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  ASSERT_NE(at, std::string::npos) << from;
  text.replace(at, from.size(), to);
}

void replaceAll(std::string& text, const std::string& from, const std::string& to) {
  ASSERT_NE(text.find(from), std::string::npos) << from;
  for (size_t at = 0; (at = text.find(from, at)) != std::string::npos; at += to.size()) text.replace(at, from.size(), to);
}

struct Inspection {
  int status = -1;  // lfi inspect's: 0 pass, 3 fail
  nlohmann::json record;
};

double nearest(const nlohmann::json& record, double x, double y, nlohmann::json* which = nullptr) {
  double best = 1e9;
  for (const auto& d : record["defects"]) {
    const double r = std::hypot(d["centroid_mm"][0].get<double>() - x, d["centroid_mm"][1].get<double>() - y);
    if (r < best) {
      best = r;
      if (which) *which = d;
    }
  }
  return best;
}

// Param: the reference's capture, "sim" (the simulated light field sensor) or "coded" (through the display).
class LfiHilLoop : public testing::TestWithParam<std::string> {
protected:
  void SetUp() override {
    const std::string scenes = (source_ / "data" / "scenes").string() + "/";
    const bool coded = GetParam() == "coded";
    // In process: the shipped simulated bench of this capture.
    std::string text = readText(source_ / "data" / "benches" / (coded ? "inspection_coded_sim.toml"
                                                                        : "inspection_sim.toml"));
    replaceAll(text, "sim:../scenes/", "sim:" + scenes);
    replaceOnce(text, "folder = \"../../out/" + std::string(coded ? "bench/coded_reference" : "bench/reference"),
                "folder = \"" + (folder_ / "in-process" / "reference").string());
    replaceOnce(text, "folder = \"../../out/" + std::string(coded ? "bench/coded_inspections" : "bench/inspections"),
                "folder = \"" + (folder_ / "in-process" / "inspections").string());
    simBench_ = folder_.write("sim-bench.toml", text);
    // Through the real drivers: the shipped bench that names sim-bench's devices, with this capture.
    text = readText(source_ / "data" / "benches" / "inspection_hil.toml");
    replaceOnce(text, "folder = \"../../out/bench-hil/reference", "folder = \"" + (folder_ / "hil" / "reference").string());
    replaceOnce(text, "folder = \"../../out/bench-hil/inspections",
                "folder = \"" + (folder_ / "hil" / "inspections").string());
    if (!coded)
      replaceOnce(text, "uri = \"coded:?distance_mm=30\"",
                  "uri = \"sim:" + scenes + "inspection_bench.toml?distance_mm=30\"");
    hilBench_ = folder_.write("hil-bench.toml", text);
    // The sim-bench that serves them: the in-process bench's scene.
    servedBench_ = simBench_;
    const std::string scene = readText(source_ / "data" / "scenes" / "inspection_bench.toml");
    for (const StudyPart& part : studyParts())
      scenes_[part.name] = folder_.write(part.name + ".toml", lfi::testing_support::studyPartScene(scene, part));
  }

  // lfi capture, then lfi inspect --part of each part, all in the lfi process's sim: devices.
  std::map<std::string, Inspection> inProcess() {
    std::map<std::string, Inspection> out;
    const auto capture = runLfi("-q capture " + shellQuoted(simBench_.string()));
    EXPECT_EQ(capture.status, 0) << capture.output;
    for (const StudyPart& part : studyParts()) {
      const auto r = runLfi("-q inspect " + shellQuoted(simBench_.string()) + " --json --part " +
                                shellQuoted(scenes_[part.name].string()), false);
      out[part.name] = {r.status, nlohmann::json::parse(r.output, nullptr, false)};
    }
    return out;
  }

  // One `lfi sim-bench` running a script: lfi capture, then for each part `lfi bench-control part` and lfi inspect.
  std::map<std::string, Inspection> overRealDrivers() {
    const std::string lfi = shellQuoted(LFI_EXECUTABLE), bench = shellQuoted(hilBench_.string());
    std::string script = "set -u\n" + lfi + " -q capture " + bench + " || exit 10\n";
    for (const StudyPart& part : studyParts()) {
      const std::string out = shellQuoted((folder_ / ("hil-" + part.name)).string());
      script += lfi + " -q bench-control part " + (part.intact ? "" : shellQuoted(scenes_[part.name].string())) +
                " >/dev/null || exit 11\n" + lfi + " -q inspect " + bench + " --json > " + out + ".json\necho $? > " +
                out + ".status\n";
    }
    const fs::path file = folder_.write("hil.sh", script);
    const auto r = runLfi("-q sim-bench " + shellQuoted(servedBench_.string()) + " -- sh " + shellQuoted(file.string()),
                          true, "timeout --foreground --signal=KILL 600 ");
    EXPECT_EQ(r.status, 0) << r.output;
    std::map<std::string, Inspection> out;
    for (const StudyPart& part : studyParts()) {
      const fs::path base = folder_ / ("hil-" + part.name);
      Inspection& i = out[part.name];
      std::istringstream(readText(base.string() + ".status")) >> i.status;
      i.record = nlohmann::json::parse(readText(base.string() + ".json"), nullptr, false);
    }
    return out;
  }

  const fs::path source_ = LFI_SOURCE_DIR;
  lfi::testing_support::LoopbackGigeLock lock_;  // (sim-bench serves on 127.0.0.1:3956)
  lfi::testing_support::TestFolder folder_{"lfi-hil-loop"};
  fs::path simBench_, hilBench_, servedBench_;
  std::map<std::string, fs::path> scenes_;
};

INSTANTIATE_TEST_SUITE_P(Captures, LfiHilLoop, testing::Values("sim", "coded"),
                         [](const testing::TestParamInfo<std::string>& p) {
                           return p.param == "sim" ? std::string("SimulatedSensor") : std::string("Coded");
                         });

// The verdicts agree part by part, and are the truth: the intact part passes, every defect part fails.
// Where a defect has a place, each wiring finds it there, and the two wirings' positions
// agree within a pixel: both image the same rendered radiance through the same detector, and only the
// noise draw differs (frame ids, and Mono12 against Mono16's finer quantisation), which moves a
// region's edge pixels in or out and its centroid by a fraction of a pixel.
TEST_P(LfiHilLoop, TheRealDriversGiveTheVerdictsAndDefectsOfTheInProcessLoop) {
  const auto local = inProcess();
  const auto remote = overRealDrivers();
  for (const StudyPart& part : studyParts()) {
    SCOPED_TRACE(part.name);
    const Inspection &a = local.at(part.name), &b = remote.at(part.name);
    ASSERT_FALSE(a.record.is_discarded());
    ASSERT_FALSE(b.record.is_discarded());
    EXPECT_EQ(a.status, part.intact ? 0 : 3) << a.record.dump(1);
    EXPECT_EQ(b.status, a.status) << b.record.dump(1);
    EXPECT_EQ(b.record["verdict"], a.record["verdict"]);
    EXPECT_EQ(b.record["defects"].empty(), a.record["defects"].empty());
    for (const auto& [x, y] : part.defects_mm) {
      nlohmann::json da, db;
      EXPECT_LE(nearest(a.record, x, y, &da), part.within_mm) << a.record.dump(1);
      EXPECT_LE(nearest(b.record, x, y, &db), part.within_mm) << b.record.dump(1);
      if (da.is_null() || db.is_null()) continue;
      EXPECT_LE(std::hypot(da["centroid_mm"][0].get<double>() - db["centroid_mm"][0].get<double>(),
                           da["centroid_mm"][1].get<double>() - db["centroid_mm"][1].get<double>()),
                lfi::testing_support::kInspectionPixel_mm)
          << da.dump() << "\n" << db.dump();
    }
  }
  // The records name the bench that took them: the sim: devices' in process, the served devices' over the drivers.
  EXPECT_EQ(fs::path(local.at("cut").record["bench"]["file"].get<std::string>()), fs::absolute(simBench_));
  EXPECT_EQ(fs::path(remote.at("cut").record["bench"]["file"].get<std::string>()), fs::absolute(hilBench_));
}

}  // namespace
