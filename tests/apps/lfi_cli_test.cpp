// The `lfi` command line tool as a user runs it: `lfi render` writes its
// images, keeps them unless asked, gives the same image for any thread count,
// and answers bad arguments and bad scene files with messages that name them.

#include "lfi/core/exr_io.h"

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace {

namespace fs = std::filesystem;

struct Result {
  int status = -1;     // the exit status
  std::string output;  // stdout and stderr
};

std::string quoted(const std::string& s) {
  std::string q = "'";
  for (const char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

Result lfi(const std::string& arguments) {
  const std::string command = quoted(LFI_EXECUTABLE) + " " + arguments + " 2>&1";
  Result run;
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) return run;
  char buffer[4096];
  for (size_t n; (n = fread(buffer, 1, sizeof buffer, pipe)) > 0;) run.output.append(buffer, n);
  const int status = pclose(pipe);
  run.status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return run;
}

std::string readBytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

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
    std::string text = readBytes(fs::path(LFI_SOURCE_DIR) / "data" / "scenes" / "reference.toml");
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

  const std::string before = readBytes(exr);
  const Result again = lfi("render " + quoted(scene) + " --out " + quoted(out) + " --spp 1");
  EXPECT_NE(again.status, 0);
  EXPECT_NE(again.output.find(exr.string()), std::string::npos) << again.output;
  EXPECT_NE(again.output.find("--force"), std::string::npos) << again.output;
  EXPECT_EQ(readBytes(exr), before) << "an existing image was replaced without --force";

  const Result forced = lfi("render " + quoted(scene) + " --out " + quoted(out) + " --spp 1 --force");
  EXPECT_EQ(forced.status, 0) << forced.output;
  EXPECT_NE(readBytes(exr), before) << "--force did not replace the image (1 spp against 4)";
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
       {std::pair<std::string, std::string>{"--spp 0", "--spp: '0' is not a whole number >= 1"},
        {"--spp 2.5", "--spp: '2.5' is not a whole number >= 1"},
        {"--threads -1", "--threads: '-1' is not a whole number >= 0"}}) {
    const Result run = lfi("render " + quoted(scene) + " --out " + quoted(out) + " " + arguments);
    EXPECT_NE(run.status, 0) << arguments;
    EXPECT_NE(run.output.find(message), std::string::npos) << arguments << ": " << run.output;
  }
  EXPECT_FALSE(fs::exists(out / "small.exr"));
}

TEST_F(LfiCli, BadSceneFilesAreNamedWithTheLineOrKey) {
  const fs::path out = dir_ / "out";
  const fs::path malformed = dir_ / "malformed.toml";
  std::ofstream(malformed) << "format = \"lfi-scene\"\nversion = = 1\n";
  Result run = lfi("render " + quoted(malformed) + " --out " + quoted(out));
  EXPECT_NE(run.status, 0);
  EXPECT_NE(run.output.find("malformed.toml:2"), std::string::npos) << run.output;

  const fs::path unknownKey = dir_ / "unknown.toml";
  std::string text = readBytes(smallScene());
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
