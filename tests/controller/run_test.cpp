// SPDX-License-Identifier: Apache-2.0
// The controller's run (run.h) on the ray-traced bench: its records and
// summary, and device loss ridden out with the doubling back-off or ending
// the run, through a camera backend that drops out when told to. The
// back-off's pauses are recorded, not slept.

#include "lfi/controller/run.h"
#include "forwarding_camera.h"
#include "lfi/drivers/camera_registry.h"
#include "lfi/sim/devices/sim_camera.h"
#include "lfi_test_support.h"
#include "quick_run_bench.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <atomic>
#include <fstream>

namespace lfi {
namespace {

namespace fs = std::filesystem;
using testing_support::TestFolder;
using testing_support::throwsError;

// What the "test-flaky" cameras do: vanish at a grab, then refuse to open a number of times.
struct Flakiness {
  std::atomic<int> grabsLeft{-1};    // grabs before the camera vanishes (-1: never)
  std::atomic<int> refusedOpens{0};  // opens refused after that (-1: every one)
};
Flakiness flaky;

// The sim: camera of the same scene, failing as `flaky` says (a camera pulled off the network and plugged back).
class FlakyCamera final : public testing_support::ForwardingCamera {
 public:
  using ForwardingCamera::ForwardingCamera;
  void grabInto(Frame& frame, std::chrono::milliseconds timeout) override {
    if (flaky.grabsLeft.load() == 0) {
      inner().close();
      fail(Errc::Device, "test-flaky camera: gone from the network");
    }
    if (flaky.grabsLeft.load() > 0) --flaky.grabsLeft;
    inner().grabInto(frame, timeout);
  }
};

void registerFlakyCamera() {
  backendRegistry<Camera>().addOnce(CameraBackend{
      .scheme = "test-flaky",
      .description = "test-flaky:<scene-file>  the sim: camera, failing as the test says",
      .factory = [](const DeviceUri& uri) -> std::unique_ptr<Camera> {
        if (flaky.grabsLeft.load() == 0 && flaky.refusedOpens.load() != 0) {
          if (flaky.refusedOpens.load() > 0) --flaky.refusedOpens;
          fail(Errc::NotFound, "test-flaky camera '{}': not on the network", uri.path);
        }
        if (flaky.grabsLeft.load() == 0) flaky.grabsLeft = -1;  // back for good
        return std::make_unique<FlakyCamera>(openCamera(DeviceUri{.scheme = "sim", .path = uri.path}));
      },
  });
}

class RunTest : public ::testing::Test {
 protected:
  // The shipped simulated bench with a quick reference, its camera the flaky one.
  static void SetUpTestSuite() {
    sim::registerSimBackends();
    registerFlakyCamera();
    folder_ = new TestFolder("lfi-run");
    benchText_ = new std::string(testing_support::quickRunBenchText("test-flaky"));
    package_ = new ReferencePackage(testing_support::quickRunReference(*folder_, *benchText_));
  }
  static void TearDownTestSuite() {
    delete package_;
    delete benchText_;
    delete folder_;
  }
  void SetUp() override {
    flaky.grabsLeft = -1;
    flaky.refusedOpens = 0;
  }

  // The bench with `[run]` as given.
  BenchFile bench(const std::string& run) const {
    const std::string name = ::testing::UnitTest::GetInstance()->current_test_info()->name();
    return readBenchFile(folder_->write(name + ".toml", *benchText_ + "\n[run]\n" + run + "\n"));
  }

  RunOptions options(long parts) {
    RunOptions o;
    o.folder = folder_->path() / ::testing::UnitTest::GetInstance()->current_test_info()->name();
    o.parts = parts;
    o.pause = [this](std::chrono::milliseconds p) { pauses_.push_back(p.count()); };
    o.onPart = [this](const RunCounts& c, double) { seen_.push_back(c); };
    return o;
  }

  // The run's records, one JSON object per line.
  static std::vector<nlohmann::json> records(const fs::path& file) {
    std::vector<nlohmann::json> out;
    std::ifstream in(file);
    for (std::string line; std::getline(in, line);) out.push_back(nlohmann::json::parse(line));
    return out;
  }

