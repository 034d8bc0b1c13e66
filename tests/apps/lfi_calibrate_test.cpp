// SPDX-License-Identifier: Apache-2.0
// `lfi calibrate display|part|camera BENCH` as a user runs them, on the simulated
// inspection bench whose display's lens array is not where the bench file
// says (the bench states the nominal 1 mm square array at no rotation and no
// offset; the scene's has another pitch, rotation and offset): the bench file
// gets the measured values and the camera's scale, keeps the rest of its text,
// and a backup and a record lie beside it; a dry run writes nothing; a part in
// view is refused and nothing is written; the calibrated bench captures its
// reference and passes the intact part. Then the display is knocked further
// from the part: the part calibration finds where it went. The camera's scale
// on the shipped chessboard target; the camera's dark and flat frames.

#include "lfi_process.h"
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
using Result = lfi::testing_support::LfiResult;

Result lfi(const std::string& arguments) {
  return lfi::testing_support::runLfi(arguments);
}
std::string quoted(const fs::path& p) {
  return "'" + p.string() + "'";
}

// The scene's lens array, the truth.
constexpr double kPitch_mm = 1.006, kRotation_rad = 0.012, kOffsetX_mm = 0.23, kOffsetY_mm = -0.31;
// The camera's object pixel: 0.1215 mm sensor pixels at the magnification b / w of f = 20.03 mm, b = 24.9075 mm.
const double kObjectPixel_mm = 0.1215 / 24.9075 / (1 / 20.03 - 1 / 24.9075);

