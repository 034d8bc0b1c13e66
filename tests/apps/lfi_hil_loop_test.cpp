// SPDX-License-Identifier: Apache-2.0
// The inspection loop over the real drivers gives the answers it gives in
// process: capture → emit → inspect on the study's defect parts, once with the
// sim: devices in the `lfi` process (data/benches/inspection_sim.toml and
// inspection_coded_sim.toml) and once through the aravis: and usb: backends
// against `lfi sim-bench` (data/benches/inspection_hil.toml), for both ways of
// taking the reference: the simulated light field sensor and the coded
// capture through the display and camera; and the coded capture once more
// through the aravis: and window: backends against `lfi sim-bench --display
// window`, whose display is an X server (data/benches/inspection_window.toml),
// and through Aravis's USB3 Vision path against `lfi sim-bench --camera u3v`,
// whose camera is a USB3 Vision device (data/benches/inspection_u3v.toml).
// Under sim-bench one script takes the reference and inspects the parts one
// after another, putting each under the camera with `lfi bench-control part`,
// as a line would.

#include "gige_device_process.h"
#include "lfi_process.h"
#include "record_defects.h"
#include "study_parts.h"
#include "test_folder.h"
#include "text_edit.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <map>
#include <set>
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
using lfi::testing_support::StudyPart;
using lfi::testing_support::studyParts;

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

// One line of a driver trace: the process, the layer, the call.
struct TraceLine {
  std::string pid, layer, call, detail;
};

std::vector<TraceLine> readTrace(const fs::path& file) {
  std::vector<TraceLine> lines;
  std::istringstream in(readText(file));
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::vector<std::string> f;
    std::istringstream columns(line);
    for (std::string c; std::getline(columns, c, '\t');) f.push_back(c);
    EXPECT_GE(f.size(), 5u) << line;
    if (f.size() >= 5) lines.push_back({f[1], f[2], f[4], f.size() > 5 ? f[5] : ""});
  }
  return lines;
}

// Param: the reference's capture, "sim" (the simulated light field sensor) or "coded" (through the display),
// with the usb: display and a GigE Vision camera; "window": the coded capture with the window: display;
// "u3v": the coded capture with a USB3 Vision camera.
class LfiHilLoop : public testing::TestWithParam<std::string> {
 protected:
  void SetUp() override {
    const std::string scenes = (source_ / "data" / "scenes").string() + "/";
    const bool coded = GetParam() != "sim";
    // In process: the shipped simulated bench of this capture.
    std::string text =
        readText(source_ / "data" / "benches" / (coded ? "inspection_coded_sim.toml" : "inspection_sim.toml"));
    replaceAll(text, "sim:../scenes/", "sim:" + scenes);
    replaceOnce(text, "folder = \"../../out/" + std::string(coded ? "bench/coded_reference" : "bench/reference"),
                "folder = \"" + (folder_ / "in-process" / "reference").string());
    replaceOnce(text, "folder = \"../../out/" + std::string(coded ? "bench/coded_inspections" : "bench/inspections"),
                "folder = \"" + (folder_ / "in-process" / "inspections").string());
    simBench_ = folder_.write("sim-bench.toml", text);
    // Through the real drivers: the shipped bench that names sim-bench's devices, with this capture.
    const std::string served = "bench-" + hil();
    text = readText(source_ / "data" / "benches" / ("inspection_" + hil() + ".toml"));
    replaceOnce(text, "folder = \"../../out/" + served + "/reference",
                "folder = \"" + (folder_ / "hil" / "reference").string());
    replaceOnce(text, "folder = \"../../out/" + served + "/inspections",
                "folder = \"" + (folder_ / "hil" / "inspections").string());
    if (!coded) replaceOnce(text, "uri = \"coded:\"", "uri = \"sim:" + scenes + "inspection_bench.toml\"");
    hilBench_ = folder_.write("hil-bench.toml", text);
    const std::string scene = readText(source_ / "data" / "scenes" / "inspection_bench.toml");
    for (const StudyPart& part : studyParts())
      scenes_[part.name] = folder_.write(part.name + ".toml", lfi::testing_support::studyPartScene(scene, part));
  }

