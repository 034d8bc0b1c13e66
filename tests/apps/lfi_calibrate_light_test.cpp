// SPDX-License-Identifier: Apache-2.0
// A bench that measures its own light, as a user calibrates it: the
// simulated inspection bench with a panel of gamma 2.2 whose backlight falls
// by 20 % to the corners, a camera with a black level, 2 % fixed-pattern
// noise and 15 % vignetting, turned 90° (and seeing the display mirrored, as
// a camera looking down does). Its coded reference images the intact part
// less uniformly before `lfi calibrate camera --dark`, `--flat`, `display` and
// `panel` than after, and within the bar of cv 0.05 after; the
// panel's curve and backlight in the bench file are the scene's within their
// U; particles are found where they are on the part, through the turned
// camera's map. A response that is not monotonic is refused by name.

#include "lfi_process.h"
#include "text_edit.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <toml++/toml.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>
#include <string>
#include <utility>
#include <vector>

namespace lfi::calibrate_light_test {
namespace {

namespace fs = std::filesystem;
using lfi::testing_support::readText;
using lfi::testing_support::replaceAll;
using lfi::testing_support::replaceOnce;
using Result = lfi::testing_support::LfiResult;

using lfi::testing_support::runLfi;
using lfi::testing_support::shellQuoted;

constexpr double kGamma = 2.2, kFalloff = 0.2;

class LfiCalibrateLight : public testing::Test {
 protected:
  void SetUp() override {
    fs::create_directories(dir_);
    for (const char* name : {"inspection_bench", "inspection_bench_empty", "inspection_bench_flat"}) {
      std::string scene = readText(fs::path(LFI_SOURCE_DIR) / "data/scenes" / (std::string(name) + ".toml"));
      replaceOnce(scene, "rotation_deg = [180, 0, 0]", "rotation_deg = [180, 0, 90]");
      replaceOnce(scene, "bit_depth = 12\n",
                  "bit_depth = 12\nblack_level_dn = 64\ndark_fpn_dn = 2\ngain_fpn = 0.02\nvignetting = 0.15\n");
      replaceOnce(
          scene, "panel_height_px = 800\n",
          fmt::format("panel_height_px = 800\nresponse_gamma = {}\nbacklight_falloff = {}\n", kGamma, kFalloff));
      write(std::string(name) + ".toml", scene);
    }
    std::string bench = readText(fs::path(LFI_SOURCE_DIR) / "data/benches/inspection_coded_sim.toml");
    replaceAll(bench, "../scenes/", "");
    replaceAll(bench, "../../out/bench/", "out/");
    bench_ = write("bench.toml", bench);
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path write(const std::string& name, const std::string& text) {
    std::ofstream(dir_ / name) << text;
    return dir_ / name;
  }
  // `lfi calibrate ARGUMENTS` on the bench, which must succeed.
  void calibrate(const std::string& what, const std::string& part) {
    const Result r = runLfi("-q calibrate " + what + " " + shellQuoted(bench_.string()) + " --part " +
                            shellQuoted((dir_ / part).string()));
    ASSERT_EQ(r.status, 0) << what << "\n" << r.output;
  }
  // The intact part's image's cv over the part, as `lfi capture` reports it.
  double capturedCv() {
    const Result r = runLfi("capture --force " + shellQuoted(bench_.string()));
    EXPECT_EQ(r.status, 0) << r.output;
    std::smatch m;
    const std::regex cv("the intact part's image there: mean [0-9.]+ DN, cv ([0-9.]+)");
    if (!std::regex_search(r.output, m, cv)) {
      ADD_FAILURE() << r.output;
      return 1;
    }
    return std::stod(m[1]);
  }

  const fs::path dir_ = fs::temp_directory_path() / fmt::format("lfi-calibrate-light-{}", ::getpid());
  fs::path bench_;
};

TEST_F(LfiCalibrateLight, TheCalibratedBenchImagesTheIntactPartUniformlyAndPlacesDefectsOnThePart) {
  const double before = capturedCv();
  ASSERT_NO_FATAL_FAILURE(calibrate("camera --dark", "inspection_bench_empty.toml"));
  ASSERT_NO_FATAL_FAILURE(calibrate("camera --flat", "inspection_bench_flat.toml"));
  ASSERT_NO_FATAL_FAILURE(calibrate("display", "inspection_bench_empty.toml"));
  ASSERT_NO_FATAL_FAILURE(calibrate("panel", "inspection_bench_empty.toml"));
  const double after = capturedCv();
  EXPECT_LE(after, 0.05) << "before the calibrations " << before;
  // The coded capture's closed loop takes the uncalibrated bench to its own bar of cv 0.05 too; the calibrations
  // take it below, from an image whose 1876 pixels know their cv to about 2 % of it.
  EXPECT_LT(after, 0.9 * before) << "before the calibrations " << before;

  // The panel's curve and backlight as the bench file states them, against the scene's.
  const toml::table bench = toml::parse_file(bench_.string());
  const toml::table& response = *bench["display"]["response"].as_table();
  const toml::array& levels = *response["levels"].as_array();
  int points = 0, covered = 0;
  for (const char* colour : {"red", "green", "blue"}) {
    const toml::array& light = *response[colour].as_array();
    const toml::array& u = *response[std::string(colour) + "_u"].as_array();
    for (std::size_t i = 1; i + 1 < levels.size(); ++i) {
      const double truth = std::pow(levels[i].value<double>().value() / 255, kGamma);
      ++points;
      covered += std::abs(light[i].value<double>().value() - truth) <= u[i].value<double>().value();
    }
  }
  EXPECT_GE(covered, 0.9 * points) << covered << " of " << points;
  // B = 1 - f (x^2 + y^2) / r_corner^2 over the 25.2 mm square panel.
  const double quadratic = -kFalloff / (2 * std::pow(799 / 2.0 * 0.0315, 2));
  const toml::array& b = *response["backlight"].as_array();
  const toml::array& bu = *response["backlight_u"].as_array();
  for (const std::size_t term : {3u, 5u})
    EXPECT_NEAR(b[term].value<double>().value(), quadratic, bu[term].value<double>().value()) << "term " << term;

  // Particles of the study's size (Ø1 mm, absorbing) at known places in the lens's centre plane: found on the
  // part's axes through the turned camera's map, within half a camera pixel (0.25 mm) of where they are.
  std::string particles = readText(dir_ / "inspection_bench.toml");
  const std::vector<std::pair<double, double>> truth{{0, 0}, {10, 0}, {4, 7}};
  for (const auto& [x, y] : truth)
    particles += fmt::format(
        "[[object]]\nname = \"particle at {0}, {1}\"\nshape = \"sphere\"\nradius_mm = 0.5\n"
        "position_mm = [{0}, {1}, 0]\nmaterial = \"absorber\"\n",
        x, y);
  // With the part's model in the bench, each is placed inside the lens too, at its centre plane (z = 0).
  std::string text = readText(bench_);
  replaceOnce(text, "part_centre_px = [27.5, 27.5]",
              "part_centre_px = [27.5, 27.5]\npart_model = \"inspection_bench.toml\"");
  write("bench.toml", text);
  const Result inspect = runLfi("-q inspect " + shellQuoted(bench_.string()) + " --part " +
                                shellQuoted(write("particles.toml", particles).string()));
  EXPECT_EQ(inspect.status, 3) << inspect.output;
  const std::size_t at = inspect.output.find("FAIL: ");
  ASSERT_NE(at, std::string::npos) << inspect.output;
  const fs::path record = inspect.output.substr(at + 6, inspect.output.find('\n', at) - at - 6);
  const auto found = nlohmann::json::parse(readText(record.is_absolute() ? record : dir_ / record));
  ASSERT_EQ(found["defects"].size(), truth.size()) << found.dump(2);
  for (const auto& [x, y] : truth) {
    SCOPED_TRACE(fmt::format("the particle at ({}, {}) mm\n{}", x, y, found["defects"].dump()));
    const nlohmann::json* nearest = nullptr;
    double distance = 1e9;
    for (const auto& d : found["defects"])
      if (const double r = std::hypot(d["centroid_mm"][0].get<double>() - x, d["centroid_mm"][1].get<double>() - y);
          r < distance) {
        distance = r;
        nearest = &d;
      }
    EXPECT_LE(distance, 0.25);
    // Within the position's stated uncertainty on each axis.
    ASSERT_NE(nearest, nullptr);
    EXPECT_LE(std::abs((*nearest)["centroid_mm"][0].get<double>() - x), (*nearest)["centroid_u_mm"][0].get<double>());
    EXPECT_LE(std::abs((*nearest)["centroid_mm"][1].get<double>() - y), (*nearest)["centroid_u_mm"][1].get<double>());
    // Inside the lens: the apparent position moved towards the axis by the front face's refraction (Snell's law at
    // the face's normal, asin(r / R), over the face's height above z = 0), and within the same U of the truth.
    const auto& apparent = (*nearest)["centroid_mm"];
    const auto& inside = (*nearest)["inside_mm"];
    ASSERT_TRUE(inside.is_array());
    const double r = std::hypot(apparent[0].get<double>(), apparent[1].get<double>());
    const double theta = std::asin(r / 51.5), bent = std::asin(std::sin(theta) / 1.5168);
    const double face = 2.5 - (51.5 - std::sqrt(51.5 * 51.5 - r * r));
    EXPECT_NEAR(r - std::hypot(inside[0].get<double>(), inside[1].get<double>()), face * std::tan(theta - bent), 1e-6);
    EXPECT_LE(std::abs(inside[0].get<double>() - x), (*nearest)["centroid_u_mm"][0].get<double>());
    EXPECT_LE(std::abs(inside[1].get<double>() - y), (*nearest)["centroid_u_mm"][1].get<double>());
  }
  EXPECT_EQ(found["inside_depth_mm"], 0);
}

TEST_F(LfiCalibrateLight, AResponseThatIsNotMonotonicIsRefusedByName) {
  std::string text = readText(bench_);
  replaceOnce(text, "\n[capture]",
              "\n[display.response]\nlevels = [0, 64, 128, 255]\nlight = [0, 0.3, 0.2, 1]\n\n[capture]");
  write("bench.toml", text);
  const Result r = runLfi("-q capture --force " + shellQuoted(bench_.string()));
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("bench.toml"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("[display.response]: panel response: light is not monotonic: 0.2 at level 128 after 0.3"),
            std::string::npos)
      << r.output;
}

}  // namespace
}  // namespace lfi::calibrate_light_test
