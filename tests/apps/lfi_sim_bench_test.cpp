// SPDX-License-Identifier: Apache-2.0
// `lfi sim-bench` and `lfi bench-control` as a bench user runs them: a run of
// 50 parts through the real drivers with the camera taken off the network 5
// times and the display unplugged 5 times, which records each fault against
// the part in hand, loses nothing and goes on when the device is back; the
// program's exit status passed on; and requests and benches it refuses, with
// errors that name them.

#include "gige_device_process.h"
#include "lfi/controller/bench_file.h"
#include "lfi_process.h"
#include "record_defects.h"
#include "study_parts.h"
#include "test_folder.h"
#include "text_edit.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;
using lfi::testing_support::readText;
using lfi::testing_support::replaceOnce;
using lfi::testing_support::runLfi;
using lfi::testing_support::shellQuoted;

// A run's records, one JSON object a line; fails at a line that is not one (a torn record).
testing::AssertionResult readRecords(const fs::path& file, std::vector<nlohmann::json>& lines) {
  std::ifstream in(file);
  for (std::string line; std::getline(in, line);) {
    lines.push_back(nlohmann::json::parse(line, nullptr, false));
    if (lines.back().is_discarded()) return testing::AssertionFailure() << "a torn record: " << line;
  }
  return testing::AssertionSuccess();
}

class LfiSimBench : public testing::Test {
 protected:
  void SetUp() override {
    const std::string scenes = (source_ / "data" / "scenes").string();
    // The shipped simulated bench, served; and a bench of its served devices with the simulated sensor's
    // reference (the quicker one), waiting for devices that drop out. 16 frames a part (about 0.1 s)
    // keep a run of 50 parts long enough for 10 faults a second long, with parts between them.
    std::string text = readText(source_ / "data" / "benches" / "inspection_sim.toml");
    for (size_t at; (at = text.find("sim:../scenes/")) != std::string::npos;)
      text.replace(at, 14, "sim:" + scenes + "/");
    served_ = folder_.write("served.toml", text);
    hil_ = folder_.write("hil.toml", fmt::format(R"(format = "lfi-inspection-bench"
version = 1
[camera]
uri = "aravis:lfi-SimCamera-LFISIM01"
exposure_us = 10000
pixel_format = "Mono16"
object_pixel_mm = 0.5
dn_per_electron = 6.24
read_noise_dn = 15.7
grab_timeout_ms = 1000
retries = 0
[display]
uri = "usb:1209:4c46/LFI-SIM-0001"
[capture]
uri = "sim:{0}/inspection_bench.toml"
[geometry]
distance_mm = 30
part_centre_px = [27.5, 27.5]
[reference]
folder = "reference"
mask_radius_mm = 12.2
[inspection]
frames = 16
smallest_defect_mm = 1.0
closing_mm = 0.5
[output]
folder = "out"
save_images = "none"
[run]
on_device_loss = "wait"
wait_limit_s = 60
)",
                                                 scenes));
  }

  // `lfi sim-bench` on the served bench running `sh -c SCRIPT`.
  lfi::testing_support::LfiResult simBench(const std::string& script, const std::string& options = "") {
    return runLfi("-q sim-bench " + shellQuoted(served_.string()) + options + " -- sh -c " + shellQuoted(script), true,
                  "timeout --foreground --signal=KILL 600 ");
  }

  const fs::path source_ = LFI_SOURCE_DIR;
  lfi::testing_support::LoopbackGigeLock lock_;  // (sim-bench serves on 127.0.0.1:3956)
  lfi::testing_support::TestFolder folder_{"lfi-sim-bench"};
  fs::path served_, hil_;
};

