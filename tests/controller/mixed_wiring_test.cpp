// SPDX-License-Identifier: Apache-2.0
// The inspection loop with one device behind its real driver and the other
// simulated, in one process: the served bench (emulation/served_bench.h) puts
// the ray-traced camera on the network and the display on the emulated USB
// bus, and the loop drives (1) the aravis: camera with the sim: display, and
// (2) the sim: camera with the usb: display, each against the loop with both
// devices sim: — capture, emit and inspect on the study's defect parts, for
// the simulated sensor's reference and the coded one. A sim: device shares the
// served bench's scene (one SimBench per scene file in a process), so what one
// device does the other sees.

#include "gige_device_process.h"
#include "lfi_test_support.h"
#include "study_parts.h"
#include "test_folder.h"
#include "text_edit.h"

#include "lfi/controller/bench_devices.h"
#include "lfi/controller/coded_capture.h"
#include "lfi/controller/inspector.h"
#include "lfi/controller/reference_capture.h"
#include "lfi/controller/run.h"
#include "lfi/drivers/builtin_backends.h"
#include "lfi/emulation/served_bench.h"
#include "lfi/sim/devices/sim_camera.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <memory>
#include <ostream>
#include <string>
#include <tuple>
#include <vector>

namespace lfi {
namespace {

namespace fs = std::filesystem;
using testing_support::readText;
using testing_support::StudyPart;
using testing_support::studyParts;

enum class Wiring { AllSim, ServedCamera, ServedDisplay, AllServed };
void PrintTo(Wiring w, std::ostream* os) {
  *os << (w == Wiring::AllSim         ? "sim: camera and display"
          : w == Wiring::ServedCamera ? "aravis: camera, sim: display"
          : w == Wiring::AllServed    ? "aravis: camera, usb: display"
                                      : "sim: camera, usb: display");
}

struct Outcome {
  bool pass = false;
  std::vector<Vec2> defects_mm;
};

// Param: the wiring, and the reference's capture ("sim" or "coded").
class MixedWiring : public testing::TestWithParam<std::tuple<Wiring, std::string>> {
 protected:
  static void SetUpTestSuite() {
    emulation::usePrivateTmpDir();
    registerDriverBackends();
    sim::registerSimBackends();
    registerControllerBackends();
  }

  void SetUp() override {
    if (!emulation::umockdevPreloadActive()) GTEST_FAIL() << "run under umockdev's preload (run_with_umockdev.sh)";
    const std::string text = readText(source_ / "data" / "scenes" / "inspection_bench.toml");
    for (const StudyPart& part : studyParts())
      scenes_[part.name] = folder_.write(part.name + ".toml", testing_support::studyPartScene(text, part));
    served_ = std::make_unique<emulation::ServedBench>(emulation::ServedBenchOptions{.scene = scenes_["intact"]});
  }

  // The bench with the part of `scene` in place: the served devices by their URIs, the simulated ones on `scene`;
  // `more` after its tables.
  BenchFile bench(Wiring wiring, const std::string& capture, const fs::path& scene,
                  const std::string& more = "") const {
    const std::string sim = "sim:" + scene.string();
    const bool servedCamera = wiring == Wiring::ServedCamera || wiring == Wiring::AllServed;
    return readBenchFile(folder_.write(
        "bench.toml",
        fmt::format(R"(format = "lfi-inspection-bench"
version = 1
[camera]
uri = "{0}"
exposure_us = 10000
pixel_format = "{1}"
object_pixel_mm = 0.5
dn_per_electron = {2}
read_noise_dn = {3}
[display]
uri = "{4}"
[capture]
uri = "{5}"
[geometry]
distance_mm = 30
part_centre_px = [27.5, 27.5]
[reference]
folder = "reference"
mask_radius_mm = 12.2
[inspection]
smallest_defect_mm = 1.0
closing_mm = 0.5
[output]
folder = "out"
{6}
)",
                    servedCamera ? served_->cameraUri().text() : sim,
                    // The served camera's format is Mono16 (the scene's 12 bits x 16); the sim: camera's Mono12.
                    servedCamera ? "Mono16" : "Mono12", servedCamera ? 6.24 : 0.39, servedCamera ? 15.7 : 0.98,
                    wiring == Wiring::ServedDisplay || wiring == Wiring::AllServed ? served_->displayUri().text() : sim,
                    capture == "coded" ? std::string("coded:")
                                       : DeviceUri{.scheme = "sim", .path = scenes_.at("intact").string()}.text(),
                    more)));
  }

  // The reference with the intact part.
  ReferencePackage reference(Wiring wiring, const std::string& capture) {
    served_->putPart(scenes_.at("intact"));
    const BenchFile b = bench(wiring, capture, scenes_.at("intact"));
    auto c = openBenchCapture(b);
    auto display = openBenchDisplay(b);
    auto camera = openBenchCamera(b);
    return takeReference(b, *c, *display, *camera);
  }

  // Capture → emit → inspect: the reference with the intact part, then each part of the study in turn.
  std::map<std::string, Outcome> loop(Wiring wiring, const std::string& capture) {
    const ReferencePackage package = reference(wiring, capture);
    std::map<std::string, Outcome> out;
    for (const StudyPart& part : studyParts()) {
      served_->putPart(scenes_.at(part.name));
      const BenchFile b = bench(wiring, capture, scenes_.at(part.name));
      auto display = openBenchDisplay(b);
      auto camera = openBenchCamera(b);
      Inspector inspector(b, package, *display, *camera);
      inspector.showReference();
      const PartInspection result = inspector.inspectPart();
      Outcome& o = out[part.name];
      o.pass = result.verdict.pass;
      for (const PartDefect& d : result.verdict.defects) o.defects_mm.push_back(d.centroid_mm);
    }
    return out;
  }

