// SPDX-License-Identifier: Apache-2.0
// Sweep files and their shards (sweep_file.h, grid_sweep.h): the grid's
// points and their benches, a sweep's results the same whether computed
// whole or as 1, 3 or 7 shards merged (study.json less provenance, every
// image byte for byte), and the named refusals of bad files and of shards
// that do not make one sweep.

#include "lfi/study/grid_sweep.h"
#include "lfi/study/sweep_file.h"

#include "lfi_test_support.h"
#include "sweep_outputs.h"
#include "test_folder.h"
#include "text_edit.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>

namespace lfi::study {
namespace {

namespace fs = std::filesystem;
using testing_support::TestFolder;
using testing_support::throwsError;

// A sweep of 2 x 3 points over Δ and the display's pitch, inverse schlieren only.
std::string smallSweep(std::uint64_t seed = 3) {
  return fmt::format(R"(format = "lfi-sweep"
version = 1
bench = "bench.toml"
quality = "quick"
seed = {}
setups = ["inverse_schlieren"]
[[axis]]
key = "inverse_schlieren.distance_mm"
values = [25, 30]
[[axis]]
key = "inverse_schlieren.angular"
from = 8
to = 16
steps = 3
)",
                     seed);
}

TEST(SweepFile, TheGridIsEveryCombinationTheFirstAxisSlowest) {
  TestFolder folder("lfi-sweep-file");
  folder.write("bench.toml", testing_support::smallStudyBench());
  const SweepFile s = readSweepFile(folder.write("sweep.toml", smallSweep()));
  ASSERT_EQ(s.pointCount(), 6u);
  EXPECT_EQ(s.axes[1].values, (std::vector<double>{8, 12, 16}));
  const std::vector<std::pair<double, double>> expected = {{25, 8}, {25, 12}, {25, 16}, {30, 8}, {30, 12}, {30, 16}};
  for (std::size_t k = 0; k < 6; ++k) {
    const auto values = s.point(k);
    EXPECT_EQ(values[0].value, expected[k].first);
    EXPECT_EQ(values[1].value, expected[k].second);
    // The point's bench has them (Bench::load's own reading).
    const Bench b = sweepBench(s, k);
    EXPECT_EQ(b.inverseSchlieren.distance_mm, expected[k].first);
    EXPECT_EQ(b.inverseSchlieren.angular, expected[k].second);
  }
  EXPECT_EQ(s.setups, (std::vector<std::string>{"inverse_schlieren"}));
  // Shards: disjoint, together every point, whatever N.
  for (int n : {1, 2, 4, 7}) {
    std::vector<int> seen(6, 0);
    for (int i = 1; i <= n; ++i)
      for (std::size_t k : shardPoints(6, {i, n})) ++seen[k];
    EXPECT_EQ(seen, std::vector<int>(6, 1)) << n << " shards";
  }
  // The identity follows what the results depend on: the seed, an axis, the bench's bytes.
  const std::string identity = s.identity;
  EXPECT_NE(readSweepFile(folder.write("sweep.toml", smallSweep(4))).identity, identity);
  folder.write("bench.toml", testing_support::smallStudyBench() + "\n# a comment\n");
  EXPECT_NE(readSweepFile(folder.write("sweep.toml", smallSweep())).identity, identity);
}

TEST(SweepFile, ABadFileIsNamedByItsKeyAndABadPointByItsValues) {
  TestFolder folder("lfi-sweep-bad");
  folder.write("bench.toml", testing_support::smallStudyBench());
  const auto refused = [&](const std::string& from, const std::string& to, Errc code,
                           std::initializer_list<std::string> fragments) {
    std::string text = smallSweep();
    testing_support::replaceOnce(text, from, to);
    const fs::path file = folder.write("sweep.toml", text);
    return throwsError([&] { readSweepFile(file); }, code, fragments);
  };
  EXPECT_TRUE(refused("\"inverse_schlieren.distance_mm\"", "\"inverse_schlieren.distance\"", Errc::Config,
                      {"point 0", "has no number 'inverse_schlieren.distance'"}));
  EXPECT_TRUE(refused("\"inverse_schlieren.distance_mm\"", "\"display.optics\"", Errc::Config,
                      {"has no number 'display.optics'"}));
  EXPECT_TRUE(refused("to = 16\nsteps = 3", "to = 16\nsteps = 4", Errc::Config,
                      {"point 1", "the whole number 'inverse_schlieren.angular' cannot be set to 10.6"}));
  EXPECT_TRUE(refused("values = [25, 30]", "values = [25, 25]", Errc::Config, {"axis 1", "repeats a value"}));
  EXPECT_TRUE(refused("values = [25, 30]", "values = [25, 30]\nfrom = 1", Errc::Config, {"either values"}));
  EXPECT_TRUE(refused("setups = [\"inverse_schlieren\"]", "setups = [\"schlieren\"]", Errc::Config,
                      {"setups", "'schlieren' is not one of"}));
  EXPECT_TRUE(refused("bench = \"bench.toml\"", "bench = \"none.toml\"", Errc::NotFound, {"none.toml"}));
  // A point whose bench cannot be: named with its values, before any work.
  EXPECT_TRUE(refused("values = [25, 30]", "values = [25, -30]", Errc::Config,
                      {"point 3", "inverse_schlieren.distance_mm = -30", "distance_mm"}));
  // No axis at all.
  const std::string noAxis = smallSweep().substr(0, smallSweep().find("[[axis]]"));
  const fs::path file = folder.write("sweep.toml", noAxis);
  EXPECT_TRUE(throwsError([&] { readSweepFile(file); }, Errc::Config, {"no [[axis]]"}));
  EXPECT_TRUE(throwsError([] { parseShard("4/3"); }, Errc::InvalidArgument, {"4/3"}));
  EXPECT_TRUE(throwsError([] { parseShard("1/x"); }, Errc::InvalidArgument, {"1/x"}));
}

class SweepShards : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    folder_ = new TestFolder("lfi-sweep-shards");
    folder_->write("bench.toml", testing_support::smallStudyBench());
    sweep_ = new SweepFile(readSweepFile(folder_->write("sweep.toml", smallSweep())));
    SweepOptions whole;
    runSweep(*sweep_, folder_->path() / "whole", whole);
  }
  static void TearDownTestSuite() {
    delete sweep_;
    delete folder_;
  }

  // The sweep as n shards, each into a folder of its own; the folders.
  static std::vector<fs::path> shards(int n, const std::string& name) {
    std::vector<fs::path> folders;
    for (int i = 1; i <= n; ++i) {
      SweepOptions o;
      o.shard = SweepShard{i, n};
      folders.push_back(folder_->path() / fmt::format("{}-{}-of-{}", name, i, n));
      runSweep(*sweep_, folders.back(), o);
    }
    return folders;
  }

  static TestFolder* folder_;
  static SweepFile* sweep_;
};

