// SPDX-License-Identifier: Apache-2.0
// A run's records read back for its summary (readRecordSummary): the keys it
// needs, and records it must refuse by name rather than read wrongly.

#include "lfi/controller/inspection_record.h"
#include "lfi/core/error.h"

#include "lfi_test_support.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

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

}  // namespace