  static TestFolder* folder_;
  static std::string* benchText_;
  static ReferencePackage* package_;
  std::vector<long> pauses_;
  std::vector<RunCounts> seen_;
};

TestFolder* RunTest::folder_ = nullptr;
std::string* RunTest::benchText_ = nullptr;
ReferencePackage* RunTest::package_ = nullptr;

TEST_F(RunTest, EveryPartIsRecordedInOrderAndSummarised) {
  const BenchFile b = bench("on_device_loss = \"stop\"");
  const RunResult r = runParts(b, b, *package_, options(4));
  EXPECT_EQ(r.counts.parts, 4);
  EXPECT_EQ(r.counts.passed + r.counts.failed, 4);
  EXPECT_EQ(r.counts.errors, 0);
  const auto lines = records(r.records);
  ASSERT_EQ(lines.size(), 4u);
  for (std::size_t i = 0; i < lines.size(); ++i) {
    EXPECT_EQ(lines[i]["part"], i + 1);
    EXPECT_TRUE(lines[i].contains("verdict"));
  }
  ASSERT_EQ(seen_.size(), 4u);
  for (std::size_t i = 0; i < seen_.size(); ++i) EXPECT_EQ(seen_[i].parts, static_cast<long>(i + 1));
  EXPECT_TRUE(fs::is_regular_file(r.page));
  EXPECT_TRUE(pauses_.empty());
  // A run's folder is its own: a second run into it is refused before any part.
  EXPECT_TRUE(throwsError([&] { runParts(b, b, *package_, options(1)); }, Errc::Io, {"records.jsonl"}));
}

TEST_F(RunTest, ADeviceLostMidRunIsWaitedForWithADoublingBackOff) {
  const BenchFile b = bench("on_device_loss = \"wait\"\nwait_limit_s = 60");
  flaky.grabsLeft = 2;     // gone after two frames
  flaky.refusedOpens = 2;  // back at the third try
  const RunResult r = runParts(b, b, *package_, options(5));
  EXPECT_EQ((std::vector<long>{500, 1000, 2000}), pauses_);
  EXPECT_EQ(r.counts.parts, 5);
  EXPECT_EQ(r.counts.errors, 1);
  const auto lines = records(r.records);
  ASSERT_EQ(lines.size(), 5u);
  // One part is recorded as not inspected, with the device's reason; the parts before and after it are judged.
  int errors = 0;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    EXPECT_EQ(lines[i]["part"], i + 1);
    if (!lines[i].contains("error")) continue;
    ++errors;
    EXPECT_NE(lines[i]["error"].get<std::string>().find("gone from the network"), std::string::npos) << lines[i];
    EXPECT_LT(i, 4u);  // the run went on after it
  }
  EXPECT_EQ(errors, 1);
}

TEST_F(RunTest, ADeviceThatDoesNotComeBackEndsTheRunAtTheWaitLimit) {
  const BenchFile b = bench("on_device_loss = \"wait\"\nwait_limit_s = 10");
  flaky.grabsLeft = 1;
  flaky.refusedOpens = -1;
  EXPECT_TRUE(throwsError([&] { runParts(b, b, *package_, options(5)); }, Errc::Device,
                          {"did not come back within 10 s", "not on the network"}));
  // 0.5 + 1 + 2 + 4 s waited; 8 s more would pass the limit.
  EXPECT_EQ((std::vector<long>{500, 1000, 2000, 4000}), pauses_);
  const fs::path folder = folder_->path() / "ADeviceThatDoesNotComeBackEndsTheRunAtTheWaitLimit";
  const auto lines = records(folder / "records.jsonl");
  ASSERT_FALSE(lines.empty());
  EXPECT_TRUE(lines.back().contains("error"));
  EXPECT_TRUE(fs::is_regular_file(folder / "summary.html"));
}

TEST_F(RunTest, ADeviceLostStopsARunThatDoesNotWait) {
  const BenchFile b = bench("on_device_loss = \"stop\"");
  flaky.grabsLeft = 1;
  EXPECT_TRUE(throwsError([&] { runParts(b, b, *package_, options(5)); }, Errc::Device,
                          {"could not be inspected", "gone from the network", "records.jsonl"}));
  EXPECT_TRUE(pauses_.empty());
  const auto lines = records(folder_->path() / "ADeviceLostStopsARunThatDoesNotWait" / "records.jsonl");
  ASSERT_FALSE(lines.empty());
  EXPECT_TRUE(lines.back().contains("error"));
  for (std::size_t i = 0; i + 1 < lines.size(); ++i) EXPECT_FALSE(lines[i].contains("error"));
}

TEST_F(RunTest, AStopRequestEndsTheRunAfterThePartInHand) {
  const BenchFile b = bench("on_device_loss = \"wait\"");
  RunOptions o = options(0);
  o.stopRequested = [this] { return seen_.size() >= 2; };
  const RunResult r = runParts(b, b, *package_, o);
  EXPECT_EQ(r.counts.parts, 2);
  // While waiting for the devices, a stop ends the run as cancelled.
  flaky.grabsLeft = 1;
  flaky.refusedOpens = -1;
  RunOptions waiting = options(5);
  waiting.folder += "-waiting";
  waiting.stopRequested = [this] { return !pauses_.empty(); };
  EXPECT_TRUE(throwsError([&] { runParts(b, b, *package_, waiting); }, Errc::Cancelled, {"stopped while waiting"}));
}

}  // namespace
}  // namespace lfi
