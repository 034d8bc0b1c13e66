// SPDX-License-Identifier: Apache-2.0
// The `lfi` command line tool as a user runs it: `lfi render` writes its
// images, keeps them unless asked, gives the same image for any thread count,
// and answers bad arguments and bad scene files with messages that name them.

#include "lfi/core/exr_io.h"
#include "lfi_process.h"
#include "text_edit.h"

#include <gtest/gtest.h>
#include <unistd.h>
#include <opencv2/core.hpp>

#include <filesystem>
#include <fstream>
#include <string>

namespace {

namespace fs = std::filesystem;

using Result = lfi::testing_support::LfiResult;
const auto quoted = [](const auto& s) { return lfi::testing_support::shellQuoted(std::string(s)); };

Result lfi(const std::string& arguments) {
  return lfi::testing_support::runLfi(arguments);
}

using lfi::testing_support::readText;

class LfiCli : public testing::Test {
 protected:
  void SetUp() override {
    const auto* test = testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::path(testing::TempDir()) / ("lfi_cli_" + std::string(test->name()) + "_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // The reference scene at 64 x 64 pixels over the same 60 mm field.
  fs::path smallScene() const {
    std::string text = readText(fs::path(LFI_SOURCE_DIR) / "data" / "scenes" / "reference.toml");
    using Edit = std::pair<std::string, std::string>;
    for (const auto& [from, to] : {Edit{"pixel_pitch_mm = 0.1171875", "pixel_pitch_mm = 0.9375"},
                                   Edit{"width = 512", "width = 64"}, Edit{"height = 512", "height = 64"}}) {
      const size_t at = text.find(from);
      EXPECT_NE(at, std::string::npos) << from;
      if (at != std::string::npos) text.replace(at, from.size(), to);
    }
    const fs::path scene = dir_ / "small.toml";
    std::ofstream(scene) << text;
    return scene;
  }

  fs::path dir_;
};

TEST_F(LfiCli, RenderWritesTheImagesAndKeepsThemUnlessForced) {
  const fs::path scene = smallScene(), out = dir_ / "out";
  const Result first = lfi("render " + quoted(scene) + " --out " + quoted(out) + " --spp 4");
  ASSERT_EQ(first.status, 0) << first.output;
  const fs::path exr = out / "small.exr";
  ASSERT_TRUE(fs::exists(exr)) << first.output;
  EXPECT_TRUE(fs::exists(out / "small.png"));
  const cv::Mat image = lfi::readRadianceExr(exr);
  ASSERT_EQ(image.rows, 64);
  ASSERT_EQ(image.cols, 64);
  // A corner pixel sees the Lambertian back light past the lens (Ø50 in a
  // 60 mm field) through air: radiance is conserved along the ray, so every
  // sample reads the emitter's radiance, 1.
  EXPECT_EQ(image.at<float>(0, 0), 1.0f);
  EXPECT_EQ(image.at<float>(63, 63), 1.0f);

  const std::string before = readText(exr);
  const Result again = lfi("render " + quoted(scene) + " --out " + quoted(out) + " --spp 1");
  EXPECT_NE(again.status, 0);
  EXPECT_NE(again.output.find(exr.string()), std::string::npos) << again.output;
  EXPECT_NE(again.output.find("--force"), std::string::npos) << again.output;
  EXPECT_EQ(readText(exr), before) << "an existing image was replaced without --force";

  const Result forced = lfi("render " + quoted(scene) + " --out " + quoted(out) + " --spp 1 --force");
  EXPECT_EQ(forced.status, 0) << forced.output;
  EXPECT_NE(readText(exr), before) << "--force did not replace the image (1 spp against 4)";
}

TEST_F(LfiCli, RenderGivesTheSameImageForAnyThreadCount) {
  const fs::path scene = smallScene();
  cv::Mat images[2];
  for (const int threads : {1, 2}) {
    const fs::path out = dir_ / ("threads" + std::to_string(threads));
    const Result run = lfi("render " + quoted(scene) + " --out " + quoted(out) + " --spp 9 --seed 7 --threads " +
                           std::to_string(threads));
    ASSERT_EQ(run.status, 0) << run.output;
    images[threads - 1] = lfi::readRadianceExr(out / "small.exr");
  }
  ASSERT_EQ(images[0].size(), images[1].size());
  EXPECT_EQ(cv::norm(images[0], images[1], cv::NORM_INF), 0.0);
  // And the seed matters: a different one gives other samples inside the lens.
  const Result other = lfi("render " + quoted(scene) + " --out " + quoted(dir_ / "seed8") + " --spp 9 --seed 8");
  ASSERT_EQ(other.status, 0) << other.output;
  EXPECT_GT(cv::norm(images[0], lfi::readRadianceExr(dir_ / "seed8" / "small.exr"), cv::NORM_INF), 0.0);
}

TEST_F(LfiCli, BadArgumentsNameTheOptionAndTheValue) {
  const fs::path scene = smallScene(), out = dir_ / "out";
  for (const auto& [arguments, message] :
       {std::pair<std::string, std::string>{"--spp 0", "--spp: '0' is not a whole number in [1, 1048576]"},
        {"--spp 2.5", "--spp: '2.5' is not a whole number in [1, 1048576]"},
        {"--spp 2000000000", "--spp: '2000000000' is not a whole number in [1, 1048576]"},
        {"--threads -1", "--threads: '-1' is not a whole number in [0, 4096]"},
        {"--seed -1", "--seed: '-1' is not a whole number in [0, 9223372036854775807]"},
        // (TOML's largest integer: every seed taken here can be written in a scene file)
        {"--seed 9223372036854775808",
         "--seed: '9223372036854775808' is not a whole number in [0, 9223372036854775807]"}}) {
    const Result run = lfi("render " + quoted(scene) + " --out " + quoted(out) + " " + arguments);
    EXPECT_NE(run.status, 0) << arguments;
    EXPECT_NE(run.output.find(message), std::string::npos) << arguments << ": " << run.output;
  }
  EXPECT_FALSE(fs::exists(out / "small.exr"));
  // Quiet and verbose at once is a contradiction, not quiet winning silently (CLI11's ExcludesError: 108).
  const Result both = lfi("-q -v render " + quoted(scene) + " --out " + quoted(out));
  EXPECT_EQ(both.status, 108) << both.output;
  EXPECT_NE(both.output.find("excludes"), std::string::npos) << both.output;
  // Decimal, whatever CLI11 would make of a leading zero (octal): --spp 010 renders 10 samples, as 10 does.
  const Result ten = lfi("render " + quoted(scene) + " --out " + quoted(dir_ / "ten") + " --spp 010 --seed 3");
  const Result plain = lfi("render " + quoted(scene) + " --out " + quoted(dir_ / "plain") + " --spp 10 --seed 3");
  ASSERT_EQ(ten.status, 0) << ten.output;
  ASSERT_EQ(plain.status, 0) << plain.output;
  EXPECT_EQ(readText(dir_ / "ten" / "small.exr"), readText(dir_ / "plain" / "small.exr"));
  // An image in the way is found before the render, and nothing is written.
  fs::create_directories(out);
  std::ofstream(out / "small.png") << "an earlier image";
  const Result blocked = lfi("render " + quoted(scene) + " --out " + quoted(out) + " --spp 1");
  EXPECT_NE(blocked.status, 0);
  EXPECT_NE(blocked.output.find((out / "small.png").string() + "' exists"), std::string::npos) << blocked.output;
  EXPECT_EQ(blocked.output.find("samples in"), std::string::npos) << "rendered first: " << blocked.output;
  EXPECT_FALSE(fs::exists(out / "small.exr"));
  const Result notAFolder = lfi("render " + quoted(scene) + " --out " + quoted(out / "small.png") + " --spp 1");
  EXPECT_NE(notAFolder.output.find("cannot make the folder"), std::string::npos) << notAFolder.output;
  // serve-camera on an interface the host does not have: named before the renders, which come first otherwise.
  const Result noInterface = lfi("serve-camera " + quoted(scene) + " --interface lfi-none0");
  EXPECT_EQ(noInterface.status, 1) << noInterface.output;
  EXPECT_NE(noInterface.output.find("cannot serve on 'lfi-none0': it is neither a network interface"),
            std::string::npos)
      << noInterface.output;
  EXPECT_NE(noInterface.output.find("usable here: "), std::string::npos) << noInterface.output;  // what it has
  EXPECT_EQ(noInterface.output.find("rendering"), std::string::npos) << "rendered first: " << noInterface.output;
  // So is a serial GigE Vision cannot hold (16 bytes with its terminating zero).
  const Result longSerial = lfi("serve-camera " + quoted(scene) + " --serial LFI-0123456789AB");
  EXPECT_EQ(longSerial.status, 1) << longSerial.output;
  EXPECT_NE(longSerial.output.find("serial 'LFI-0123456789AB' must have 1..15 characters"), std::string::npos)
      << longSerial.output;
  EXPECT_EQ(longSerial.output.find("rendering"), std::string::npos) << "rendered first: " << longSerial.output;
}

TEST_F(LfiCli, BadSceneFilesAreNamedWithTheLineOrKey) {
  const fs::path out = dir_ / "out";
  const fs::path malformed = dir_ / "malformed.toml";
  std::ofstream(malformed) << "format = \"lfi-scene\"\nversion = = 1\n";
  Result run = lfi("render " + quoted(malformed) + " --out " + quoted(out));
  EXPECT_NE(run.status, 0);
  EXPECT_NE(run.output.find("malformed.toml:2"), std::string::npos) << run.output;

  const fs::path unknownKey = dir_ / "unknown.toml";
  std::string text = readText(smallScene());
  text.replace(text.find("ior = 1.5"), 9, "ior = 1.5\nrefractive_index = 1.5");
  std::ofstream(unknownKey) << text;
  run = lfi("render " + quoted(unknownKey) + " --out " + quoted(out));
  EXPECT_NE(run.status, 0);
  EXPECT_NE(run.output.find("unknown.toml"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("refractive_index"), std::string::npos) << run.output;

  run = lfi("render " + quoted(dir_ / "absent.toml") + " --out " + quoted(out));
  EXPECT_NE(run.status, 0);
  EXPECT_NE(run.output.find((dir_ / "absent.toml").string()), std::string::npos) << run.output;
  EXPECT_FALSE(fs::exists(out));
}

}  // namespace

namespace {

// A sweep of two points over Δ on the reference bench at 32 x 32 camera pixels (quick quality), ideal emitter only.
void writeSmallSweep(const fs::path& dir) {
  std::string bench = readText(fs::path(LFI_SOURCE_DIR) / "data" / "benches" / "reference.toml");
  lfi::testing_support::replaceOnce(bench, "width = 512", "width = 128");
  lfi::testing_support::replaceOnce(bench, "height = 512", "height = 128");
  lfi::testing_support::replaceOnce(bench, "pixel_pitch_mm = 0.0138", "pixel_pitch_mm = 0.0552");
  std::ofstream(dir / "bench.toml") << bench;
  std::ofstream(dir / "sweep.toml") << "format = \"lfi-sweep\"\nversion = 1\nbench = \"bench.toml\"\n"
                                       "setups = [\"inverse_schlieren\"]\n[[axis]]\n"
                                       "key = \"inverse_schlieren.distance_mm\"\nvalues = [25, 30]\n";
}

TEST_F(LfiCli, ASweepsShardsMergeIntoTheWholeSweep) {
  writeSmallSweep(dir_);
  const std::string sweep = quoted(dir_ / "sweep.toml");
  const Result whole = lfi("-q study --sweep " + sweep + " --out " + quoted(dir_ / "whole"));
  ASSERT_EQ(whole.status, 0) << whole.output;
  for (const char* shard : {"1/2", "2/2"}) {
    const Result part = lfi("-q study --sweep " + sweep + " --shard " + shard + " --out " +
                            quoted(dir_ / ("shard-" + std::string(1, shard[0]))));
    ASSERT_EQ(part.status, 0) << part.output;
  }
  const Result merged = lfi("-q study merge " + quoted(dir_ / "merged") + " " + quoted(dir_ / "shard-1") + " " +
                            quoted(dir_ / "shard-2"));
  ASSERT_EQ(merged.status, 0) << merged.output;
  EXPECT_EQ(readText(dir_ / "merged" / "study.json"), readText(dir_ / "whole" / "study.json"));
  // The refusals name what is wrong.
  for (const auto& [arguments, message] :
       {std::pair<std::string, std::string>{"study --sweep " + sweep + " --out x --seed 4",
                                            "--seed is the sweep file's"},
        {"study --shard 1/2 --out x", "--shard splits a sweep file's grid"},
        {"study --sweep " + sweep + " --shard 3/2 --out x", "shard '3/2'"},
        {"study --sweep " + sweep, "--out is required"},
        {"study merge " + quoted(dir_ / "again") + " " + quoted(dir_ / "shard-1"),
         "shard 2/2 of the sweep is missing"}}) {
    const Result run = lfi(arguments);
    EXPECT_NE(run.status, 0) << arguments;
    EXPECT_NE(run.output.find(message), std::string::npos) << arguments << ": " << run.output;
  }
}

}  // namespace