TestFolder* SweepShards::folder_ = nullptr;
SweepFile* SweepShards::sweep_ = nullptr;

TEST_F(SweepShards, MergedShardsAreTheWholeRunWhateverTheirNumber) {
  const fs::path whole = folder_->path() / "whole";
  const auto wholeJson = testing_support::resultsWithoutProvenance(whole / "study.json");
  ASSERT_EQ(wholeJson["points"].size(), 6u);
  const auto wholeImages = testing_support::sweepImages(whole);
  ASSERT_EQ(wholeImages.size(), 6u * 7 * 3);  // each point's seven scenes: EXR, PNG and difference
  for (int n : {1, 3, 7}) {
    SCOPED_TRACE(fmt::format("{} shards", n));
    const fs::path merged = folder_->path() / fmt::format("merged-{}", n);
    mergeSweepShards(merged, shards(n, "s"), false);
    EXPECT_TRUE(testing_support::resultsWithoutProvenance(merged / "study.json") == wholeJson)
        << "study.json differs from the whole run's";
    EXPECT_TRUE(testing_support::sweepImages(merged) == wholeImages) << "the images differ from the whole run's";
    // (even the provenance here: the same sweep file)
    EXPECT_TRUE(testing_support::readText(merged / "study.json") == testing_support::readText(whole / "study.json"));
  }
  // The answers are the points' own verdicts.
  for (const auto& [defect, points] : wholeJson["answers"]["detected_at"]["inverse_schlieren"].items())
    for (const auto& k : points)
      EXPECT_EQ(wholeJson["points"][k.get<std::size_t>()]["setups"]["inverse_schlieren"]["verdicts"][defect],
                "detected");
}