// Each fault is injected once the run has recorded the one before and inspected a part since (so that
// it hits a run in full flow, and never the same outage twice), at part 2, 6, 10, ... at the earliest,
// and lasts until the run has recorded the part in hand as not inspected: whatever the host's speed, the
// part in hand sees it. The run then waits for the device with its back-off and goes on; it is stopped
// (SIGTERM) once it has inspected a part after the tenth and reached fifty parts. Every part is the intact
// one, so an image taken while the display was dark would fail: none may be judged.
TEST_F(LfiSimBench, ARunOfFiftyPartsRidesOutTheCameraGoneAndTheDisplayUnpluggedFiveTimesEach) {
  const std::string lfi = shellQuoted(LFI_EXECUTABLE), bench = shellQuoted(hil_.string());
  const fs::path run = folder_ / "run", records = run / "records.jsonl";
  const std::string script = fmt::format(R"sh(set -u
{0} -q capture {1} || exit 10
{0} -q run {1} --out {2} & run=$!
count() {{ if [ -f {3} ]; then wc -l < {3}; else echo 0; fi; }}
errors() {{ if [ -f {3} ]; then grep -c '"status":"error"' {3} || true; else echo 0; fi; }}
recovered() {{ tail -n 1 {3} 2>/dev/null | grep -q '"status":"inspected"'; }}
# waits (up to 120 s) until the condition holds
until_() {{ i=0; until "$@"; do i=$((i+1)); [ $i -gt 2400 ] && exit 12; sleep 0.05; done; }}
k=0
for device in camera display camera display camera display camera display camera display; do
  until_ eval '[ "$(count)" -ge $((2 + 4 * k)) ] && [ "$(errors)" -eq $k ] && recovered'
  if [ $device = camera ]; then
    {0} -q bench-control camera off >/dev/null || exit 11
    until_ eval '[ "$(errors)" -gt $k ]'; {0} -q bench-control camera on >/dev/null || exit 11
  else
    {0} -q bench-control display unplug >/dev/null || exit 11
    until_ eval '[ "$(errors)" -gt $k ]'; {0} -q bench-control display plug >/dev/null || exit 11
  fi
  k=$((k+1))
done
until_ eval '[ "$(count)" -ge 50 ] && recovered'
kill -TERM $run
wait $run
)sh",
                                         lfi, bench, shellQuoted(run.string()), shellQuoted(records.string()));
  const auto r = simBench(script);
  ASSERT_EQ(r.status, 0) << r.output;
  std::vector<nlohmann::json> lines;
  ASSERT_TRUE(readRecords(records, lines));
  ASSERT_GE(lines.size(), 50u);
  std::vector<std::string> faults;
  for (size_t i = 0; i < lines.size(); ++i) {
    const auto& j = lines[i];
    EXPECT_EQ(j["part"], i + 1);
    if (j["status"] == "error") {
      const std::string error = j["error"];
      const bool camera = error.find("lfi-SimCamera-LFISIM01") != std::string::npos;
      const bool display =
          error.find("LFI-SIM-0001") != std::string::npos || error.find("display") != std::string::npos;
      EXPECT_TRUE(camera != display) << "names the device that failed: " << error;
      faults.push_back(camera ? "camera" : "display");
      ASSERT_LT(i + 1, lines.size());
      EXPECT_EQ(lines[i + 1]["status"], "inspected") << "the run goes on once the device is back";
    } else {
      EXPECT_EQ(j["verdict"], "pass") << j.dump();
    }
  }
  EXPECT_EQ(faults, (std::vector<std::string>{"camera", "display", "camera", "display", "camera", "display", "camera",
                                              "display", "camera", "display"}));
  const size_t n = lines.size();
  EXPECT_NE(readText(run / "summary.html").find(fmt::format("<td>{}</td><td>{}</td><td>0</td><td>10</td>", n, n - 10)),
            std::string::npos);
}

