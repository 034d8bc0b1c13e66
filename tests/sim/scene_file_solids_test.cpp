// SPDX-License-Identifier: Apache-2.0
// Solids in scene files: cut-outs subtracted from a solid, and sensors whose
// rays would start inside a solid refused.

#include "lfi/sim/scene_file.h"

#include "lfi_test_support.h"
#include "scene_file_fixture.h"

#include <gtest/gtest.h>

#include <memory>
#include <string>

namespace {

namespace fs = std::filesystem;
using namespace lfi;
using namespace lfi::sim;
using lfi::testing_support::kCamera;
using lfi::testing_support::SceneFile;
using lfi::testing_support::throwsError;

TEST_F(SceneFile, CutsAreSubtractedFromTheSolid) {
  const fs::path f = write("cut.toml", std::string("format = \"lfi-scene\"\nversion = 1\n") + kCamera + R"(
[[object]]
name = "ball"
shape = "sphere"
radius_mm = 10
material = "dielectric"
ior = 1.5
[[object.cut]]
position_mm = [0, 0, 10]
radius_mm = 3
)");
  const SceneDescription d = loadSceneFile(f);
  const auto& solid = *std::get<std::shared_ptr<const Solid>>(d.objects[0].shape);
  EXPECT_TRUE(solid.contains({0, 0, 6.5}));
  EXPECT_FALSE(solid.contains({0, 0, 8}));  // inside the cut sphere
  EXPECT_TRUE(solid.contains({0, 8, 0}));
  // An empty list of cut-outs is none (inline, as TOML writes an empty array of tables).
  const SceneDescription none =
      loadSceneFile(write("no-cut.toml", std::string("format = \"lfi-scene\"\nversion = 1\n") + kCamera + R"(
[[object]]
name = "ball"
shape = "sphere"
radius_mm = 10
cut = []
)"));
  const auto& whole = *std::get<std::shared_ptr<const Solid>>(none.objects[0].shape);
  EXPECT_TRUE(whole.contains({0, 0, 8}));
  // An array of anything else is still refused.
  EXPECT_TRUE(throwsError(
      [&] {
        loadSceneFile(write("bad-cut.toml", std::string("format = \"lfi-scene\"\nversion = 1\n") + kCamera +
                                                "[[object]]\nname = \"ball\"\nshape = \"sphere\"\nradius_mm = 10\n"
                                                "cut = [1, 2]\n"));
      },
      Errc::Config, {"bad-cut.toml:", "cut", "array of tables"}));
}

// The tracer starts a sensor's rays in air; rays that would start inside a
// solid are named at the sensor's position instead of making a wrong image.
TEST_F(SceneFile, SensorInsideASolidIsAnError) {
  const std::string head = std::string("format = \"lfi-scene\"\nversion = 1\n") + kCamera;
  // The camera's plane at z = 200 inside a sphere of radius 300 about the origin.
  EXPECT_TRUE(throwsError(
      [&] { loadSceneFile(write("a.toml", head + "[[object]]\nname='big'\nshape='sphere'\nradius_mm=300\n")); },
      Errc::Config, {"a.toml:", "camera.position_mm", "inside object 'big'"}));
  // Its field of 16 pixels of 0.1 mm and its stop's offsets of up to b/(b - f) D/2 = 2 mm start rays
  // up to 0.8 + 2 = 2.8 mm off the axis: a sphere of radius 1 at 3.9 mm is clear of them, one at 3.5 is not.
  const std::string beside = "[[object]]\nname='s'\nshape='sphere'\nradius_mm=1\nposition_mm=[0, 3.9, 200]\n";
  EXPECT_NO_THROW(loadSceneFile(write("b.toml", head + beside)));
  const std::string touching = "[[object]]\nname='s'\nshape='sphere'\nradius_mm=1\nposition_mm=[0, 3.5, 200]\n";
  EXPECT_TRUE(throwsError([&] { loadSceneFile(write("c.toml", head + touching)); }, Errc::Config,
                          {"camera.position_mm", "inside object 's'"}));
  // A light field sensor plane through a lens.
  EXPECT_TRUE(throwsError(
      [&] {
        loadSceneFile(write("d.toml",
                            "format = \"lfi-scene\"\nversion = 1\n[light_field_sensor]\n"
                            "spatial_x = 8\nspatial_y = 8\nangular = 4\npixel_pitch_mm = 0.1\n"
                            "[[object]]\nname='lens'\nshape='lens'\nfront_radius_mm=100\n"
                            "back_radius_mm=-100\ncentre_thickness_mm=7\ndiameter_mm=50\n"));
      },
      Errc::Config, {"d.toml:", "light_field_sensor.position_mm", "inside object 'lens'"}));
}

}  // namespace