TEST_F(SweepShards, ShardsThatDoNotMakeOneSweepAreNamedAndNothingIsMerged) {
  const std::vector<fs::path> three = shards(3, "bad");
  const fs::path out = folder_->path() / "refused";
  const auto refused = [&](const std::vector<fs::path>& folders, Errc code,
                           std::initializer_list<std::string> fragments) {
    const bool named = throwsError([&] { mergeSweepShards(out, folders, false); }, code, fragments);
    return named && !fs::exists(out / "study.json") && !fs::exists(out / "images");
  };
  EXPECT_TRUE(refused({three[0], three[2]}, Errc::InvalidArgument, {"shard 2/3", "missing"}));
  EXPECT_TRUE(refused({three[0], three[1], three[1], three[2]}, Errc::InvalidArgument,
                      {"shard 2/3 is given twice", three[1].string()}));
  // Another sweep's shard (another seed).
  TestFolder other("lfi-sweep-other");
  other.write("bench.toml", testing_support::smallStudyBench());
  SweepOptions o;
  o.shard = SweepShard{2, 3};
  runSweep(readSweepFile(other.write("sweep.toml", smallSweep(9))), other.path() / "s2", o);
  EXPECT_TRUE(refused({three[0], other.path() / "s2", three[2]}, Errc::InvalidFile,
                      {"different sweeps", three[0].string(), (other.path() / "s2").string()}));
  // A shard of another lfi version.
  std::string record = testing_support::readText(three[1] / "shard.json");
  testing_support::replaceOnce(record, fmt::format("\"lfi_version\": \"{}\"", lfiVersion()),
                               "\"lfi_version\": \"0.0.1\"");
  const fs::path old = folder_->path() / "old";
  fs::create_directories(old);
  fs::copy(three[1], old, fs::copy_options::recursive | fs::copy_options::overwrite_existing);
  std::ofstream(old / "shard.json") << record;
  EXPECT_TRUE(refused({three[0], old, three[2]}, Errc::InvalidFile, {old.string(), "lfi 0.0.1"}));
  // A folder that is no shard, and a shard whose file is cut short.
  EXPECT_TRUE(refused({three[0], folder_->path(), three[2]}, Errc::InvalidFile, {"holds no shard.json"}));
  std::ofstream(old / "shard.json") << record.substr(0, record.size() / 2);
  EXPECT_TRUE(refused({three[0], old, three[2]}, Errc::InvalidFile, {"cannot be read", "shard.json"}));
  // A shard's folder written again replaces its own files only, and a merge into a folder with results
  // is refused unless asked.
  SweepOptions again;
  again.shard = SweepShard{2, 3};
  EXPECT_TRUE(throwsError([&] { runSweep(*sweep_, three[1], again); }, Errc::Exists, {"shard.json"}));
  again.overwrite = true;
  runSweep(*sweep_, three[1], again);
  mergeSweepShards(out, three, false);
  EXPECT_TRUE(throwsError([&] { mergeSweepShards(out, three, false); }, Errc::Exists, {"study.json"}));
}

}  // namespace
}  // namespace lfi::study
