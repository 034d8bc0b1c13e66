// SPDX-License-Identifier: Apache-2.0
// A run's records read back for its summary (readRecordSummary): the keys it
// needs, and records it must refuse by name rather than read wrongly; and the
// summary page made of them (writeRunSummary).

#include "lfi/controller/inspection_record.h"
#include "lfi/controller/run_summary.h"
#include "lfi/core/error.h"

#include "lfi_test_support.h"
#include "test_folder.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <fstream>
#include <iterator>
#include <string>

namespace {

using lfi::Errc;
using lfi::testing_support::throwsError;

const char* kRecord = R"({"format":"lfi-inspection-record","version":1,"part":7,"time_utc":"2026-11-28T15:21:08.926Z",)"
                      R"("status":"inspected","verdict":"fail","defects":[{"centroid_mm":[10.5,-0.25]}]})";

TEST(InspectionRecordSummary, ReadsThePartItsVerdictAndItsDefects) {
  const lfi::RecordSummary s = lfi::readRecordSummary(nlohmann::json::parse(kRecord), "records.jsonl:1");
  EXPECT_EQ(s.part, 7u);
  EXPECT_EQ(s.status, "inspected");
  EXPECT_EQ(s.verdict, "fail");
  ASSERT_EQ(s.defects_mm.size(), 1u);
  EXPECT_EQ(s.defects_mm[0].x, 10.5);
  EXPECT_EQ(s.defects_mm[0].y, -0.25);
  nlohmann::json error = nlohmann::json::parse(kRecord);
  error["status"] = "error";
  error["verdict"] = nullptr;
  EXPECT_EQ(lfi::readRecordSummary(error, "records.jsonl:2").verdict, "");
}

TEST(InspectionRecordSummary, APartThatIsNotAPartNumberIsNamed) {
  // 1e50 was converted to an unsigned integer with undefined behaviour (found by fuzzing).
  for (const char* part : {"1e50", "-1", "2.5", "\"7\"", "null"}) {
    nlohmann::json j = nlohmann::json::parse(kRecord);
    j["part"] = nlohmann::json::parse(part);
    EXPECT_TRUE(throwsError([&] { lfi::readRecordSummary(j, "records.jsonl:3"); }, Errc::InvalidFile,
                            {"records.jsonl:3", "not an inspection record"}))
        << part;
  }
}

TEST(InspectionRecordSummary, AMissingOrMistypedKeyIsNamed) {
  for (const char* key : {"part", "time_utc", "status", "verdict", "defects"}) {
    nlohmann::json j = nlohmann::json::parse(kRecord);
    j.erase(key);
    EXPECT_TRUE(throwsError([&] { lfi::readRecordSummary(j, "records.jsonl:4"); }, Errc::InvalidFile,
                            {"records.jsonl:4", "not an inspection record"}))
        << key;
  }
  nlohmann::json j = nlohmann::json::parse(kRecord);
  j["defects"][0]["centroid_mm"] = "here";
  EXPECT_TRUE(
      throwsError([&] { lfi::readRecordSummary(j, "records.jsonl:5"); }, Errc::InvalidFile, {"records.jsonl:5"}));
}

// The summary page's map places a defect at the edge of the doubles' range in its corner bin: no bin number from
// an overflow (the run_summary fuzz target's input fuzz/corpus/run_summary/regression-defect-far-out.jsonl:
// 1.7e308 + 1.7e308 overflowed, and the NaN of infinity over infinity was converted to an int).
TEST(RunSummary, ADefectFarOutIsMappedWithoutOverflow) {
  const lfi::testing_support::TestFolder folder("lfi-run-summary-far-out");
  const auto records =
      folder.write("records.jsonl", R"({"part":1,"time_utc":"t","status":"inspected","verdict":"fail",)"
                                    R"("defects":[{"centroid_mm":[1.7e308,-1.7e308]},{"centroid_mm":[0,0]}]})"
                                    "\n");
  const lfi::RunCounts counts = lfi::writeRunSummary(records, folder / "summary.html", false);
  EXPECT_EQ(counts.failed, 1);
  std::ifstream in(folder / "summary.html");
  const std::string page((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(page.find(R"(<rect x="310.0" y="310.0")"), std::string::npos) << page;
  EXPECT_NE(page.find(R"(<rect x="160.0" y="160.0")"), std::string::npos) << page;
}

}  // namespace