  static testing_support::Centroids centroids(const Outcome& o) {
    testing_support::Centroids found;
    for (const Vec2& d : o.defects_mm) found.emplace_back(d.x, d.y);
    return found;
  }

  static double nearest(const Outcome& o, double x, double y, Vec2* which) {
    double best = 1e9;
    for (const Vec2& d : o.defects_mm)
      if (const double r = std::hypot(d.x - x, d.y - y); r < best) best = r, *which = d;
    return best;
  }

  const fs::path source_ = LFI_SOURCE_DIR;
  testing_support::LoopbackGigeLock lock_;  // (the served camera takes 127.0.0.1:3956)
  testing_support::TestFolder folder_{"lfi-mixed-wiring"};
  std::map<std::string, fs::path> scenes_;
  std::unique_ptr<emulation::ServedBench> served_;
};

INSTANTIATE_TEST_SUITE_P(Wirings, MixedWiring,
                         testing::Combine(testing::Values(Wiring::ServedCamera, Wiring::ServedDisplay),
                                          testing::Values("sim", "coded")),
                         [](const testing::TestParamInfo<std::tuple<Wiring, std::string>>& p) {
                           return std::string(std::get<0>(p.param) == Wiring::ServedCamera ? "AravisCameraSimDisplay"
                                                                                           : "SimCameraUsbDisplay") +
                                  (std::get<1>(p.param) == "sim" ? "SimulatedSensor" : "Coded");
                         });

// As tests/apps/lfi_hil_loop_test.cpp: the verdicts agree and are the truth; each localised defect is
// found where it is and nothing beside it, and the two wirings place it within a pixel of each other (the same radiance
// through the same detector; only the noise draw and the quantisation differ).
TEST_P(MixedWiring, OneRealDriverGivesTheVerdictsAndDefectsOfTheSimulatedLoop) {
  const auto [wiring, capture] = GetParam();
  const auto simulated = loop(Wiring::AllSim, capture);
  const auto mixed = loop(wiring, capture);
  for (const StudyPart& part : studyParts()) {
    SCOPED_TRACE(part.name);
    const Outcome &a = simulated.at(part.name), &b = mixed.at(part.name);
    EXPECT_EQ(a.pass, part.intact);
    EXPECT_EQ(b.pass, a.pass);
    EXPECT_EQ(testing_support::misplacedDefects(part, centroids(a)), "") << "simulated";
    EXPECT_EQ(testing_support::misplacedDefects(part, centroids(b)), "") << "mixed";
    for (const auto& [x, y] : part.defects_mm) {
      Vec2 da{1e9, 1e9}, db{-1e9, -1e9};
      nearest(a, x, y, &da);
      nearest(b, x, y, &db);
      EXPECT_LE(std::hypot(da.x - db.x, da.y - db.y), testing_support::kInspectionPixel_mm)
          << "(" << da.x << ", " << da.y << ") against (" << db.x << ", " << db.y << ")";
    }
  }
  const auto counts = served_->counters();
  // (and the served device took part)
  EXPECT_GT(wiring == Wiring::ServedCamera ? counts.framesServed : counts.panelsPresented, 0u);
}

// [output.line] on the served camera, through Aravis: a run of intact and defect parts raises the camera's
// UserOutput0 on Line1 at each failed part's verdict (high in the device's registers while its record is written)
// and lowers it before the next part; a passed part leaves it low. So it toggles once per failed part.
class RejectLineOnTheServedCamera : public MixedWiring {};

TEST_F(RejectLineOnTheServedCamera, TogglesOncePerFailedPart) {
  // (both devices served, so that the parts change under the devices the run keeps open)
  const ReferencePackage package = reference(Wiring::AllServed, "sim");
  std::string defect;
  for (const StudyPart& part : studyParts())
    if (!part.intact && defect.empty()) defect = part.name;
  const std::vector<std::string> parts = {"intact", defect, defect, "intact", defect, "intact"};
  const BenchFile b = bench(Wiring::AllServed, "sim", scenes_.at("intact"),
                            "[output.line]\nline = \"Line1\"\nuser_output = \"UserOutput0\"\npulse_ms = 5\n");
  served_->putPart(scenes_.at(parts[0]));
  RunOptions o;
  o.folder = folder_.path() / "run";
  o.parts = static_cast<long>(parts.size());
  std::vector<bool> failed, highAtRecord, highAfterPart;
  o.onRecord = [&](const InspectionRecord& r) {
    ASSERT_TRUE(r.verdict.has_value()) << r.error;
    failed.push_back(!r.verdict->pass);
    highAtRecord.push_back(served_->cameraUserOutput(0));
    if (r.part < parts.size()) served_->putPart(scenes_.at(parts[r.part]));
  };
  o.onPart = [&](const RunCounts&, double) { highAfterPart.push_back(served_->cameraUserOutput(0)); };
  const RunResult r = runParts(b, b, package, o);
  EXPECT_EQ(served_->cameraLineSource(1), "UserOutput0");
  ASSERT_EQ(failed.size(), parts.size());
  ASSERT_EQ(highAfterPart.size(), parts.size());
  for (std::size_t i = 0; i < parts.size(); ++i) {
    SCOPED_TRACE(i + 1);
    EXPECT_EQ(failed[i], parts[i] != "intact");
    EXPECT_EQ(highAtRecord[i], failed[i]);
    EXPECT_FALSE(highAfterPart[i]);
  }
  EXPECT_EQ(r.counts.failed, 3);
}

}  // namespace
}  // namespace lfi
