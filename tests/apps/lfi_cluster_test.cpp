// SPDX-License-Identifier: Apache-2.0
// A sweep on a Slurm cluster (scripts/slurm/study-array.sh, docs/cluster.md),
// against a single-node cluster the test starts: a job array of four shards
// and its merge job give the unsharded sweep's results, also when one task is
// killed mid-run and requeued.

#include "lfi_process.h"
#include "lfi_test_support.h"
#include "slurm_cluster.h"
#include "sweep_outputs.h"
#include "test_folder.h"
#include "text_edit.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <filesystem>
#include <sstream>
#include <thread>

namespace {

namespace fs = std::filesystem;
using lfi::testing_support::runCommand;
using lfi::testing_support::shellQuoted;

// Waits up to `seconds` for `done`, checking every 10 ms.
template <typename Done>
bool waitFor(Done done, int seconds) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(seconds);
  while (!done()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return true;
}

TEST(LfiCluster, AJobArrayOfFourShardsAndItsMergeGiveTheUnshardedSweepWithATaskRequeued) {
  if (!lfi::testing_support::SlurmCluster::available()) LFI_SKIP_WITHOUT_TOOL("no Slurm (Debian: slurm-wlm, munge)");
  lfi::testing_support::TestFolder folder("lfi-cluster");
  // The reference bench at 32 x 32 camera pixels (quick quality), 2 x 4 points of the ideal emitter.
  folder.write("bench.toml", lfi::testing_support::smallStudyBench());
  const fs::path sweep = folder.write("sweep.toml", R"(format = "lfi-sweep"
version = 1
bench = "bench.toml"
setups = ["inverse_schlieren"]
[[axis]]
key = "inverse_schlieren.distance_mm"
values = [25, 30]
[[axis]]
key = "inverse_schlieren.angular"
values = [8, 12, 16, 20]
)");
  const auto whole = lfi::testing_support::runLfi("-q study --sweep " + shellQuoted(sweep.string()) + " --out " +
                                                  shellQuoted((folder.path() / "whole").string()));
  ASSERT_EQ(whole.status, 0) << whole.output;

  lfi::testing_support::SlurmCluster cluster(folder.path() / "slurm");
  const fs::path out = folder.path() / "cluster";
  const auto submitted = runCommand(cluster.environment() + "LFI=" + shellQuoted(LFI_EXECUTABLE) + " " +
                                    shellQuoted(std::string(LFI_SOURCE_DIR) + "/scripts/slurm/study-array.sh") + " " +
                                    shellQuoted(sweep.string()) + " " + shellQuoted(out.string()) + " 4 2>&1");
  ASSERT_EQ(submitted.status, 0) << submitted.output;
  std::istringstream ids(submitted.output);
  std::string array, merge;
  ASSERT_TRUE(ids >> array >> merge) << submitted.output;

  // Task 2 killed once it has written some of its images and before its shard.json, then requeued now (Slurm
  // would hold it back a while); its second run replaces what the first left.
  const fs::path shard2 = out / "shards" / "2";
  const auto midRun = [&] {
    std::error_code ec;
    if (fs::exists(shard2 / "shard.json", ec)) return true;
    for (auto it = fs::recursive_directory_iterator(shard2 / "images", ec);
         !ec && it != fs::recursive_directory_iterator(); it.increment(ec))
      if (it->is_regular_file()) return true;
    return false;
  };
  ASSERT_TRUE(waitFor(midRun, 120)) << "task 2 did not start within 120 s";
  ASSERT_FALSE(fs::exists(shard2 / "shard.json")) << "task 2 finished before it could be killed";
  const auto requeue = runCommand(cluster.environment() + "scontrol requeue " + array + "_2 2>&1");
  ASSERT_EQ(requeue.status, 0) << requeue.output;
  // (once Slurm has ended the first run and holds the task pending: an update before that is refused)
  ASSERT_TRUE(waitFor(
      [&] {
        return runCommand(cluster.environment() + "squeue -h -o %T -j " + array + "_2 2>&1").output.find("PENDING") !=
               std::string::npos;
      },
      60))
      << "task 2 is not pending again after its requeue";
  const auto release = runCommand(cluster.environment() + "scontrol update JobId=" + array + "_2 StartTime=now 2>&1");
  ASSERT_EQ(release.status, 0) << release.output;

  ASSERT_TRUE(waitFor([&] { return fs::exists(out / "sweep" / "study.json"); }, 180))
      << "no merged sweep within 180 s: " << runCommand(cluster.environment() + "squeue 2>&1").output
      << lfi::testing_support::readText(out / "logs" / "merge.log");
  EXPECT_NE(runCommand(cluster.environment() + "scontrol show job " + array + "_2 2>&1").output.find("Restarts=1"),
            std::string::npos)
      << "task 2 was not requeued";
  EXPECT_TRUE(lfi::testing_support::resultsWithoutProvenance(out / "sweep" / "study.json") ==
              lfi::testing_support::resultsWithoutProvenance(folder.path() / "whole" / "study.json"))
      << "the merged study.json differs from the unsharded run's";
  EXPECT_TRUE(lfi::testing_support::sweepImages(out / "sweep") ==
              lfi::testing_support::sweepImages(folder.path() / "whole"))
      << "the images differ";
}

TEST(LfiCluster, TheScriptNamesWhatItCannotSubmit) {
  const std::string script = shellQuoted(std::string(LFI_SOURCE_DIR) + "/scripts/slurm/study-array.sh");
  for (const auto& [arguments, message] :
       {std::pair<std::string, std::string>{"", "usage:"},
        {"/no/such/sweep.toml out 4", "cannot read the sweep file '/no/such/sweep.toml'"},
        {std::string(LFI_SOURCE_DIR) + "/README.md out 0", "N = '0'"},
        {std::string(LFI_SOURCE_DIR) + "/README.md out x", "N = 'x'"}}) {
    const auto run = runCommand("LFI=" + shellQuoted(LFI_EXECUTABLE) + " " + script + " " + arguments + " 2>&1");
    EXPECT_EQ(run.status, 2) << arguments;
    EXPECT_NE(run.output.find(message), std::string::npos) << arguments << ": " << run.output;
  }
}

}  // namespace