// The display served as a monitor (an X server) and driven by the window: backend: a run that waits for
// lost devices rides out the X server killed three times, at part 2, 5, 8 at the earliest. The part in
// hand when the server goes is recorded as not inspected, naming the output; the run opens the display
// again on the server that comes back (the same display number) and goes on; every other part passes.
TEST_F(LfiSimBench, ARunOnAMonitorRidesOutItsXServerKilledThreeTimes) {
  std::string text = readText(hil_);
  replaceOnce(text, "uri = \"usb:1209:4c46/LFI-SIM-0001\"", R"(uri = "window:0?pitch_mm=0.0315&mode=800x800&layout=rgb"
[display.optics]
optics = "lenslet_array"
array_pitch_mm = 1.0
gap_mm = 1.37
focal_length_mm = 1.37)");
  const fs::path bench = folder_.write("window.toml", text);
  const std::string lfi = shellQuoted(LFI_EXECUTABLE);
  const fs::path run = folder_ / "run", records = run / "records.jsonl";
  const std::string script =
      fmt::format(R"sh(set -u
{0} -q capture {1} || exit 10
{0} -q run {1} --out {2} & run=$!
count() {{ if [ -f {3} ]; then wc -l < {3}; else echo 0; fi; }}
errors() {{ if [ -f {3} ]; then grep -c '"status":"error"' {3} || true; else echo 0; fi; }}
recovered() {{ tail -n 1 {3} 2>/dev/null | grep -q '"status":"inspected"'; }}
until_() {{ i=0; until "$@"; do i=$((i+1)); [ $i -gt 2400 ] && exit 12; sleep 0.05; done; }}
for k in 0 1 2; do
  until_ eval '[ "$(count)" -ge $((2 + 3 * k)) ] && [ "$(errors)" -eq $k ] && recovered'
  {0} -q bench-control display unplug >/dev/null || exit 11
  until_ eval '[ "$(errors)" -gt $k ]'; {0} -q bench-control display plug >/dev/null || exit 11
done
until_ eval '[ "$(count)" -ge 12 ] && recovered'
kill -TERM $run
wait $run
)sh",
                  lfi, shellQuoted(bench.string()), shellQuoted(run.string()), shellQuoted(records.string()));
  const auto r = simBench(script, " --display window");
  ASSERT_EQ(r.status, 0) << r.output;
  std::vector<nlohmann::json> lines;
  ASSERT_TRUE(readRecords(records, lines));
  ASSERT_GE(lines.size(), 12u);
  int faults = 0;
  for (size_t i = 0; i < lines.size(); ++i) {
    const auto& j = lines[i];
    EXPECT_EQ(j["part"], i + 1);
    if (j["status"] == "error") {
      ++faults;
      EXPECT_NE(j["error"].get<std::string>().find("window:0"), std::string::npos) << "names the output: " << j;
      ASSERT_LT(i + 1, lines.size());
      EXPECT_EQ(lines[i + 1]["status"], "inspected") << "the run goes on once the server is back";
    } else {
      EXPECT_EQ(j["verdict"], "pass") << j.dump();
    }
  }
  EXPECT_EQ(faults, 3);
}

// A line: each part put under the camera fires its input line Line0, and a run whose camera is triggered
// by that line inspects the part, one image each. The records follow the parts in the order the line
// brought them, with each part's verdict. The same bench file takes its reference: lfi triggers those
// exposures itself (no part passes the sensor then). A part is put only once the camera takes the edge
// (it acquires once the run has shown the reference) and the record of the one before is written.
TEST_F(LfiSimBench, ALineTriggeredRunInspectsEachPartTheLineBringsInItsOrder) {
  std::string text = readText(hil_);
  replaceOnce(text, "grab_timeout_ms", "trigger = \"line\"\ntrigger_line = \"Line0\"\ngrab_timeout_ms");
  replaceOnce(text, "frames = 16", "frames = 1");  // (one edge, one frame)
  replaceOnce(text, "on_device_loss = \"wait\"", "on_device_loss = \"stop\"");
  const fs::path line = folder_.write("line.toml", text);
  const std::string sceneText = readText(source_ / "data" / "scenes" / "inspection_bench.toml");
  const std::string lfi = shellQuoted(LFI_EXECUTABLE);
  const fs::path run = folder_ / "run", records = run / "records.jsonl";
  std::string script = fmt::format(R"sh(set -u
{0} -q capture {1} || exit 10
{0} -q run {1} --parts {2} --out {3} & run=$!
count() {{ if [ -f {4} ]; then wc -l < {4}; else echo 0; fi; }}
bring() {{ i=0; until {0} -q bench-control part "$1" | grep -q "triggered a frame"; do i=$((i+1)); [ $i -gt 600 ] && exit 12; sleep 0.1; done; }}
until_records() {{ i=0; while [ "$(count)" -lt "$1" ]; do i=$((i+1)); [ $i -gt 1200 ] && exit 13; sleep 0.05; done; }}
)sh",
                                   lfi, shellQuoted(line.string()), lfi::testing_support::studyParts().size(),
                                   shellQuoted(run.string()), shellQuoted(records.string()));
  int k = 0;
  for (const auto& part : lfi::testing_support::studyParts()) {
    const fs::path scene = folder_.write(part.name + ".toml", lfi::testing_support::studyPartScene(sceneText, part));
    script += fmt::format("bring {}\nuntil_records {}\n", shellQuoted(scene.string()), ++k);
  }
  script += "wait $run\n";
  const auto r = simBench(script);
  ASSERT_EQ(r.status, 0) << r.output;
  std::vector<nlohmann::json> lines;
  std::ifstream in(records);
  for (std::string l; std::getline(in, l);) lines.push_back(nlohmann::json::parse(l, nullptr, false));
  const auto parts = lfi::testing_support::studyParts();
  ASSERT_EQ(lines.size(), parts.size()) << r.output;
  for (size_t i = 0; i < parts.size(); ++i) {
    SCOPED_TRACE(parts[i].name);
    ASSERT_FALSE(lines[i].is_discarded());
    EXPECT_EQ(lines[i]["status"], "inspected") << lines[i].dump();
    EXPECT_EQ(lines[i]["verdict"], parts[i].intact ? "pass" : "fail") << lines[i].dump();
    EXPECT_EQ(lfi::testing_support::misplacedDefects(parts[i], lfi::testing_support::centroidsOf(lines[i])), "")
        << lines[i].dump();
  }
}

