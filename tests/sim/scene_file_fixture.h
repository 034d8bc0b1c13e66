// SPDX-License-Identifier: Apache-2.0
#pragma once
// The fixture of the scene file tests (scene_file*_test.cpp): a folder of the
// test's own for the files it writes, and the [camera] table of most scenes.

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

namespace lfi::testing_support {

class SceneFile : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ =
        std::filesystem::path(::testing::TempDir()) / ("lfi_scene_" + std::to_string(::getpid()) + "_" +
                                                       ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::filesystem::path write(const std::string& name, const std::string& text) {
    std::ofstream(dir_ / name) << text;
    return dir_ / name;
  }
  std::filesystem::path dir_;
};

// A 1:1 telecentric camera (f = 100 mm, b = 200 mm) of 16 x 16 pixels of
// 0.1 mm, 200 mm above the origin and looking down -z.
inline constexpr const char* kCamera = R"(
[camera]
focal_length_mm = 100
image_distance_mm = 200
stop_diameter_mm = 2
pixel_pitch_mm = 0.1
width = 16
height = 16
position_mm = [0, 0, 200]
rotation_deg = [180, 0, 0]
)";

}  // namespace lfi::testing_support
