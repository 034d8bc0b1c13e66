// SPDX-License-Identifier: Apache-2.0
// Scene files: the documented keys load into the scene they describe, and
// every kind of bad input, written or seeded, is an error naming file, line
// and key.

#include "lfi/sim/scene_file.h"
#include "lfi/core/exr_io.h"
#include "lfi/core/image.h"

#include "lfi_test_support.h"
#include "scene_file_fixture.h"
#include "toml_mutation.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;
using namespace lfi;
using namespace lfi::sim;
using lfi::testing_support::kCamera;
using lfi::testing_support::SceneFile;
using lfi::testing_support::throwsError;

TEST_F(SceneFile, ReferenceSceneLoadsAsDocumented) {
  const SceneDescription d = loadSceneFile(fs::path(LFI_SOURCE_DIR) / "data" / "scenes" / "reference.toml");
  ASSERT_EQ(d.objects.size(), 2u);
  EXPECT_EQ(d.objects[0].name, "lens");
  EXPECT_DOUBLE_EQ(std::get<Dielectric>(d.objects[0].material).ior, 1.5);
  const auto& cam = std::get<TelecentricCamera>(d.sensor);
  EXPECT_DOUBLE_EQ(cam.focusDistance_mm(), 200);
  EXPECT_NEAR(cam.acceptanceHalfAngle_rad(), 0.01, 1e-6);
  // rotation_deg = [180, 0, 0] at z = 200 is the camera looking down -z.
  const Rigid3 expected = TelecentricCamera::lookingDownFrom(200);
  for (int i = 0; i < 9; ++i) EXPECT_NEAR(cam.worldFromCamera.r[i], expected.r[i], 1e-12);
  EXPECT_EQ(d.render.samplesPerPixel, 16);
  EXPECT_EQ(d.render.splitDepth, 0);
  ASSERT_TRUE(d.objects[1].emission.has_value());
  EXPECT_TRUE(std::holds_alternative<LambertianEmission>(*d.objects[1].emission));
}

TEST_F(SceneFile, UnknownKeyNamesFileLineAndKey) {
  const fs::path f = write("typo.toml", std::string("format = \"lfi-scene\"\nversion = 1\n") + kCamera + R"(
[[object]]
name = "ball"
shape = "sphere"
radius_mm = 10
materal = "absorber"
)");
  EXPECT_TRUE(throwsError([&] { loadSceneFile(f); }, Errc::Config, {f.string() + ":18:", "object[0].materal"}));
  // A misspelt table is named as unknown before anything else is checked (not as a missing sensor).
  std::string camera = kCamera;
  camera.replace(camera.find("[camera]"), 8, "[camra]");
  const fs::path table = write("table-typo.toml", std::string("format = \"lfi-scene\"\nversion = 1\n") + camera +
                                                      "[[object]]\nname = \"ball\"\nshape = \"sphere\"\n");
  EXPECT_TRUE(throwsError([&] { loadSceneFile(table); }, Errc::Config,
                          {table.string() + ":", "unknown key 'camra'", "known here: format, version"}));
}