// The display's and the network's faults reach the real drivers through sim-bench as a physical bench's
// would: a stalled endpoint is cleared and the frame sent again (the part is inspected), a frame the
// display refuses for its CRC fails the show with the device's reason, and GVSP packets lost at 5 %
// (Aravis's device does not resend) cost incomplete frames that the inspection's retries ride out.
// A 56 x 56 Mono16 frame is 7 packets or more, so about 30 % of frames come incomplete: among the 50
// parts' frames some do with a probability of 1 - 0.7^50 (1 - 2e-8), and 10 retries fail a part with
// 0.3^11 (2e-6).
TEST_F(LfiSimBench, DisplayAndNetworkFaultsReachTheRealDriversAsOnABench) {
  std::string text = readText(hil_);
  replaceOnce(text, "frames = 16", "frames = 1");
  replaceOnce(text, "retries = 0", "retries = 10");
  const fs::path bench = folder_.write("retries.toml", text);
  const std::string lfi = shellQuoted(LFI_EXECUTABLE), b = shellQuoted(bench.string());
  const auto r = simBench(fmt::format(R"sh({0} -q capture {1} || exit 10
{0} -q bench-control display stall >/dev/null; {0} -q inspect {1} >/dev/null; echo "stalled: $?"
{0} -q bench-control display corrupt >/dev/null; {0} -q inspect {1} >/dev/null; echo "corrupt: $?"
{0} -q bench-control status
{0} -q bench-control packet-loss 0.05 >/dev/null
{0} -q run {1} --parts 50 --out {2} | head -1
{0} -q bench-control status
)sh",
                                      lfi, b, shellQuoted((folder_ / "run").string())));
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("stalled: 0"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("corrupt: 1"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("payload CRC mismatch"), std::string::npos) << "the device's reason: " << r.output;
  EXPECT_NE(r.output.find("50 parts in"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("50 passed, 0 failed, 0 not inspected"), std::string::npos) << r.output;
  // Frames served before and after the run: more than one a part went out for the 50 parts.
  std::vector<long> served;
  for (size_t at = 0; (at = r.output.find(" frames served", at)) != std::string::npos; ++at) {
    const size_t start = r.output.rfind(' ', at - 1) + 1;
    served.push_back(std::stol(r.output.substr(start, at - start)));
  }
  ASSERT_EQ(served.size(), 2u) << r.output;
  EXPECT_GT(served[1] - served[0], 50) << "no frame came incomplete: was the packet loss applied?\n" << r.output;
}

// The calibrations unchanged over the real drivers: the served display's lens array and the camera's scale with
// the lens taken away (bench-control part), then Δ and the part's place with it back, written into the bench of
// the served devices. The served bench is the shipped one: its truth is data/scenes/inspection_bench.toml's.
TEST_F(LfiSimBench, BothCalibrationsRunOverTheRealDriversAndFindTheServedBench) {
  const std::string lfi = shellQuoted(LFI_EXECUTABLE), b = shellQuoted(hil_.string());
  const std::string scenes = (source_ / "data" / "scenes").string();
  const auto r =
      simBench(fmt::format(R"sh({0} -q bench-control part {2}/inspection_bench_empty.toml >/dev/null || exit 10
{0} -q calibrate display {1} --frames 1 || exit 11
{0} -q bench-control part {2}/inspection_bench.toml >/dev/null || exit 12
{0} -q calibrate part {1} --frames 1 --model {2}/inspection_bench.toml || exit 13
)sh",
                           lfi, b, shellQuoted(scenes)));
  ASSERT_EQ(r.status, 0) << r.output;
  const lfi::BenchFile bench = lfi::readBenchFile(hil_);
  // Tolerances (docs/calibration.md): a point at the field's edge (28 px) within a tenth of a pixel; the lens
  // centres at the panel's edge (12.6 mm) within a quarter of a 0.0315 mm panel pixel; Δ within 0.05 / 0.27 mm
  // and the part's place within a tenth of a pixel (0.05 mm).
  const double objectPixel = 0.1215 * (1 / (1 / 20.03 - 1 / 24.9075)) / 24.9075;
  EXPECT_NEAR(bench.objectPixel_mm, objectPixel, objectPixel * 0.1 / 28);
  ASSERT_TRUE(bench.displayOptics);
  EXPECT_NEAR(bench.displayOptics->arrayPitch_mm, 1.0, 0.25 * 0.0315 / 12.6);
  EXPECT_NEAR(bench.distance_mm, 30, 0.05 / 0.27);
  ASSERT_TRUE(bench.partCentre_px);
  EXPECT_NEAR(bench.partCentre_px->x, 27.5, 0.1);
  EXPECT_NEAR(bench.partCentre_px->y, 27.5, 0.1);
}