class LfiCalibrate : public testing::Test {
 protected:
  void SetUp() override {
    fs::create_directories(dir_);
    std::string scene = readText(fs::path(LFI_SOURCE_DIR) / "data/scenes/inspection_bench.toml");
    replaceOnce(
        scene, "panel_height_px = 800\n",
        fmt::format("panel_height_px = 800\narray_pitch_mm = {}\nrotation_rad = {}\narray_offset_mm = [{}, {}]\n",
                    kPitch_mm, kRotation_rad, kOffsetX_mm, kOffsetY_mm));
    write("scene.toml", scene);
    write("empty.toml", scene.substr(0, scene.find("[[object]]")));
    std::string bench = readText(fs::path(LFI_SOURCE_DIR) / "data/benches/inspection_sim.toml");
    lfi::testing_support::replaceAll(bench, "../scenes/inspection_bench.toml", "scene.toml");
    lfi::testing_support::replaceAll(bench, "../../out/bench/", "out/");
    replaceOnce(bench, "\n[capture]",
                "\n[display.optics]  # the display's factory calibration\noptics = \"lenslet_array\"\npacking = "
                "\"square\"\narray_pitch_mm = 1.0\nrotation_rad = 0\narray_offset_mm = [0, 0]\ngap_mm = 1.37\n\n"
                "[capture]");
    bench_ = write("bench.toml", bench);
    original_ = bench;
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path write(const std::string& name, const std::string& text) {
    std::ofstream(dir_ / name) << text;
    return dir_ / name;
  }

  const fs::path dir_ = fs::temp_directory_path() / fmt::format("lfi-calibrate-{}", ::getpid());
  fs::path bench_;
  std::string original_;
};

TEST_F(LfiCalibrate, DisplayWritesTheMeasuredArrayAndScaleIntoTheBenchWithABackupAndARecord) {
  const Result run = lfi("-q calibrate display " + quoted(bench_) + " --part " + quoted(dir_ / "empty.toml"));
  ASSERT_EQ(run.status, 0) << run.output;
  const fs::path folder = dir_ / "bench.calibrations";
  ASSERT_TRUE(fs::is_directory(folder));
  fs::path record, backup;
  for (const auto& entry : fs::directory_iterator(folder))
    (entry.path().extension() == ".json" ? record : backup) = entry.path();
  ASSERT_FALSE(record.empty());
  ASSERT_FALSE(backup.empty());
  EXPECT_EQ(readText(backup), original_);

  // The record: every value with its uncertainty; the truth within the expanded uncertainty's tolerance (the
  // display calibration test checks the uncertainty's coverage over many benches; here: the file's values).
  const auto r = nlohmann::json::parse(readText(record));
  EXPECT_EQ(r["format"], "lfi-calibration-record");
  EXPECT_EQ(r["what"], "display");
  EXPECT_EQ(r["frames"], 58);
  const auto value = [&](const char* group, const char* name) { return r[group][name]["value"].get<double>(); };
  // Tolerances (docs/calibration.md): the lens centres at the panel's edge (12.6 mm) within a quarter panel pixel;
  // a point at the field's edge (28 px) within a tenth of a camera pixel.
  EXPECT_NEAR(value("lens_array", "pitch"), kPitch_mm, 0.25 * 0.0315 / 12.6);
  EXPECT_NEAR(value("lens_array", "rotation"), kRotation_rad, 0.25 * 0.0315 / 12.6);
  EXPECT_NEAR(value("lens_array", "offset_x"), kOffsetX_mm, 0.25 * 0.0315);
  EXPECT_NEAR(value("lens_array", "offset_y"), kOffsetY_mm, 0.25 * 0.0315);
  EXPECT_NEAR(value("camera_scale", "object_pixel"), kObjectPixel_mm, kObjectPixel_mm * 0.1 / 28);
  EXPECT_EQ(r["previous"]["array_pitch_mm"], 1.0);

  // The bench file: the same values (to the digits written), its other text as it was.
  const std::string text = readText(bench_);
  const auto line = [&](const std::string& key) {
    const size_t at = text.find("\n" + key + " = ");
    return at == std::string::npos ? std::string() : text.substr(at + 1, text.find('\n', at + 1) - at - 1);
  };
  EXPECT_NE(line("array_pitch_mm").find(fmt::format("{:.9g}", value("lens_array", "pitch"))), std::string::npos)
      << line("array_pitch_mm");
  EXPECT_NE(line("object_pixel_mm").find(fmt::format("{:.9g}", value("camera_scale", "object_pixel"))),
            std::string::npos)
      << line("object_pixel_mm");
  // Each value's uncertainty as a key beside it, at the coverage factor the file states once.
  EXPECT_EQ(line("array_pitch_mm_u"),
            fmt::format("array_pitch_mm_u = {:.2g}", r["lens_array"]["pitch"]["expanded_uncertainty"].get<double>()));
  EXPECT_NE(line("display_per_pixel_mm_u").find("["), std::string::npos) << text;
  EXPECT_NE(text.find("\nversion = 1\ncoverage_factor = 2  # k of every"), std::string::npos) << text;
  // Where the camera looks on the display: the scene's camera axis is the display's centre.
  EXPECT_NE(line("display_per_pixel_mm").find("["), std::string::npos) << text;
  EXPECT_NEAR(r["camera_scale"]["image_centre_on_display_mm"][0].get<double>(), 0, 0.1 * kObjectPixel_mm);
  EXPECT_NEAR(r["camera_scale"]["image_centre_on_display_mm"][1].get<double>(), 0, 0.1 * kObjectPixel_mm);
  EXPECT_NE(text.find("relative = 6                 # 6 sigma"), std::string::npos) << "a comment was lost";
  EXPECT_NE(text.find("[display.optics]  # the display's factory calibration"), std::string::npos);

  // The calibrated bench takes its reference and passes the intact part through the calibrated optics.
  const Result capture = lfi("-q capture " + quoted(bench_));
  ASSERT_EQ(capture.status, 0) << capture.output;
  const Result inspect = lfi("-q inspect " + quoted(bench_));
  EXPECT_EQ(inspect.status, 0) << inspect.output;
}

TEST_F(LfiCalibrate, ADryRunPrintsTheChangesAndWritesNothing) {
  const Result run =
      lfi("-q calibrate display " + quoted(bench_) + " --part " + quoted(dir_ / "empty.toml") + " --dry-run");
  ASSERT_EQ(run.status, 0) << run.output;
  EXPECT_NE(run.output.find("would change"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find(" | array_pitch_mm = 1.0\n"), std::string::npos) << run.output;  // the line removed
  EXPECT_NE(run.output.find(" | array_pitch_mm = 1.00"), std::string::npos) << run.output;   // and written
  EXPECT_EQ(readText(bench_), original_);
  EXPECT_FALSE(fs::exists(dir_ / "bench.calibrations"));
}

TEST_F(LfiCalibrate, APartInViewIsRefusedAndNothingIsWritten) {
  const Result run = lfi("-q calibrate display " + quoted(bench_));  // the scene's lens under the camera
  EXPECT_EQ(run.status, 1) << run.output;
  EXPECT_NE(run.output.find("too large for the model"), std::string::npos) << run.output;
  EXPECT_EQ(readText(bench_), original_);
  EXPECT_FALSE(fs::exists(dir_ / "bench.calibrations"));
}

TEST_F(LfiCalibrate, OpticsOfAnotherClassThanTheDisplaysAreNamed) {
  std::string bench = original_;
  replaceOnce(bench, "optics = \"lenslet_array\"\n", "optics = \"pinhole_array\"\npinhole_diameter_mm = 0.1\n");
  write("bench.toml", bench);
  const Result run = lfi("-q calibrate display " + quoted(bench_) + " --part " + quoted(dir_ / "empty.toml"));
  EXPECT_EQ(run.status, 1) << run.output;
  EXPECT_NE(run.output.find("[display.optics] states pinhole_array optics"), std::string::npos) << run.output;
}

// A display knocked 6 mm further from the part than its reference was taken at (beyond the study's ±4 mm Δ
// tolerance) fails the intact part against its golden model; `lfi calibrate part` finds where it went, the
// reference taken again at that Δ passes the intact part, and defects are placed on the part, not on the image.
TEST_F(LfiCalibrate, PartFindsWhereTheDisplayWentAndTheNewReferencePassesTheIntactPart) {
  std::string scene = readText(dir_ / "scene.toml");
  replaceOnce(scene, "ior = 1.5168\n", "ior = 1.5168\nposition_mm = [0.4, -0.3, 0]\n");  // the part 0.5 mm off
  write("scene.toml", scene);
  ASSERT_EQ(lfi("-q calibrate display " + quoted(bench_) + " --part " + quoted(dir_ / "empty.toml")).status, 0);
  ASSERT_EQ(lfi("-q capture " + quoted(bench_)).status, 0);
  ASSERT_EQ(lfi("-q inspect " + quoted(bench_)).status, 0);

  replaceOnce(scene, "position_mm = [0, 0, -30]", "position_mm = [0, 0, -36]");  // the display knocked down
  write("scene.toml", scene);
  const Result knocked = lfi("-q inspect " + quoted(bench_));
  EXPECT_EQ(knocked.status, 3) << "the intact part passed under a display 6 mm off: " << knocked.output;

  const fs::path model = fs::path(LFI_SOURCE_DIR) / "data/scenes/inspection_bench.toml";
  const Result run = lfi("-q calibrate part " + quoted(bench_) + " --model " + quoted(model));
  ASSERT_EQ(run.status, 0) << run.output;
  fs::path record;
  for (const auto& entry : fs::directory_iterator(dir_ / "bench.calibrations"))
    if (entry.path().string().ends_with("-part.json")) record = entry.path();
  ASSERT_FALSE(record.empty());
  const auto r = nlohmann::json::parse(readText(record));
  EXPECT_EQ(r["what"], "part");
  // Tolerances (docs/calibration.md): the display's steepest ray (0.27) at the part within a tenth of a camera
  // pixel: Δ within 0.05 / 0.27 mm, the lateral position within 0.05 mm.
  EXPECT_NEAR(r["distance"]["value"].get<double>(), 36, 0.05 / 0.27);
  EXPECT_NEAR(r["lateral_x"]["value"].get<double>(), 0.4, 0.05);
  EXPECT_NEAR(r["lateral_y"]["value"].get<double>(), -0.3, 0.05);
  const std::string text = readText(bench_);
  EXPECT_NE(text.find(fmt::format("distance_mm = {:.9g}", r["distance"]["value"].get<double>())), std::string::npos)
      << text;
  // Δ has one place: the capture URI does not carry it and is left as it was.
  EXPECT_EQ(text.find("?distance_mm="), std::string::npos) << text;

  ASSERT_EQ(lfi("-q capture " + quoted(bench_) + " --force").status, 0);
  const Result intact = lfi("-q inspect " + quoted(bench_));
  EXPECT_EQ(intact.status, 0) << intact.output;
  // A particle 10 mm from the part's centre: placed there, not 10 mm from the image's centre.
  std::string rim = scene;
  rim +=
      "[[object]]\nname = \"rim\"\nshape = \"sphere\"\nradius_mm = 0.5\nposition_mm = [10.4, -0.3, 0]\n"
      "material = \"absorber\"\n";
  const Result defect = lfi("-q inspect " + quoted(bench_) + " --part " + quoted(write("rim.toml", rim)));
  EXPECT_EQ(defect.status, 3) << defect.output;
  const size_t at = defect.output.find("FAIL: ");
  ASSERT_NE(at, std::string::npos) << defect.output;
  const std::string path = defect.output.substr(at + 6, defect.output.find('\n', at) - at - 6);
  const auto found = nlohmann::json::parse(readText(fs::path(path).is_absolute() ? fs::path(path) : dir_ / path));
  ASSERT_EQ(found["defects"].size(), 1u);
  // Within a camera pixel (0.5 mm) of (10, 0) on the part.
  EXPECT_NEAR(found["defects"][0]["centroid_mm"][0].get<double>(), 10, 0.5);
  EXPECT_NEAR(found["defects"][0]["centroid_mm"][1].get<double>(), 0, 0.5);
}

// The shipped chessboard target (data/scenes/inspection_bench_target.toml) under the bench's camera.
TEST_F(LfiCalibrate, CameraOnAChessboardWritesTheScaleWithABackupAndARecord) {
  const fs::path target = fs::path(LFI_SOURCE_DIR) / "data/scenes/inspection_bench_target.toml";
  const std::string board = " --corners 5x5 --square-mm 3";
  const Result noBoard =
      lfi("-q calibrate camera " + quoted(bench_) + board + " --part " + quoted(dir_ / "empty.toml"));
  EXPECT_EQ(noBoard.status, 1) << noBoard.output;
  EXPECT_NE(noBoard.output.find("no chessboard of 5 x 5 inner corners, 3 mm squares"), std::string::npos)
      << noBoard.output;
  const Result unnamed = lfi("-q calibrate camera " + quoted(bench_) + " --part " + quoted(target));
  EXPECT_EQ(unnamed.status, 1) << unnamed.output;
  EXPECT_NE(unnamed.output.find("--corners COLSxROWS and --square-mm"), std::string::npos) << unnamed.output;
  EXPECT_EQ(readText(bench_), original_);
  EXPECT_FALSE(fs::exists(dir_ / "bench.calibrations"));

  const Result run = lfi("-q calibrate camera " + quoted(bench_) + board + " --part " + quoted(target));
  ASSERT_EQ(run.status, 0) << run.output;
  fs::path record, backup;
  for (const auto& entry : fs::directory_iterator(dir_ / "bench.calibrations"))
    (entry.path().extension() == ".json" ? record : backup) = entry.path();
  ASSERT_FALSE(record.empty());
  EXPECT_EQ(readText(backup), original_);
  const auto r = nlohmann::json::parse(readText(record));
  EXPECT_EQ(r["what"], "camera");
  EXPECT_EQ(r["frames"], 1);
  EXPECT_EQ(r["camera_scale"]["corners"], 25);
  // A point at the field's edge (28 px) within a tenth of a camera pixel, as the display calibration's scale.
  const double scale = r["camera_scale"]["object_pixel"]["value"].get<double>();
  EXPECT_NEAR(scale, kObjectPixel_mm, kObjectPixel_mm * 0.1 / 28);
  const std::string text = readText(bench_);
  EXPECT_NE(text.find(fmt::format("object_pixel_mm = {:.9g}  # lfi calibrate camera", scale)), std::string::npos)
      << text;
}

// The camera's dark and flat frames: refused in the wrong order or from the
// wrong light with the bench untouched; written beside the bench and named in
// it; then every image the bench takes is corrected (its reference and
// inspection), and a bench whose exposure changed since takes no reference
// until they are taken again.
TEST_F(LfiCalibrate, CameraDarkAndFlatFramesAreKeptBesideTheBenchAndCorrectItsImages) {
  const std::string flatScene = readText(fs::path(LFI_SOURCE_DIR) / "data/scenes/inspection_bench_flat.toml");
  const fs::path flat = write("flat.toml", flatScene);
  std::string bright = flatScene, unlit = flatScene;
  replaceOnce(bright, "radiance = 0.75", "radiance = 2");                 // 14 000 e- into the 10 500 e- well
  replaceOnce(unlit, "emitter = \"lambertian\"\nradiance = 0.75\n", "");  // an opaque card: no light
  const auto calibrate = [&](const std::string& arguments) {
    return lfi("-q calibrate camera " + quoted(bench_) + " " + arguments);
  };
  const auto refused = [&](const Result& r, const std::vector<std::string>& fragments, const std::string& bench) {
    EXPECT_EQ(r.status, 1) << r.output;
    for (const std::string& f : fragments) EXPECT_NE(r.output.find(f), std::string::npos) << f << "\n" << r.output;
    EXPECT_EQ(readText(bench_), bench);
  };
  refused(calibrate("--flat --part " + quoted(flat)), {"dark_frame is not set", "--dark"}, original_);
  EXPECT_FALSE(fs::exists(dir_ / "bench.calibrations"));

  ASSERT_EQ(calibrate("--dark").status, 0);
  const std::string withDark = readText(bench_);
  EXPECT_NE(withDark.find("dark_frame = \"bench.calibrations/"), std::string::npos) << withDark;
  const auto files = [&] {
    std::vector<std::string> names;
    for (const auto& entry : fs::directory_iterator(dir_ / "bench.calibrations"))
      names.push_back(entry.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
  };
  ASSERT_EQ(files().size(), 3u) << "the frame, the record and the bench before";
  refused(calibrate("--flat --part " + quoted(write("bright.toml", bright))),
          {"saturated pixels", "lower the exposure"}, withDark);
  refused(calibrate("--flat --part " + quoted(write("unlit.toml", unlit))),
          {"is no brighter than the dark frame", "was the light on"}, withDark);
  EXPECT_EQ(files().size(), 3u) << "nothing kept of a refused frame";

  const Result good = calibrate("--flat --part " + quoted(flat));
  ASSERT_EQ(good.status, 0) << good.output;
  const std::string withFlat = readText(bench_);
  EXPECT_NE(withFlat.find("flat_frame = \"bench.calibrations/"), std::string::npos) << withFlat;
  EXPECT_EQ(files().size(), 6u);
  for (const std::string& name : files())
    if (name.ends_with("-flat.json")) {
      const auto r = nlohmann::json::parse(readText(dir_ / "bench.calibrations" / name));
      EXPECT_EQ(r["what"], "flat");
      EXPECT_EQ(r["frames"], 64);
      EXPECT_EQ(r["camera"]["pixel_format"], "Mono12");
      // The flat source at half scale: 0.75 of radiance 1's 7000 e- at 10 ms, in 4095 DN over 10 500 e-.
      EXPECT_NEAR(r["frame_dn"]["mean"].get<double>(), 0.75 * 7000 * 4095 / 10500, 20);
    }

  // The corrected bench takes its reference and passes the intact part.
  ASSERT_EQ(lfi("-q capture " + quoted(bench_)).status, 0);
  const Result inspect = lfi("-q inspect " + quoted(bench_));
  EXPECT_EQ(inspect.status, 0) << inspect.output;
  std::string longer = withFlat;
  replaceOnce(longer, "exposure_us = 10000", "exposure_us = 12000");
  write("bench.toml", longer);
  const Result stale = lfi("-q capture --force " + quoted(bench_));
  EXPECT_EQ(stale.status, 1) << stale.output;
  EXPECT_NE(stale.output.find("exposure_us 10000 against 12000"), std::string::npos) << stale.output;
  EXPECT_NE(stale.output.find("take it again"), std::string::npos) << stale.output;
  // A dark frame at the new exposure: the flat frame no longer fits it and leaves the bench, which says so.
  const Result newDark = lfi("calibrate camera " + quoted(bench_) + " --dark");
  ASSERT_EQ(newDark.status, 0) << newDark.output;
  EXPECT_NE(newDark.output.find("the bench's flat frame does not fit the new dark frame"), std::string::npos)
      << newDark.output;
  EXPECT_EQ(readText(bench_).find("flat_frame"), std::string::npos) << readText(bench_);
  EXPECT_EQ(lfi("-q capture --force " + quoted(bench_)).status, 0);
}

TEST_F(LfiCalibrate, PartWithoutTheCamerasMapOrAModelIsRefusedBeforeAnyFrame) {
  const fs::path model = fs::path(LFI_SOURCE_DIR) / "data/scenes/inspection_bench.toml";
  const Result noMap = lfi("-q calibrate part " + quoted(bench_) + " --model " + quoted(model));
  EXPECT_EQ(noMap.status, 1) << noMap.output;
  EXPECT_NE(noMap.output.find("run `lfi calibrate display` first"), std::string::npos) << noMap.output;
  ASSERT_EQ(lfi("-q calibrate display " + quoted(bench_) + " --part " + quoted(dir_ / "empty.toml")).status, 0);
  const Result noModel = lfi("-q calibrate part " + quoted(bench_));
  EXPECT_EQ(noModel.status, 1) << noModel.output;
  EXPECT_NE(noModel.output.find("--model names the part's model"), std::string::npos) << noModel.output;
}

}  // namespace