TEST_F(SceneFile, BadValuesAreErrors) {
  const std::string head = std::string("format = \"lfi-scene\"\nversion = 1\n") + kCamera;
  EXPECT_TRUE(throwsError([&] { loadSceneFile(write("a.toml", head + "[[object]]\nname='x'\nshape='cube'\n")); },
                          Errc::Config, {"object[0].shape", "cube"}));
  EXPECT_TRUE(throwsError(
      [&] { loadSceneFile(write("b.toml", head + "[[object]]\nname='x'\nshape='sphere'\nradius_mm=-1\n")); },
      Errc::Config, {"object[0].radius_mm"}));
  EXPECT_TRUE(throwsError(
      [&] {
        loadSceneFile(write("c.toml", head + "[[object]]\nname='x'\nshape='sphere'\nradius_mm=1\nposition_mm=[1,2]\n"));
      },
      Errc::Config, {"object[0].position_mm", "3 numbers"}));
  EXPECT_TRUE(throwsError([&] { loadSceneFile(write("d.toml", head)); }, Errc::Config, {"no [[object]]"}));
  std::string nearCamera = head;
  nearCamera.replace(nearCamera.find("image_distance_mm = 200"), 23, "image_distance_mm = 90");
  EXPECT_TRUE(throwsError([&] { loadSceneFile(write("near.toml", nearCamera)); }, Errc::Config,
                          {"near.toml:6:", "camera.image_distance_mm", "must exceed focal_length_mm = 100"}));
  EXPECT_TRUE(throwsError(
      [&] {
        loadSceneFile(write("lens.toml", head + "[[object]]\nname='l'\nshape='lens'\nfront_radius_mm=100\n"
                                                "back_radius_mm=-10\ncentre_thickness_mm=7\ndiameter_mm=50\n"));
      },
      Errc::Config, {"lens.toml:", "object[0].back_radius_mm", "semi-diameter 25"}));
  EXPECT_TRUE(throwsError(  // faces of radius 26 on Ø50 sag 18.9 mm each: they meet inside the diameter
      [&] {
        loadSceneFile(write("edge.toml", head + "[[object]]\nname='l'\nshape='lens'\nfront_radius_mm=26\n"
                                                "back_radius_mm=-26\ncentre_thickness_mm=7\ndiameter_mm=50\n"));
      },
      Errc::Config, {"edge.toml:", "object[0].centre_thickness_mm", "the faces meet inside the diameter"}));
  EXPECT_TRUE(throwsError(
      [&] {
        loadSceneFile(write("lfs.toml",
                            "format = \"lfi-scene\"\nversion = 1\n[light_field_sensor]\n"
                            "spatial_x = 32768\nspatial_y = 32768\nangular = 2\npixel_pitch_mm = 0.1\n"
                            "[[object]]\nname='x'\nshape='sphere'\nradius_mm=1\n"));
      },
      Errc::Config, {"lfs.toml:6:", "light_field_sensor.angular", "too large"}));
  EXPECT_TRUE(throwsError(  // 1024 elements of 128 x 100 mm: 13 km wide
      [&] {
        loadSceneFile(write("wide.toml",
                            "format = \"lfi-scene\"\nversion = 1\n[light_field_sensor]\n"
                            "spatial_x = 1024\nspatial_y = 8\nangular = 128\npixel_pitch_mm = 100\n"
                            "[[object]]\nname='x'\nshape='sphere'\nradius_mm=1\n"));
      },
      Errc::Config, {"wide.toml:7:", "light_field_sensor.pixel_pitch_mm", "reaches 6.5536e+06 mm"}));
  EXPECT_TRUE(throwsError(
      [&] {
        loadSceneFile(write("thin.toml", head + "[[object]]\nname='r'\nshape='rectangle'\nsize_mm=[5e-324,10]\n"));
      },
      Errc::Config, {"thin.toml:", "object[0].size_mm"}));
  EXPECT_TRUE(throwsError(
      [&] {
        loadSceneFile(write("spin.toml", head + "[[object]]\nname='r'\nshape='rectangle'\nsize_mm=[1,1]\n"
                                                "rotation_deg=[1e300,0,0]\n"));
      },
      Errc::Config, {"spin.toml:", "object[0].rotation_deg"}));
  EXPECT_TRUE(throwsError(
      [&] {
        loadSceneFile(write(
            "e.toml", "format = \"lfi-scene\"\nversion = 1\n[[object]]\nname='x'\nshape='sphere'\nradius_mm=1\n"));
      },
      Errc::Config, {"exactly one sensor"}));
  EXPECT_TRUE(throwsError([&] { loadSceneFile(write("f.toml", "format = \"lfi-scene\"\nversion = [\n")); },
                          Errc::Config, {"f.toml:"}));
  EXPECT_TRUE(throwsError([&] { loadSceneFile(dir_ / "missing.toml"); }, Errc::NotFound, {"missing.toml"}));
  // A light field emitter whose file is corrupt: the EXR error names that file, and the scene file and key.
  write("lf.exr", "not an exr");
  EXPECT_TRUE(throwsError(
      [&] {
        loadSceneFile(write("g.toml", head + "[[object]]\nname='d'\nshape='rectangle'\nsize_mm=[1,1]\n"
                                             "emitter='light_field'\nlight_field='lf.exr'\n"));
      },
      Errc::InvalidFile, {"g.toml:", "object[0].light_field", "lf.exr"}));
  EXPECT_TRUE(throwsError(
      [&] { loadSceneFile(write("h.toml", head + "[[object]]\nname='m'\nshape='mesh'\nfile='none.ply'\n")); },
      Errc::NotFound, {"h.toml:", "object[0].file", "none.ply"}));
  // More cut-outs than the tracer can follow along one ray: refused at load, not mid-render without a name.
  std::string cuts = head + "[[object]]\nname='holes'\nshape='cylinder'\nradius_mm=2\nlength_mm=100\n";
  for (int i = 0; i < 15; ++i) cuts += fmt::format("[[object.cut]]\nposition_mm=[0, 0, {}]\nradius_mm=1\n", 6 * i - 45);
  EXPECT_TRUE(throwsError([&] { loadSceneFile(write("cuts.toml", cuts)); }, Errc::Config,
                          {"cuts.toml:", "object[0].cut", "15 cut-outs", "at most 14 for this cylinder"}));
  // Objects the scene file refuses, each named by its file, line and key (Errc::Config).
  auto refused = [&](const std::string& name, const std::string& objects, std::vector<std::string> fragments) {
    fragments.push_back(name + ":");
    return throwsError([&] { loadSceneFile(write(name, head + objects)); }, Errc::Config, fragments);
  };
  // A size or position standing in for "infinite": Embree, in float, would drop the object silently.
  EXPECT_TRUE(refused("huge.toml",
                      "[[object]]\nname='l'\nshape='rectangle'\nsize_mm=[1e20, 1e20]\nemitter='lambertian'\n",
                      {"object[0].size_mm", "1e+20 (element 0) is outside"}));
  EXPECT_TRUE(refused("far.toml", "[[object]]\nname='s'\nshape='sphere'\nradius_mm=1\nposition_mm=[0, 0, -2e18]\n",
                      {"object[0].position_mm", "(element 2) is outside"}));
  // Objects are named once each, and not 'display' beside a [display]; cut-outs are for solids.
  const std::string sphere = "[[object]]\nname='a'\nshape='sphere'\nradius_mm=1\n";
  EXPECT_TRUE(
      refused("twice.toml", sphere + sphere, {"object[1].name", "'a' names another object too", "object[0].name"}));
  EXPECT_TRUE(
      refused("unnamed.toml", "[[object]]\nname=''\nshape='sphere'\nradius_mm=1\n", {"object[0].name", "is empty"}));
  EXPECT_TRUE(refused("cut-rect.toml",
                      "[[object]]\nname='r'\nshape='rectangle'\nsize_mm=[1,1]\n"
                      "[[object.cut]]\nposition_mm=[0,0,0]\nradius_mm=0.1\n",
                      {"object[0].cut", "apply to solids", "not to a rectangle"}));
  // An emitter with a material: its ior would be read and never used (an emitting object is opaque).
  EXPECT_TRUE(refused("glowing.toml",
                      "[[object]]\nname='g'\nshape='sphere'\nradius_mm=5\nmaterial='dielectric'\nior=1.5\n"
                      "emitter='lambertian'\n",
                      {"object[0].material", "an emitting object is opaque"}));
  // A camera of more pixels than its image could be written with (each side in range).
  std::string big = std::string("format = \"lfi-scene\"\nversion = 1\n") + kCamera;
  big = big.replace(big.find("width = 16"), 10, "width = 65536").replace(big.find("height = 16"), 11, "height = 16385");
  EXPECT_TRUE(throwsError([&] { loadSceneFile(write("big.toml", big)); }, Errc::Config,
                          {"big.toml:", "camera.height", "65536 x 16385 pixels", "2^30"}));
  // A panel's response: a table that falls, that does not end at full light, or both a table and a gamma.
  EXPECT_TRUE(refused("falling.toml", "[display]\nresponse_table = [0, 0.6, 0.5, 1]\n",
                      {"display.response_table", "element 2 (0.5) is below element 1 (0.6)"}));
  EXPECT_TRUE(refused("short.toml", "[display]\nresponse_table = [0, 0.5, 0.9]\n",
                      {"display.response_table", "the last element is 0.9, not 1"}));
  EXPECT_TRUE(refused("both.toml", "[display]\nresponse_table = [0, 1]\nresponse_gamma = 2.2\n",
                      {"display.response_table", "not both"}));
  EXPECT_TRUE(refused("one.toml", "[display]\nresponse_table = [1]\n",
                      {"display.response_table", "an array of 2 to 4096 numbers"}));
  // The camera's fixed pattern: a black level past half the ADC's range is a wrong unit.
  EXPECT_TRUE(refused("black.toml", "[camera_sensor]\nbit_depth = 8\nblack_level_dn = 200\n",
                      {"camera_sensor.black_level_dn", "outside [0, 127.5]"}));

  const std::string ball = "[[object]]\nname='b'\nshape='sphere'\nradius_mm=1\n";
  EXPECT_EQ(loadSceneFile(write("seed.toml", head + ball + "[render]\nseed = 9223372036854775807\n")).render.seed,
            9223372036854775807ull);
  EXPECT_TRUE(throwsError([&] { loadSceneFile(write("seed.toml", head + ball + "[render]\nseed = -1\n")); },
                          Errc::Config, {"seed.toml:", "render.seed", "outside [0, 9223372036854775807]"}));
  // A cut-out that misses the part (here, a position in the world's frame where the object's was meant) or
  // holds all of it.
  const std::string part =
      head + "[[object]]\nname='lens'\nshape='sphere'\nradius_mm=5\nposition_mm=[0, 0, -30]\n[[object.cut]]\n";
  EXPECT_TRUE(throwsError(
      [&] { loadSceneFile(write("far-cut.toml", part + "position_mm=[0, 1, -30]\nradius_mm=0.5\n")); }, Errc::Config,
      {"far-cut.toml:", "object[0].cut[0].position_mm", "does not meet the part", "[-5, -5, -5]"}));
  EXPECT_TRUE(
      throwsError([&] { loadSceneFile(write("off-cut.toml", part + "position_mm=[0, 5.5, 5.5]\nradius_mm=0.5\n")); },
                  Errc::Config, {"off-cut.toml:", "does not meet the part"}));
  EXPECT_TRUE(throwsError([&] { loadSceneFile(write("big-cut.toml", part + "position_mm=[0, 0, 0]\nradius_mm=9\n")); },
                          Errc::Config, {"big-cut.toml:", "object[0].cut[0].radius_mm", "holds the whole part"}));
  // A bubble inside, and a nick at the top of the sphere that only just reaches the box, are kept.
  EXPECT_NO_THROW(loadSceneFile(write("bubble.toml", part + "position_mm=[0, 1, 2]\nradius_mm=0.5\n")));
  EXPECT_NO_THROW(loadSceneFile(write("nick.toml", part + "position_mm=[0, 0, 5.4]\nradius_mm=0.5\n")));
  // Two cut-outs that each leave part of the box but together hold the whole ball (radius 5): every point
  // of it is within sqrt(5^2 + 3^2) = 5.83 mm of the nearer centre.
  EXPECT_TRUE(throwsError(
      [&] {
        loadSceneFile(write("two-cuts.toml", part + "position_mm=[3, 0, 0]\nradius_mm=7\n"
                                                    "[[object.cut]]\nposition_mm=[-3, 0, 0]\nradius_mm=7\n"));
      },
      Errc::Config, {"two-cuts.toml:", "object[0].cut[1].radius_mm", "together leave nothing"}));
  EXPECT_NO_THROW(
      loadSceneFile(write("two-nicks.toml", part + "position_mm=[3, 0, 0]\nradius_mm=5\n"
                                                   "[[object.cut]]\nposition_mm=[-3, 0, 0]\nradius_mm=5\n")));
  // Parts thinner than the tracer can follow (its least hit distance is 1e-6 mm): at least 1 µm.
  EXPECT_TRUE(throwsError(
      [&] {
        loadSceneFile(write("thin.toml", head + "[[object]]\nname='t'\nshape='lens'\nfront_radius_mm=0\n"
                                                "back_radius_mm=0\ncentre_thickness_mm=1e-6\ndiameter_mm=5\n"));
      },
      Errc::Config, {"thin.toml:", "object[0].centre_thickness_mm", "outside [0.001"}));
  // A biconcave lens crosses a line in up to three pieces: two cut-outs fewer than a sphere takes.
  std::string biconcave = head +
                          "[[object]]\nname='b'\nshape='lens'\nfront_radius_mm=-15\nback_radius_mm=15\n"
                          "centre_thickness_mm=1\ndiameter_mm=20\n";
  for (int i = 0; i < 13; ++i)
    biconcave += fmt::format("[[object.cut]]\nposition_mm=[0, {}, 4]\nradius_mm=0.1\n", i - 6);
  EXPECT_TRUE(throwsError([&] { loadSceneFile(write("biconcave.toml", biconcave)); }, Errc::Config,
                          {"biconcave.toml:", "object[0].cut", "13 cut-outs", "at most 12 for this lens"}));
  // A camera focused so far away (b a hair past f) that its field leaves any bench: refused at image_distance_mm.
  std::string far = std::string("format = \"lfi-scene\"\nversion = 1\n") + kCamera + ball;
  far.replace(far.find("image_distance_mm = 200"), 23, "image_distance_mm = 100.0000001");
  EXPECT_TRUE(throwsError([&] { loadSceneFile(write("far-focus.toml", far)); }, Errc::Config,
                          {"far-focus.toml:", "camera.image_distance_mm", "past 1e+06 mm"}));
  // A light field emitter is a rectangle of the light field's extent: 4 x 3 elements of 2 x 0.5 mm.
  writeLightFieldExr(dir_ / "good.exr",
                     LightField({.spatialX = 4, .spatialY = 3, .angular = 2, .pixelPitch_mm = 0.5, .distance_mm = 30}));
  auto display = [&](const std::string& shape) {
    return head + "[[object]]\nname='d'\n" + shape + "emitter='light_field'\nlight_field='good.exr'\n";
  };
  EXPECT_NO_THROW(loadSceneFile(write("i.toml", display("shape='rectangle'\nsize_mm=[4,3]\n"))));
  EXPECT_TRUE(throwsError([&] { loadSceneFile(write("j.toml", display("shape='rectangle'\nsize_mm=[4,4]\n"))); },
                          Errc::Config, {"j.toml:", "object[0].size_mm", "[4, 3] mm"}));
  EXPECT_TRUE(throwsError([&] { loadSceneFile(write("k.toml", display("shape='sphere'\nradius_mm=2\n"))); },
                          Errc::Config, {"k.toml:", "object[0].emitter", "rectangle"}));
}

