// SPDX-License-Identifier: Apache-2.0
// Editing a bench file's values in place (what the calibrations write), the
// [display.optics] table it adds, and publishing a calibration: the file
// replaced atomically with its previous text and a record kept beside it,
// nothing replaced when anything is wrong.

#include "lfi/controller/bench_file_edit.h"

#include "bench_file_fixture.h"
#include "text_edit.h"

#include <gtest/gtest.h>

namespace lfi::bench_file_test {
namespace {

using lfi::testing_support::readText;

class BenchFileEditTest : public BenchFileTest {};

TEST_F(BenchFileEditTest, AValueIsReplacedWhereItStandsAndEverythingElseIsKept) {
  const std::string text = replaced(kBench, "object_pixel_mm = 0.5", "object_pixel_mm = 0.5    # 0.1215 / 0.243 µm");
  BenchFileEdit edit(write(text));
  edit.set("camera", "object_pixel_mm", "0.4991");
  EXPECT_EQ(edit.text(), replaced(text, "object_pixel_mm = 0.5 ", "object_pixel_mm = 0.4991 "));
  // With a comment, the line's comment is replaced.
  edit.set("camera", "object_pixel_mm", "0.4992", "calibrated");
  EXPECT_EQ(edit.text(),
            replaced(text, "object_pixel_mm = 0.5    # 0.1215 / 0.243 µm", "object_pixel_mm = 0.4992  # calibrated"));
  EXPECT_EQ(edit.original(), text);
  const int line = lineOf(text, "object_pixel_mm");
  EXPECT_EQ(edit.changes(), fmt::format("- {:4} | object_pixel_mm = 0.5    # 0.1215 / 0.243 µm\n"
                                        "+ {:4} | object_pixel_mm = 0.4992  # calibrated\n",
                                        line, line));
}

TEST_F(BenchFileEditTest, AKeyOfTheFilesOwnGoesAfterItsLastOneBeforeAnyTable) {
  BenchFileEdit edit(write(kBench));
  edit.set("", "coverage_factor", "2", "k of every <key>_u");
  EXPECT_EQ(edit.text(), replaced(kBench, "version = 1\n", "version = 1\ncoverage_factor = 2  # k of every <key>_u\n"));
  edit.set("", "coverage_factor", "3");
  EXPECT_EQ(edit.text(), replaced(kBench, "version = 1\n", "version = 1\ncoverage_factor = 3  # k of every <key>_u\n"));
}

TEST_F(BenchFileEditTest, AKeyIsRemovedWithItsLineAndNothingElse) {
  const std::string text = replaced(kBench, "object_pixel_mm = 0.5", "object_pixel_mm = 0.5    # calibrated");
  BenchFileEdit edit(write(text));
  edit.remove("camera", "object_pixel_mm");
  EXPECT_EQ(edit.text(), replaced(text, "object_pixel_mm = 0.5    # calibrated\n", ""));
  edit.remove("camera", "object_pixel_mm");  // absent: nothing
  edit.remove("nowhere", "object_pixel_mm");
  EXPECT_EQ(edit.text(), replaced(text, "object_pixel_mm = 0.5    # calibrated\n", ""));
  // A key that shares its line is left for a person.
  BenchFileEdit inline_(write(replaced(kBench, "[output]\n", "[output]\nx = { a = 1 }\n")));
  EXPECT_TRUE(throwsError([&] { inline_.remove("output.x", "a"); }, Errc::InvalidArgument, {"output.x.a", "by hand"}));
}

TEST_F(BenchFileEditTest, ValuesAfterTextOfManyBytesPerCharacterAndOverLinesAreFound) {
  // toml++ counts columns in characters: "µ" and "Δ" take two bytes each.
  const std::string text =
      replaced(kBench, "part_centre_px = [27.5, 27.5]", "\"Δµ\" = 1\npart_centre_px = [27.5,\n    27.5]  # the axis");
  BenchFileEdit edit(write(text));
  edit.set("geometry", "part_centre_px", "[28, 26.5]");
  EXPECT_EQ(edit.text(), replaced(text, "[27.5,\n    27.5]", "[28, 26.5]"));
}

TEST_F(BenchFileEditTest, AMissingKeyGoesAfterItsTablesLastKeyAndAMissingTableAfterItsParents) {
  BenchFileEdit edit(write(kBench));
  edit.set("display", "settle_ms", "20");
  edit.set("display.optics", "optics", "\"lenslet_array\"", "stated");
  edit.set("display.optics", "array_pitch_mm", "1.0004");
  edit.set("run", "wait_limit_s", "5");
  // New lines are numbered where they stand in the edited file.
  const int added = lineOf(kBench, "uri = \"usb:1209:4c46/LFI-0001\"") + 1;
  EXPECT_EQ(edit.changes().substr(0, edit.changes().find('\n') + 1), fmt::format("+ {:4} | settle_ms = 20\n", added));
  EXPECT_EQ(edit.text(), replaced(kBench, "uri = \"usb:1209:4c46/LFI-0001\"\n",
                                  "uri = \"usb:1209:4c46/LFI-0001\"\nsettle_ms = 20\n[display.optics]\n"
                                  "optics = \"lenslet_array\"  # stated\narray_pitch_mm = 1.0004\n") +
                             "\n[run]\nwait_limit_s = 5\n");
}

// A file whose last line has no newline: a key or table added after that line goes on lines of its own (found
// by fuzzing, fuzz/corpus/bench_file_edit/regression-no-last-newline: "[c]b = 0.4991").
TEST_F(BenchFileEditTest, AKeyAddedAfterALastLineWithoutItsNewlineGoesOnALineOfItsOwn) {
  const std::string text = kBench + "[run]";
  BenchFileEdit edit(write(text));
  edit.set("run", "wait_limit_s", "5");
  EXPECT_EQ(edit.text(), kBench + "[run]\nwait_limit_s = 5\n");
  BenchFileEdit optics(write(kBench + "[display.x]\nsettle_ms = 1"));
  optics.set("display.x.optics", "gap_mm", "1.37");
  EXPECT_EQ(optics.text(), kBench + "[display.x]\nsettle_ms = 1\n[display.x.optics]\ngap_mm = 1.37\n");
}

// Tables as TOML lets a file write them: a value or an array of tables on the way refused (found by fuzzing,
// fuzz/corpus/bench_file_edit/regression-value-on-the-way: "a=1" took a new [a] table), a table with no header
// of its own gets one (regression-array-of-tables-parent: a key for [y] went into [[y.s]]), a sub-table goes
// after its parent's keys written by dotted keys too, and a key is never added to a table written inline or by
// dotted keys, nor a comment after a value that shares its line.
TEST_F(BenchFileEditTest, TablesWrittenAnyWayTomlAllowsAreEditedOrRefusedButNeverBroken) {
  const auto edited = [&](const std::string& text, const std::string& table, const std::string& key,
                          const std::string& comment = {}) {
    BenchFileEdit edit(write(text));
    edit.set(table, key, "1", comment);
    return edit.text();
  };
  EXPECT_TRUE(throwsError([&] { edited("a = 1", "a", "e"); }, Errc::InvalidArgument, {"a in", "not a table"}));
  EXPECT_TRUE(throwsError([&] { edited("[[a]]\nb = 2\n", "a.c", "e"); }, Errc::InvalidArgument, {"not a table"}));
  EXPECT_EQ(edited("[x.y]\nz = 2\n", "x", "k"), "[x.y]\nz = 2\n\n[x]\nk = 1\n");
  EXPECT_EQ(edited("[[y.s]]", "y", "k"), "[[y.s]]\n\n[y]\nk = 1\n");
  EXPECT_EQ(edited("[d]\nu = 2\ns.a = 3\n[[d.i]]\nb = 4\n", "d.o", "g"),
            "[d]\nu = 2\ns.a = 3\n[d.o]\ng = 1\n[[d.i]]\nb = 4\n");
  EXPECT_TRUE(throwsError([&] { edited("[c]\ns.g = 2\n", "c.s", "k"); }, Errc::InvalidArgument, {"by dotted keys"}));
  EXPECT_TRUE(throwsError([&] { edited("i = {a = 2}\n", "i", "k"); }, Errc::InvalidArgument, {"inline"}));
  EXPECT_TRUE(throwsError([&] { edited("i = {a = 2}\n", "i.j", "k"); }, Errc::InvalidArgument, {"inline"}));
  EXPECT_EQ(edited("i = {a = 2, b = 3}\n", "i", "a"), "i = {a = 1, b = 3}\n");
  EXPECT_TRUE(throwsError([&] { edited("i = {a = 2, b = 3}\n", "i", "a", "c"); }, Errc::InvalidArgument,
                          {"i.a", "more than a comment"}));
}

TEST_F(BenchFileEditTest, NamesThatAreNotBareKeysAndTablesAsValuesAreRefused) {
  BenchFileEdit edit(write(kBench));
  EXPECT_TRUE(throwsError([&] { edit.set("camera", "a b", "1"); }, Errc::InvalidArgument, {"bare key"}));
  EXPECT_TRUE(throwsError([&] { edit.set("camera.", "gain", "1"); }, Errc::InvalidArgument, {"bare keys"}));
  EXPECT_TRUE(throwsError([&] { edit.set("camera", "gain", "1\n[x]"); }, Errc::InvalidArgument, {"one line"}));
  edit.set("display.optics", "optics", "\"lenslet_array\"");
  EXPECT_TRUE(throwsError([&] { edit.set("display", "optics", "1"); }, Errc::InvalidArgument, {"is a table"}));
  EXPECT_TRUE(throwsError([&] { BenchFileEdit(write("a = [")); }, Errc::Config, {"bench.toml:1:"}));
  EXPECT_TRUE(throwsError([&] { BenchFileEdit(folder_ / "none.toml"); }, Errc::NotFound, {"none.toml"}));
}

TEST_F(BenchFileEditTest, PublishingKeepsThePreviousFileAndARecordAndReplacesTheBench) {
  const fs::path file = write(kBench);
  BenchFileEdit edit(file);
  edit.set("camera", "object_pixel_mm", "0.4991", "calibrated");
  const PublishedCalibration p = publishCalibration(edit, "display", "2026-11-28T10:00:00Z", "{\"a\": 1}\n");
  EXPECT_EQ(p.backup, folder_ / "benches" / "bench.calibrations" / "2026-11-28T100000Z-display.before.toml");
  EXPECT_EQ(p.record, folder_ / "benches" / "bench.calibrations" / "2026-11-28T100000Z-display.json");
  EXPECT_EQ(readText(p.backup), kBench);
  EXPECT_EQ(readText(p.record), "{\"a\": 1}\n");
  EXPECT_EQ(readText(file), edit.text());
  EXPECT_DOUBLE_EQ(readBenchFile(file).objectPixel_mm, 0.4991);
  // The same name again: the record is never overwritten, and the bench (now the edit's text) stays.
  BenchFileEdit again(file);
  again.set("camera", "object_pixel_mm", "0.4993");
  EXPECT_TRUE(throwsError([&] { publishCalibration(again, "display", "2026-11-28T10:00:00Z", "{}"); }, Errc::Exists,
                          {"2026-11-28T100000Z-display.before.toml"}));
  EXPECT_DOUBLE_EQ(readBenchFile(file).objectPixel_mm, 0.4991);
}

TEST_F(BenchFileEditTest, NothingIsReplacedWhenTheBenchChangedMeanwhileOrTheEditDoesNotRead) {
  const fs::path file = write(kBench);
  BenchFileEdit edit(file);
  edit.set("camera", "object_pixel_mm", "0.4991");
  const std::string changed = replaced(kBench, "exposure_us = 10000", "exposure_us = 20000");
  write(changed);
  EXPECT_TRUE(throwsError([&] { publishCalibration(edit, "display", "2026-11-28T10:00:00Z", "{}"); }, Errc::Exists,
                          {"changed since the calibration read it"}));
  EXPECT_EQ(readText(file), changed);

  // A value the bench refuses: the file, and no backup or record, is left.
  BenchFileEdit bad(file);
  bad.set("camera", "object_pixel_mm", "-1");
  EXPECT_TRUE(throwsError([&] { publishCalibration(bad, "display", "2026-11-28T10:00:01Z", "{}"); }, Errc::Config,
                          {"would not read back", "object_pixel_mm"}));
  EXPECT_EQ(readText(file), changed);
  EXPECT_FALSE(fs::exists(folder_ / "benches" / "bench.calibrations" / "2026-11-28T100001Z-display.json"));
  EXPECT_FALSE(fs::exists(folder_ / "benches" / "bench.calibrations" / "2026-11-28T100001Z-display.before.toml"));
}

TEST_F(BenchFileEditTest, TheDisplayOpticsTableReadsAsAClassAndItsValuesAndIsPartOfTheReference) {
  const std::string optics =
      "\n[display.optics]\noptics = \"lenslet_array\"\npacking = \"square\"\n"
      "array_pitch_mm = 1.0004\nrotation_rad = 0.002\narray_offset_mm = [0.1, -0.2]\n"
      "gap_mm = 1.37\n";
  const std::string text =
      replaced(kBench, "uri = \"usb:1209:4c46/LFI-0001\"\n", "uri = \"usb:1209:4c46/LFI-0001\"\n" + optics);
  const BenchFile b = read(text);
  ASSERT_TRUE(b.displayOptics);
  EXPECT_EQ(b.displayOptics->type, OpticsType::LensletArray);
  EXPECT_DOUBLE_EQ(b.displayOptics->arrayPitch_mm, 1.0004);
  EXPECT_DOUBLE_EQ(b.displayOptics->arrayOffsetY_mm, -0.2);
  EXPECT_DOUBLE_EQ(b.displayOptics->focalLength_mm, 1.37);  // the gap, as a lens focused on the panel
  EXPECT_NE(b.referenceHash(), read(kBench).referenceHash());
  EXPECT_NE(b.referenceHash(), read(replaced(text, "1.0004", "1.0005")).referenceHash());
  // A class and its values, or nothing.
  const fs::path noClass = write(replaced(text, "optics = \"lenslet_array\"\n", ""));
  EXPECT_TRUE(throwsError([&] { readBenchFile(noClass); }, Errc::Config, {"[display.optics] names no class"}));
  EXPECT_TRUE(refusedAt(replaced(text, "gap_mm = 1.37\n", "gap_mm = 1.37\nslant_rad = 0.1\n"),
                        lineOf(text, "gap_mm") + 1,
                        "key 'display.optics.slant_rad' is not a parameter of lenslet_array optics"));
}

TEST_F(BenchFileEditTest, WhereTheCameraLooksOnTheDisplayReadsAsAnAffineMapBothWays) {
  const std::string text = replaced(kBench, "part_centre_px = [27.5, 27.5]\n",
                                    "part_centre_px = [27.5, 27.5]\ndisplay_per_pixel_mm = [0.5, 0.01, 0.01, -0.5]\n"
                                    "display_at_image_centre_mm = [1, -2]\n");
  const BenchFile b = read(text);
  ASSERT_TRUE(b.cameraOnDisplay);
  const cv::Size image(56, 56);
  const Vec2 q = b.cameraOnDisplay->displayPoint({27.5 + 2, 27.5 + 4}, image);
  EXPECT_NEAR(q.x, 1 + 0.5 * 2 + 0.01 * 4, 1e-12);
  EXPECT_NEAR(q.y, -2 + 0.01 * 2 - 0.5 * 4, 1e-12);
  const Vec2 back = b.cameraOnDisplay->cameraPoint(q, image);
  EXPECT_NEAR(back.x, 29.5, 1e-12);
  EXPECT_NEAR(back.y, 31.5, 1e-12);
  EXPECT_FALSE(read(kBench).cameraOnDisplay);
  EXPECT_TRUE(
      refusedAt(replaced(text, "display_at_image_centre_mm = [1, -2]\n", ""), lineOf(text, "display_per_pixel_mm"),
                "key 'geometry.display_per_pixel_mm' needs display_per_pixel_mm and display_at_image_centre_mm"));
  EXPECT_TRUE(refusedAt(replaced(text, "[0.5, 0.01, 0.01, -0.5]", "[0.5, 0.5, 0.5, 0.5]"),
                        lineOf(text, "display_per_pixel_mm"),
                        "key 'geometry.display_per_pixel_mm' = [0.5, 0.5, 0.5, 0.5] maps the image onto a line"));
}

TEST_F(BenchFileEditTest, StringsReadAsTheTextHoldsThemAndWriteBackEscaped) {
  BenchFileEdit edit(write(kBench));
  EXPECT_EQ(edit.string("capture", "uri"), "sim:../scenes/bench.toml?spp=8");
  EXPECT_FALSE(edit.string("camera", "exposure_us"));  // a number
  EXPECT_FALSE(edit.string("camera", "none"));
  EXPECT_FALSE(edit.string("none", "uri"));
  const std::string odd = "a \"b\" c:\\d\te";
  edit.set("capture", "uri", tomlString(odd));
  EXPECT_EQ(edit.string("capture", "uri"), odd);
  EXPECT_EQ(tomlString("x\"y"), "\"x\\\"y\"");
}

}  // namespace
}  // namespace lfi::bench_file_test