TEST_F(LfiSimBench, TheProgramsExitStatusIsTheBenchsAndTheEnvironmentNamesTheDevices) {
  const auto r = simBench(
      "echo \"$LFI_SIM_BENCH_CAMERA $LFI_SIM_BENCH_DISPLAY\"; test -S \"$LFI_SIM_BENCH_CONTROL\"; "
      "exit 7");
  EXPECT_EQ(r.status, 7) << r.output;
  EXPECT_NE(r.output.find("aravis:lfi-SimCamera-LFISIM01 usb:1209:4c46/LFI-SIM-0001"), std::string::npos) << r.output;
  const auto killed = simBench("kill -TERM $$");
  EXPECT_EQ(killed.status, 128 + 15) << killed.output;
}

TEST_F(LfiSimBench, RequestsItCannotDoAreRefusedWithTheReasonAndTheBenchGoesOn) {
  std::string scene = readText(source_ / "data" / "scenes" / "inspection_bench.toml");
  scene.replace(scene.find("width = 56"), 10, "width = 64");
  const fs::path otherCamera = folder_.write("other-camera.toml", scene);
  const std::string lfi = shellQuoted(LFI_EXECUTABLE);
  const auto r = simBench(fmt::format(
      "{0} bench-control part {1}; echo \"status $?\"; {0} bench-control juggle; echo \"status $?\"; "
      "{0} bench-control packet-loss 2; echo \"status $?\"; {0} bench-control part /no/such.toml; echo \"status $?\"; "
      "{0} bench-control status",
      lfi, shellQuoted(otherCamera.string())));
  EXPECT_EQ(r.status, 0) << r.output;
  for (const char* expected :
       {"its camera (64 x 56 pixels of 0.1215 mm) is not the bench's (56 x 56", "unknown request 'juggle'",
        "packet-loss '2': a fraction 0..1", "no such scene file '/no/such.toml'", "part "})
    EXPECT_NE(r.output.find(expected), std::string::npos) << expected << "\n" << r.output;
  EXPECT_EQ(r.output.find("status 0"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("inspection_bench.toml; camera serving; display plugged"), std::string::npos)
      << "the intact part stays in place: " << r.output;
}

TEST_F(LfiSimBench, ABenchThatIsNotSimulatedAndAControlSocketNobodyServesAreNamed) {
  const auto notSimulated = runLfi("-q sim-bench " + shellQuoted(hil_.string()) + " -- true");
  EXPECT_EQ(notSimulated.status, 1);
  EXPECT_NE(notSimulated.output.find("is not a simulated bench: its camera ('aravis:lfi-SimCamera-LFISIM01')"),
            std::string::npos)
      << notSimulated.output;
  const auto nobody = runLfi("-q bench-control --socket " + shellQuoted((folder_ / "none.sock").string()) + " status");
  EXPECT_EQ(nobody.status, 1);
  EXPECT_NE(nobody.output.find("is `lfi sim-bench` running?"), std::string::npos) << nobody.output;
  const auto unset = runLfi("-q bench-control status", true, "env -u LFI_SIM_BENCH_CONTROL ");
  EXPECT_EQ(unset.status, 1);
  EXPECT_NE(unset.output.find("LFI_SIM_BENCH_CONTROL is not set"), std::string::npos) << unset.output;
}

}  // namespace