TEST_F(SceneFile, MutatedValuesLoadAsScenesThatRenderOrAreNamedErrors) {
  // Seeded value edits of the two shipped scene files (toml_mutation.h: NaN,
  // infinities, extremes, signs, integers past 32 bits, other words, other
  // types, keys and tables removed or repeated, unknown keys). Each file
  // either loads as a scene that renders finite, non-negative radiance (on
  // a crop of at most 8 x 8 pixels, 2 samples each) or is an lfi::Error
  // naming the file; never a crash, a hang or another exception.
  const fs::path scenes = fs::path(LFI_SOURCE_DIR) / "data" / "scenes";
  std::vector<std::string> seeds;
  for (const char* name : {"reference.toml", "inspection_bench.toml"}) {
    std::ifstream in(scenes / name);
    seeds.emplace_back(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  std::mt19937 rng(20261123);
  int rendered = 0, refused = 0;
  for (int n = 0; n < 2000; ++n) {
    std::string what;
    const std::string text = lfi::testing_support::mutateTomlValues(seeds[n % seeds.size()], rng, 3, what);
    SCOPED_TRACE(fmt::format("case {}: {}", n, what));
    const fs::path file = write("mutated.toml", text);
    SceneDescription d;
    try {
      d = loadSceneFile(file);
    } catch (const Error& e) {
      ASSERT_NE(std::string(e.what()).find(file.string()), std::string::npos) << e.what();
      ++refused;
      continue;
    }
    if (auto* cam = std::get_if<TelecentricCamera>(&d.sensor)) {
      cam->width = std::min(cam->width, 8);
      cam->height = std::min(cam->height, 8);
    } else {
      LightFieldGeometry& g = std::get<LightFieldSensor>(d.sensor).geometry;
      g.spatialX = std::min(g.spatialX, 2);
      g.spatialY = std::min(g.spatialY, 2);
      g.angular = std::min(g.angular, 4);
    }
    d.render.samplesPerPixel = std::min(d.render.samplesPerPixel, 2);
    d.render.threads = 1;
    const Scene scene(std::move(d.objects), d.ambientIor);
    cv::Mat image;
    try {
      image = render(scene, d.sensor, d.render);
    } catch (const Error& e) {  // (only a path in too many nested dielectrics may stop a render)
      ASSERT_EQ(e.code(), Errc::Config) << e.what();
      ASSERT_NE(std::string(e.what()).find("nested dielectrics"), std::string::npos) << e.what();
    }
    ASSERT_FALSE(lfi::firstNonFinite(image).has_value());
    ASSERT_FALSE(lfi::firstNegative(image).has_value());
    ++rendered;
  }
  // Both outcomes occur: the edits reach the checks of values, and many leave a scene
  // (150 of the 2000 since rotations and rectangle sizes have ranges).
  EXPECT_GT(rendered, 100);
  EXPECT_GT(refused, 1000);
}

}  // namespace