  // lfi capture, then lfi inspect --part of each part, all in the lfi process's sim: devices.
  std::map<std::string, Inspection> inProcess() {
    std::map<std::string, Inspection> out;
    const std::string trace = "LFI_DRIVER_TRACE=" + shellQuoted(localTrace().string()) + " ";
    const auto capture = runLfi("-q capture " + shellQuoted(simBench_.string()), true, trace);
    EXPECT_EQ(capture.status, 0) << capture.output;
    for (const StudyPart& part : studyParts()) {
      const auto r = runLfi("-q inspect " + shellQuoted(simBench_.string()) + " --json --part " +
                                shellQuoted(scenes_[part.name].string()),
                            false, trace);
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
    const auto r = runLfi(
        "-q sim-bench " + shellQuoted(simBench_.string()) + (window() ? " --display window" : "") +
            (GetParam() == "u3v" ? " --camera u3v" : "") + " -- sh " + shellQuoted(file.string()),
        true, "LFI_DRIVER_TRACE=" + shellQuoted(remoteTrace().string()) + " timeout --foreground --signal=KILL 600 ");
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

  // The run over the real drivers made every call of the Camera and Display interfaces that the bench
  // path makes in process (the set of calls the sim: devices saw), and each reached the wire: between a
  // call's line and the one before it of the same device in the same process, the real backend's own
  // lines show the Aravis calls and USB requests it takes.
  void checkDriverCalls() const {
    const auto local = readTrace(localTrace()), remote = readTrace(remoteTrace());
    std::set<std::string> made, reached;
    for (const TraceLine& l : local)
      if (l.layer == "camera" || l.layer == "display") made.insert(l.layer + "." + l.call);
    for (const TraceLine& l : remote)
      if (l.layer == "camera" || l.layer == "display") reached.insert(l.layer + "." + l.call);
    for (const std::string& call : made) EXPECT_TRUE(reached.count(call)) << call << " never reached the real drivers";
    for (const char* call :
         {"camera.open", "camera.configure", "camera.start", "camera.trigger", "camera.grab", "camera.stop",
          "camera.close", "display.open", "display.show", "display.status", "display.close"})
      EXPECT_TRUE(made.count(call)) << call << ": the bench path makes it (a sim: device saw none)";
    // What each interface call must have done on the wire: the USB display's requests, or the window:
    // display's presenter and its presents (a monitor's status and brightness are not the wire's).
    const std::map<std::string, std::vector<std::string>> windowWire = {
        {"display.open", {"presenter"}}, {"display.show", {"present"}}, {"display.blank", {"present black"}}};
    std::map<std::string, std::vector<std::string>> wire = {
        {"camera.open", {"arv_camera_new"}},
        {"camera.configure",
         {"arv_camera_set_exposure_time", "arv_camera_set_pixel_format_from_string", "arv_camera_set_trigger"}},
        {"camera.start", {"arv_camera_start_acquisition"}},
        {"camera.trigger", {"arv_camera_software_trigger"}},
        {"camera.grab", {"arv_stream_timeout_pop_buffer"}},
        {"camera.stop", {"arv_camera_stop_acquisition"}},
        {"display.open", {"CLAIM_INTERFACE", "GET_DEVICE_INFO", "GET_CALIBRATION"}},
        {"display.show", {"bulk OUT", "PRESENT"}},
        {"display.status", {"GET_STATUS"}},
        {"display.blank", {"BLANK"}},
        {"display.brightness", {"SET_BRIGHTNESS"}}};
    if (window()) {
      std::erase_if(wire, [](const auto& w) { return w.first.starts_with("display."); });
      wire.insert(windowWire.begin(), windowWire.end());
    }
    std::map<std::string, std::set<std::string>>
        since;  // per process and interface layer: wire calls since its last line
    std::map<std::string, int> checked;
    for (const TraceLine& l : remote) {
      const bool camera = l.layer == "camera" || l.layer == "aravis";
      std::set<std::string>& pending = since[l.pid + (camera ? "camera" : "display")];
      if (l.layer == "aravis" || l.layer == "usb" || l.layer == "window") {
        pending.insert(l.call);
        continue;
      }
      const std::string call = l.layer + "." + l.call;
      if (const auto it = wire.find(call); it != wire.end() && l.detail.rfind("failed", 0) != 0) {
        for (const std::string& w : it->second) EXPECT_TRUE(pending.count(w)) << call << " without " << w;
        ++checked[call];
      }
      pending.clear();
    }
    for (const std::string& call : made)
      EXPECT_TRUE(!wire.count(call) || checked[call] > 0) << call << " never went through the real driver whole";
  }

  static bool window() { return GetParam() == "window"; }
  // The shipped bench file that names sim-bench's devices: inspection_<hil()>.toml.
  static std::string hil() { return GetParam() == "window" || GetParam() == "u3v" ? GetParam() : "hil"; }

  // The driver traces (driver_trace.h) of the two wirings' processes.
  fs::path localTrace() const { return folder_ / "in-process.trace"; }
  fs::path remoteTrace() const { return folder_ / "hil.trace"; }

  const fs::path source_ = LFI_SOURCE_DIR;
  lfi::testing_support::LoopbackGigeLock lock_;  // (sim-bench serves on 127.0.0.1:3956)
  lfi::testing_support::TestFolder folder_{"lfi-hil-loop"};
  fs::path simBench_, hilBench_;  // (sim-bench serves the in-process bench's scene)
  std::map<std::string, fs::path> scenes_;
};

INSTANTIATE_TEST_SUITE_P(Captures, LfiHilLoop, testing::Values("sim", "coded", "window", "u3v"),
                         [](const testing::TestParamInfo<std::string>& p) {
                           return p.param == "sim"      ? std::string("SimulatedSensor")
                                  : p.param == "coded"  ? std::string("Coded")
                                  : p.param == "window" ? std::string("CodedOnAMonitor")
                                                        : std::string("CodedThroughUsb3Vision");
                         });

// The verdicts agree part by part, and are the truth: the intact part passes, every defect part fails.
// Where a defect has a place, each wiring finds it there and nothing beside it, and the two wirings' positions
// agree within a pixel: both image the same rendered radiance through the same detector, and only the
// noise draw differs (frame ids; over GigE Vision also Mono16's finer quantisation against Mono12), which moves a
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
    EXPECT_EQ(misplacedDefects(part, centroidsOf(a.record)), "") << a.record.dump(1);
    EXPECT_EQ(misplacedDefects(part, centroidsOf(b.record)), "") << b.record.dump(1);
    for (const auto& [x, y] : part.defects_mm) {
      nlohmann::json da, db;
      nearest(a.record, x, y, &da);
      nearest(b.record, x, y, &db);
      if (da.is_null() || db.is_null()) continue;
      EXPECT_LE(std::hypot(da["centroid_mm"][0].get<double>() - db["centroid_mm"][0].get<double>(),
                           da["centroid_mm"][1].get<double>() - db["centroid_mm"][1].get<double>()),
                lfi::testing_support::kInspectionPixel_mm)
          << da.dump() << "\n"
          << db.dump();
    }
  }
  checkDriverCalls();
  // The records name the bench that took them: the sim: devices' in process, the served devices' over the drivers.
  EXPECT_EQ(fs::path(local.at("cut").record["bench"]["file"].get<std::string>()), fs::absolute(simBench_));
  EXPECT_EQ(fs::path(remote.at("cut").record["bench"]["file"].get<std::string>()), fs::absolute(hilBench_));
}

}  // namespace
