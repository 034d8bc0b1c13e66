// Scene files: the documented keys load into the scene they describe, and
// every kind of bad input is an error naming file, line and key.

#include "lfi/core/exr_io.h"
#include "lfi/core/image.h"
#include "lfi/sim/scene_file.h"

#include "lfi_test_support.h"
#include "toml_mutation.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <numbers>
#include <random>

namespace {

namespace fs = std::filesystem;
using namespace lfi;
using namespace lfi::sim;
using lfi::testing_support::throwsError;

class SceneFile : public testing::Test {
protected:
  void SetUp() override {
    dir_ = fs::path(testing::TempDir()) / ("lfi_scene_" + std::to_string(::getpid()) + "_" +
                                           testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path write(const std::string& name, const std::string& text) {
    std::ofstream(dir_ / name) << text;
    return dir_ / name;
  }
  fs::path dir_;
};

const char* kCamera = R"(
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
  const SceneDescription none = loadSceneFile(write("no-cut.toml", std::string("format = \"lfi-scene\"\nversion = 1\n") +
                                                                      kCamera + R"(
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
  EXPECT_TRUE(throwsError([&] { loadSceneFile(table); }, Errc::Config, {table.string() + ":", "unknown key 'camra'",
                                                                        "known here: format, version"}));
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
  EXPECT_TRUE(refused("twice.toml", sphere + sphere,
                      {"object[1].name", "'a' names another object too", "object[0].name"}));
  EXPECT_TRUE(refused("unnamed.toml", "[[object]]\nname=''\nshape='sphere'\nradius_mm=1\n",
                      {"object[0].name", "is empty"}));
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
  // Seeds: TOML's whole range of non-negative integers, the range `lfi render --seed` takes.
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
      [&] { loadSceneFile(write("far-cut.toml", part + "position_mm=[0, 1, -30]\nradius_mm=0.5\n")); },
      Errc::Config, {"far-cut.toml:", "object[0].cut[0].position_mm", "does not meet the part", "[-5, -5, -5]"}));
  EXPECT_TRUE(throwsError(
      [&] { loadSceneFile(write("off-cut.toml", part + "position_mm=[0, 5.5, 5.5]\nradius_mm=0.5\n")); },
      Errc::Config, {"off-cut.toml:", "does not meet the part"}));
  EXPECT_TRUE(throwsError(
      [&] { loadSceneFile(write("big-cut.toml", part + "position_mm=[0, 0, 0]\nradius_mm=9\n")); },
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
  EXPECT_NO_THROW(loadSceneFile(write("two-nicks.toml", part + "position_mm=[3, 0, 0]\nradius_mm=5\n"
                                                               "[[object.cut]]\nposition_mm=[-3, 0, 0]\nradius_mm=5\n")));
  // Parts thinner than the tracer can follow (its least hit distance is 1e-6 mm): at least 1 µm.
  EXPECT_TRUE(throwsError(
      [&] { loadSceneFile(write("thin.toml", head + "[[object]]\nname='t'\nshape='lens'\nfront_radius_mm=0\n"
                                                    "back_radius_mm=0\ncentre_thickness_mm=1e-6\ndiameter_mm=5\n")); },
      Errc::Config, {"thin.toml:", "object[0].centre_thickness_mm", "outside [0.001"}));
  // A biconcave lens crosses a line in up to three pieces: two cut-outs fewer than a sphere takes.
  std::string biconcave = head + "[[object]]\nname='b'\nshape='lens'\nfront_radius_mm=-15\nback_radius_mm=15\n"
                                 "centre_thickness_mm=1\ndiameter_mm=20\n";
  for (int i = 0; i < 13; ++i) biconcave += fmt::format("[[object.cut]]\nposition_mm=[0, {}, 4]\nradius_mm=0.1\n", i - 6);
  EXPECT_TRUE(throwsError([&] { loadSceneFile(write("biconcave.toml", biconcave)); }, Errc::Config,
                          {"biconcave.toml:", "object[0].cut", "13 cut-outs", "at most 12 for this lens"}));
  // A camera focused so far away (b a hair past f) that its field leaves any bench: refused at image_distance_mm.
  std::string far = std::string("format = \"lfi-scene\"\nversion = 1\n") + kCamera + ball;
  far.replace(far.find("image_distance_mm = 200"), 23, "image_distance_mm = 100.0000001");
  EXPECT_TRUE(throwsError([&] { loadSceneFile(write("far-focus.toml", far)); }, Errc::Config,
                          {"far-focus.toml:", "camera.image_distance_mm", "past 1e+06 mm"}));
  // A light field emitter is a rectangle of the light field's extent: 4 x 3 elements of 2 x 0.5 mm.
  writeLightFieldExr(dir_ / "good.exr", LightField({.spatialX = 4, .spatialY = 3, .angular = 2, .pixelPitch_mm = 0.5,
                                                    .distance_mm = 30}));
  auto display = [&](const std::string& shape) {
    return head + "[[object]]\nname='d'\n" + shape + "emitter='light_field'\nlight_field='good.exr'\n";
  };
  EXPECT_NO_THROW(loadSceneFile(write("i.toml", display("shape='rectangle'\nsize_mm=[4,3]\n"))));
  EXPECT_TRUE(throwsError([&] { loadSceneFile(write("j.toml", display("shape='rectangle'\nsize_mm=[4,4]\n"))); },
                          Errc::Config, {"j.toml:", "object[0].size_mm", "[4, 3] mm"}));
  EXPECT_TRUE(throwsError([&] { loadSceneFile(write("k.toml", display("shape='sphere'\nradius_mm=2\n"))); },
                          Errc::Config, {"k.toml:", "object[0].emitter", "rectangle"}));
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
        loadSceneFile(write("d.toml", "format = \"lfi-scene\"\nversion = 1\n[light_field_sensor]\n"
                                      "spatial_x = 8\nspatial_y = 8\nangular = 4\npixel_pitch_mm = 0.1\n"
                                      "[[object]]\nname='lens'\nshape='lens'\nfront_radius_mm=100\n"
                                      "back_radius_mm=-100\ncentre_thickness_mm=7\ndiameter_mm=50\n"));
      },
      Errc::Config, {"d.toml:", "light_field_sensor.position_mm", "inside object 'lens'"}));
}

TEST_F(SceneFile, MeshesLoadWithOutwardSmoothNormals) {
  // An octahedron, as OBJ and as PLY: 6 vertices, 8 outward-wound triangles.
  write("octa.obj",
        "v 1 0 0\nv -1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nv 0 0 -1\n"
        "f 1 3 5\nf 3 2 5\nf 2 4 5\nf 4 1 5\nf 3 1 6\nf 2 3 6\nf 4 2 6\nf 1 4 6\n");
  write("octa.ply",
        "ply\nformat ascii 1.0\nelement vertex 6\nproperty float x\nproperty float y\nproperty float z\n"
        "element face 8\nproperty list uchar int vertex_indices\nend_header\n"
        "1 0 0\n-1 0 0\n0 1 0\n0 -1 0\n0 0 1\n0 0 -1\n"
        "3 0 2 4\n3 2 1 4\n3 1 3 4\n3 3 0 4\n3 2 0 5\n3 1 2 5\n3 3 1 5\n3 0 3 5\n");
  for (const char* file : {"octa.obj", "octa.ply"}) {
    SCOPED_TRACE(file);
    const TriangleMesh mesh = loadMesh(dir_ / file, std::numbers::pi);  // smooth across every edge
    ASSERT_EQ(mesh.vertices.size(), 6u);
    ASSERT_EQ(mesh.triangles.size(), 8u);
    ASSERT_EQ(mesh.normals.size(), 6u);
    // By symmetry each vertex normal points along the vertex itself.
    for (size_t i = 0; i < 6; ++i) EXPECT_NEAR(mesh.normals[i].dot(mesh.vertices[i]), 1.0, 1e-6);
    // Outward winding: every face normal points away from the centre.
    for (const auto& t : mesh.triangles) {
      const Vec3 n = (mesh.vertices[t[1]] - mesh.vertices[t[0]]).cross(mesh.vertices[t[2]] - mesh.vertices[t[0]]);
      EXPECT_GT(n.dot(mesh.vertices[t[0]] + mesh.vertices[t[1]] + mesh.vertices[t[2]]), 0);
    }
  }
  write("bad.obj", "v 0 0 0\nv 1 0 0\nf 1 2 7\n");
  EXPECT_TRUE(throwsError([&] { loadMesh(dir_ / "bad.obj"); }, Errc::InvalidFile, {(dir_ / "bad.obj").string()}));
  write("text.ply", "this is not a mesh\n");
  EXPECT_TRUE(throwsError([&] { loadMesh(dir_ / "text.ply"); }, Errc::InvalidFile, {"text.ply"}));
  EXPECT_TRUE(throwsError([&] { loadMesh(dir_ / "none.obj"); }, Errc::NotFound, {"none.obj"}));
}

// A bent sheet stored double-sided (both layers on the same vertices, wound
// apart): its inner edge has four faces; each layer still shades smoothly
// across it (its two faces meet at 10 degrees), and the layers do not blend.
TEST_F(SceneFile, ADoubleSidedSheetShadesSmoothlyOnEachSide) {
  const double s = std::sin(10 * std::numbers::pi / 180), c = std::cos(10 * std::numbers::pi / 180);
  // Two unit squares hinged along x = 0 (the second turned up by 10 degrees), as 4 triangles a layer.
  write("sheet.obj", fmt::format("v -1 0 0\nv -1 1 0\nv 0 0 0\nv 0 1 0\nv {} 0 {}\nv {} 1 {}\n"
                                 "f 1 3 4\nf 1 4 2\nf 3 5 6\nf 3 6 4\n"    // up (+z)
                                 "f 1 4 3\nf 1 2 4\nf 3 6 5\nf 3 4 6\n",  // down
                                 c, s, c, s));
  const TriangleMesh sheet = loadMesh(dir_ / "sheet.obj");
  // Every corner on the hinge (x = 0) has its layer's smooth normal, an
  // area-weighted mean of the faces on both sides: within 10 degrees of its
  // face's normal but not along it (flat) and not blended with the other
  // layer (which would turn it by 90 degrees or more).
  int hinge = 0;
  for (const auto& t : sheet.triangles) {
    const Vec3 n = (sheet.vertices[t[1]] - sheet.vertices[t[0]]).cross(sheet.vertices[t[2]] - sheet.vertices[t[0]])
                       .normalized();
    for (const unsigned v : t)
      if (std::abs(sheet.vertices[v].x) < 1e-9) {
        ++hinge;
        EXPECT_GT(sheet.normals[v].dot(n), c - 1e-9);
        EXPECT_LT(sheet.normals[v].dot(n), 1 - 1e-6);
      }
  }
  EXPECT_EQ(hinge, 12);  // 6 corners a layer: 2, 1, 1 and 2 of its four faces
}

// A mesh in metres (as glTF files are) comes in at its size with scale = 1000.
TEST_F(SceneFile, AMeshScaleGivesTheFilesUnit) {
  write("metres.obj", "v 0.001 0 0\nv -0.001 0 0\nv 0 0.001 0\nv 0 -0.001 0\nv 0 0 0.001\nv 0 0 -0.001\n"
                      "f 1 3 5\nf 3 2 5\nf 2 4 5\nf 4 1 5\nf 3 1 6\nf 2 3 6\nf 4 2 6\nf 1 4 6\n");
  auto scene = [&](const std::string& name, const std::string& scale) {
    return write(name, std::string("format = \"lfi-scene\"\nversion = 1\n") + kCamera +
                           "[[object]]\nname='m'\nshape='mesh'\nfile='metres.obj'\nmaterial='dielectric'\nior=1.5\n" +
                           scale + "position_mm=[0, 0, -20]\n");
  };
  const SceneDescription d = loadSceneFile(scene("metres.toml", "scale=1000\n"));
  const Bounds box = worldBounds(d.objects[0]);
  EXPECT_NEAR(box.hi.x - box.lo.x, 2.0, 1e-6);  // the octahedron's 2 mm across (Assimp reads floats)
  EXPECT_NEAR(box.hi.z - box.lo.z, 2.0, 1e-6);
  EXPECT_TRUE(throwsError([&] { loadSceneFile(scene("zero.toml", "scale=0\n")); }, Errc::Config,
                          {"zero.toml:", "object[0].scale", "outside"}));
}

// Normals are smooth across gentle edges and sharp across creases (30 degrees
// by default): a tessellated sphere shades smoothly, a glass cube's faces stay
// flat. With smooth normals everywhere, a cube of 8 shared vertices bends a
// ray that meets its face square on, as a lens would.
TEST_F(SceneFile, MeshNormalsAreSharpAcrossCreases) {
  write("octa.obj", "v 1 0 0\nv -1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nv 0 0 -1\n"
                    "f 1 3 5\nf 3 2 5\nf 2 4 5\nf 4 1 5\nf 3 1 6\nf 2 3 6\nf 4 2 6\nf 1 4 6\n");
  // The octahedron's face normals are 70.5 degrees apart across every edge.
  const TriangleMesh smooth = loadMesh(dir_ / "octa.obj", std::numbers::pi), sharp = loadMesh(dir_ / "octa.obj");
  EXPECT_EQ(smooth.vertices.size(), 6u);
  ASSERT_EQ(sharp.vertices.size(), 24u);  // each vertex once per face around it
  ASSERT_EQ(sharp.normals.size(), 24u);
  for (size_t i = 0; i < 6; ++i) EXPECT_EQ(sharp.vertices[i], smooth.vertices[i]);  // the first copy keeps its index
  for (const auto& t : sharp.triangles) {
    const Vec3 n =
        (sharp.vertices[t[1]] - sharp.vertices[t[0]]).cross(sharp.vertices[t[2]] - sharp.vertices[t[0]]).normalized();
    for (const unsigned i : t) EXPECT_NEAR((sharp.normals[i] - n).length(), 0, 1e-12);
  }
  EXPECT_EQ(meshClosureFault(sharp), std::nullopt);  // the copies weld back: still one closed surface
  EXPECT_EQ(loadMesh(dir_ / "octa.obj", 71 * std::numbers::pi / 180).vertices.size(), 6u);

  // A UV sphere of 24 x 12 faces (neighbours 15 degrees apart) keeps every vertex once, its normals near radial.
  const int segments = 24, rings = 12;
  std::vector<Vec3> points{{0, 0, 1}};
  for (int r = 1; r < rings; ++r)
    for (int k = 0; k < segments; ++k) {
      const double theta = std::numbers::pi * r / rings, phi = 2 * std::numbers::pi * k / segments;
      points.push_back({std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)});
    }
  points.push_back({0, 0, -1});
  auto ring = [&](int r, int k) { return 1 + (r - 1) * segments + (k % segments); };
  std::vector<std::array<int, 3>> faces;
  for (int k = 0; k < segments; ++k) {
    faces.push_back({0, ring(1, k), ring(1, k + 1)});
    for (int r = 1; r + 1 < rings; ++r) {
      faces.push_back({ring(r, k), ring(r + 1, k), ring(r + 1, k + 1)});
      faces.push_back({ring(r, k), ring(r + 1, k + 1), ring(r, k + 1)});
    }
    faces.push_back({ring(rings - 1, k), static_cast<int>(points.size()) - 1, ring(rings - 1, k + 1)});
  }
  std::string ply = fmt::format("ply\nformat ascii 1.0\nelement vertex {}\nproperty double x\nproperty double y\n"
                                "property double z\nelement face {}\nproperty list uchar int vertex_indices\n"
                                "end_header\n", points.size(), faces.size());
  for (const Vec3& q : points) ply += fmt::format("{} {} {}\n", q.x, q.y, q.z);
  for (const auto& f : faces) ply += fmt::format("3 {} {} {}\n", f[0], f[1], f[2]);
  write("sphere.ply", ply);
  const TriangleMesh sphere = loadMesh(dir_ / "sphere.ply");
  EXPECT_EQ(meshClosureFault(sphere), std::nullopt);  // (wound outwards)
  ASSERT_EQ(sphere.vertices.size(), points.size());
  for (size_t i = 0; i < points.size(); ++i) EXPECT_GT(sphere.normals[i].dot(points[i]), std::cos(0.05)) << i;

  // A glass cube of 8 shared vertices (corners (+-1, +-1, +-1)); a ray along +z through (0.3, 0.4).
  write("cube.ply", "ply\nformat ascii 1.0\nelement vertex 8\nproperty float x\nproperty float y\n"
                    "property float z\nelement face 12\nproperty list uchar int vertex_indices\nend_header\n"
                    "-1 -1 -1\n1 -1 -1\n-1 1 -1\n1 1 -1\n-1 -1 1\n1 -1 1\n-1 1 1\n1 1 1\n"
                    "3 0 2 3\n3 0 3 1\n3 4 5 7\n3 4 7 6\n3 0 1 5\n3 0 5 4\n3 2 6 7\n3 2 7 3\n"
                    "3 0 4 6\n3 0 6 2\n3 1 3 7\n3 1 7 5\n");
  auto exitDirection = [&](double crease) {
    const Scene scene({Object{"cube", loadMesh(dir_ / "cube.ply", crease), Rigid3{}, Dielectric{1.5, 0}}});
    const std::vector<Vec3> path = refractionPath(scene, Ray{{0.3, 0.4, -5}, {0, 0, 1}}, 8, 100);
    EXPECT_EQ(path.size(), 4u);  // in, through, out
    return (path.back() - path[path.size() - 2]).normalized();
  };
  EXPECT_LT((exitDirection(30 * std::numbers::pi / 180) - Vec3(0, 0, 1)).length(), 1e-9);
  EXPECT_GT((exitDirection(std::numbers::pi) - Vec3(0, 0, 1)).length(), 1e-2);  // smoothed: bent as by a lens

  // Smoothed, the normal near the cube's edge at x = -1 leans far out of the bottom face: a ray leaving through
  // that face there (d.Ng > 0) would meet the smoothed normal from the inside (d.Ns < 0) and count as entering.
  // The hit's normal keeps the side the geometry gives.
  const Scene smoothCube(
      {Object{"cube", loadMesh(dir_ / "cube.ply", std::numbers::pi), Rigid3{}, Dielectric{1.5, 0}}});
  const Vec3 d = Vec3(0.9, 0, -0.3).normalized(), at(-0.95, 0, -1);
  const Hit hit = smoothCube.intersect(Ray{at - d * 0.05, d});
  ASSERT_TRUE(hit.valid());
  EXPECT_NEAR(hit.point.z, -1, 1e-6);
  EXPECT_GT(hit.normal.dot(d), 0) << "leaving the cube; normal " << hit.normal;
}

// The tracer enters and leaves a dielectric through its surface: a mesh with
// a hole, a face wound the wrong way, or all faces wound inwards would give
// wrong refraction without a word. Such a dielectric is refused, naming the
// file and an edge; an opaque mesh may be an open surface.
TEST_F(SceneFile, ADielectricMeshMustBoundASolid) {
  const std::string vertices = "v 1 0 0\nv -1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nv 0 0 -1\n";
  const std::string faces[8] = {"1 3 5", "3 2 5", "2 4 5", "4 1 5", "3 1 6", "2 3 6", "4 2 6", "1 4 6"};
  auto obj = [&](const std::string& name, auto&& face) {
    std::string text = vertices;
    for (int f = 0; f < 8; ++f) text += face(f);
    return write(name, text);
  };
  auto scene = [&](const std::string& name, const fs::path& mesh, const std::string& material) {
    return write(name, std::string("format = \"lfi-scene\"\nversion = 1\n") + kCamera +
                           "[[object]]\nname='m'\nshape='mesh'\nfile='" + mesh.filename().string() +
                           "'\nmaterial='" + material + "'\n" + (material == "dielectric" ? "ior=1.5\n" : ""));
  };
  obj("closed.obj", [&](int f) { return "f " + faces[f] + "\n"; });
  EXPECT_NO_THROW(loadSceneFile(scene("closed.toml", dir_ / "closed.obj", "dielectric")));
  EXPECT_EQ(meshClosureFault(loadMesh(dir_ / "closed.obj")), std::nullopt);

  obj("holed.obj", [&](int f) { return f == 7 ? std::string() : "f " + faces[f] + "\n"; });
  EXPECT_TRUE(throwsError([&] { loadSceneFile(scene("holed.toml", dir_ / "holed.obj", "dielectric")); },
                          Errc::Config, {"holed.toml:", "object[0].file", "holed.obj", "not closed", "a hole"}));
  EXPECT_NO_THROW(loadSceneFile(scene("screen.toml", dir_ / "holed.obj", "absorber")));

  obj("flipped.obj", [&](int f) {  // one face's vertex order reversed
    return f == 0 ? std::string("f 5 3 1\n") : "f " + faces[f] + "\n";
  });
  EXPECT_TRUE(throwsError([&] { loadSceneFile(scene("flipped.toml", dir_ / "flipped.obj", "dielectric")); },
                          Errc::Config,
                          {"flipped.obj", "not consistently wound", "2 time(s) this way and 0 the other"}));

  obj("inwards.obj", [&](int f) {  // every face reversed: closed, enclosing -4/3 mm^3
    const std::string& t = faces[f];
    return "f " + t.substr(4, 1) + " " + t.substr(2, 1) + " " + t.substr(0, 1) + "\n";
  });
  EXPECT_TRUE(throwsError([&] { loadSceneFile(scene("inwards.toml", dir_ / "inwards.obj", "dielectric")); },
                          Errc::Config, {"inwards.obj", "wound inwards", "-1.33333 mm^3"}));

  // Every face with vertices of its own (as STL stores them): the same positions, one closed surface.
  std::string ply = "ply\nformat ascii 1.0\nelement vertex 24\nproperty float x\nproperty float y\n"
                    "property float z\nelement face 8\nproperty list uchar int vertex_indices\nend_header\n";
  const char* corner[6] = {"1 0 0", "-1 0 0", "0 1 0", "0 -1 0", "0 0 1", "0 0 -1"};
  for (const std::string& f : faces)
    for (int k = 0; k < 3; ++k) ply += std::string(corner[f[2 * k] - '1']) + "\n";
  for (int f = 0; f < 8; ++f) ply += fmt::format("3 {} {} {}\n", 3 * f, 3 * f + 1, 3 * f + 2);
  write("unwelded.ply", ply);
  // Its corners are joined for the normals, which stay flat: the faces meet at 109.5 degrees, past the crease.
  const TriangleMesh unwelded = loadMesh(dir_ / "unwelded.ply");
  for (const auto& t : unwelded.triangles) {
    const Vec3 n = (unwelded.vertices[t[1]] - unwelded.vertices[t[0]])
                       .cross(unwelded.vertices[t[2]] - unwelded.vertices[t[0]])
                       .normalized();
    for (const unsigned v : t) EXPECT_NEAR(unwelded.normals[v].dot(n), 1, 1e-12);
  }
  EXPECT_NO_THROW(loadSceneFile(scene("unwelded.toml", dir_ / "unwelded.ply", "dielectric")));

  // The camera's plane (z = 200) through the closed octahedron: its rays would start inside the mesh. An open
  // surface there has no inside.
  auto placed = [&](const std::string& name, const char* mesh, const char* material) {
    return write(name, std::string("format = \"lfi-scene\"\nversion = 1\n") + kCamera +
                           "[[object]]\nname='m'\nshape='mesh'\nfile='" + mesh + "'\nmaterial='" + material +
                           "'\n" + (std::string(material) == "dielectric" ? "ior=1.5\n" : "") +
                           "position_mm=[0.1, 0.2, 200]\n");
  };
  EXPECT_TRUE(throwsError([&] { loadSceneFile(placed("inside.toml", "closed.obj", "dielectric")); }, Errc::Config,
                          {"inside.toml", "inside object 'm'"}));
  EXPECT_NO_THROW(loadSceneFile(placed("open.toml", "holed.obj", "diffuse")));

  // A rectangle has no inside either: a dielectric one is refused, naming the key.
  EXPECT_TRUE(throwsError(
      [&] {
        loadSceneFile(write("pane.toml", std::string("format = \"lfi-scene\"\nversion = 1\n") + kCamera +
                                             "[[object]]\nname='pane'\nshape='rectangle'\nsize_mm=[10, 10]\n"
                                             "material='dielectric'\nior=1.5\n"));
      },
      Errc::Config, {"pane.toml:", "object[0].material", "a rectangle has no inside"}));
}

// A mesh of several closed parts: each is wound outwards, but a cavity (a part
// inside another), which is wound inwards. The whole mesh's volume alone
// passes a small part wound the wrong way beside a large one wound right.
TEST_F(SceneFile, EachPartOfAMeshIsWoundOutwardsButCavities) {
  const Vec3 corner[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  const unsigned faces[8][3] = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4}, {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  // An octahedron of 2 mm across at the origin, and another of `scale` at `centre`, wound as `outwards` says.
  auto twoParts = [&](double scale, const Vec3& centre, bool outwards) {
    TriangleMesh mesh;
    for (const Vec3& c : corner) mesh.vertices.push_back(c);
    for (const Vec3& c : corner) mesh.vertices.push_back(centre + c * scale);
    for (const auto& f : faces) mesh.triangles.push_back({f[0], f[1], f[2]});
    for (const auto& f : faces)
      mesh.triangles.push_back(outwards ? std::array<unsigned, 3>{f[0] + 6, f[1] + 6, f[2] + 6}
                                        : std::array<unsigned, 3>{f[2] + 6, f[1] + 6, f[0] + 6});
    return mesh;
  };
  EXPECT_EQ(meshClosureFault(twoParts(0.5, {5, 0, 0}, true)), std::nullopt);  // two solids
  const auto wrong = meshClosureFault(twoParts(0.5, {5, 0, 0}, false));       // total volume 4/3 - 1/6 > 0
  ASSERT_TRUE(wrong.has_value());
  EXPECT_NE(wrong->find("a part wound the wrong way"), std::string::npos) << *wrong;
  EXPECT_NE(wrong->find("triangle 8"), std::string::npos) << *wrong;
  EXPECT_NE(wrong->find("-0.166667 mm^3"), std::string::npos) << *wrong;
  EXPECT_NE(wrong->find("a solid must be wound outwards"), std::string::npos) << *wrong;
  EXPECT_EQ(meshClosureFault(twoParts(0.5, {0.1, 0.05, 0}, false)), std::nullopt);  // a hollow: cavity wound inwards
  const auto cavity = meshClosureFault(twoParts(0.5, {0.1, 0.05, 0}, true));
  ASSERT_TRUE(cavity.has_value());
  EXPECT_NE(cavity->find("a cavity must be wound inwards"), std::string::npos) << *cavity;
  // Two shells crossing each other (never merged into one solid): half of each lies inside the other, so neither
  // is a cavity nor a solid beside it. No verdict on their winding.
  EXPECT_EQ(meshClosureFault(twoParts(1, {0.5, 0, 0}, true)), std::nullopt);
  // Many parts (the check looks for the parts around a point on a grid): the hollow, an island in its cavity
  // (inside two parts: wound outwards) and 6 x 6 x 6 beads beside it.
  auto many = [&](bool islandOutwards) {
    TriangleMesh mesh = twoParts(0.5, {0.1, 0.05, 0}, false);
    auto add = [&](const Vec3& centre, double scale, bool outwards) {
      const auto base = static_cast<unsigned>(mesh.vertices.size());
      for (const Vec3& c : corner) mesh.vertices.push_back(centre + c * scale);
      for (const auto& f : faces)
        mesh.triangles.push_back(outwards ? std::array<unsigned, 3>{f[0] + base, f[1] + base, f[2] + base}
                                          : std::array<unsigned, 3>{f[2] + base, f[1] + base, f[0] + base});
    };
    add({0.1, 0.05, 0}, 0.1, islandOutwards);
    for (int i = 0; i < 216; ++i) add({3.0 + i % 6, 1.0 * (i / 6 % 6), 1.0 * (i / 36)}, 0.2, true);
    return mesh;
  };
  EXPECT_EQ(meshClosureFault(many(true)), std::nullopt);
  const auto island = meshClosureFault(many(false));
  ASSERT_TRUE(island.has_value());
  EXPECT_NE(island->find("lies inside 2 of the mesh's other 218 parts"), std::string::npos) << *island;
  EXPECT_NE(island->find("a solid must be wound outwards"), std::string::npos) << *island;
}

// Assimp's formats place meshes with node transforms (glTF, COLLADA): the
// vertices come out where the file puts them. A vertex far beyond any bench
// (wrong units, a corrupt number) is refused, naming it.
TEST_F(SceneFile, MeshFilesArePlacedAsTheySayAndKeptNearTheBench) {
  // One triangle (0,0,0), (1,0,0), (0,1,0) under a node scaled by 2 and moved 10 mm along z.
  write("placed.gltf",
        R"({"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
            "nodes": [{"mesh": 0, "translation": [0, 0, 10], "scale": [2, 2, 2]}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
            "buffers": [{"byteLength": 36, "uri":
                         "data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA"}],
            "bufferViews": [{"buffer": 0, "byteLength": 36}],
            "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                           "min": [0, 0, 0], "max": [1, 1, 0]}]})");
  const TriangleMesh mesh = loadMesh(dir_ / "placed.gltf");
  ASSERT_EQ(mesh.triangles.size(), 1u);
  std::vector<Vec3> corners;
  for (const unsigned i : mesh.triangles[0]) corners.push_back(mesh.vertices[i]);
  std::sort(corners.begin(), corners.end(), [](const Vec3& a, const Vec3& b) { return a.x + 2 * a.y < b.x + 2 * b.y; });
  EXPECT_EQ(corners, (std::vector<Vec3>{{0, 0, 10}, {2, 0, 10}, {0, 2, 10}}));

  write("far.obj", "v 0 0 0\nv 1 0 0\nv 0 2e9 0\nf 1 2 3\n");
  EXPECT_TRUE(throwsError([&] { loadMesh(dir_ / "far.obj"); }, Errc::InvalidFile,
                          {"far.obj", "vertex 2", "more than 1e+06 mm from the origin"}));
}

// Vertices closer than 1e-7 of the mesh's size are one (a float's precision:
// rings of vertices at a sphere's pole, seams written twice), wherever they
// fall on the welding grid; farther apart, they leave a hole.
TEST_F(SceneFile, NearlyCoincidentVerticesCloseAMesh) {
  const Vec3 corner[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  const int faces[8][3] = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4}, {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  // Every face with vertices of its own; the first face's copy of (1, 0, 0) moved by `offset` along x.
  auto octahedron = [&](double offset) {
    TriangleMesh mesh;
    for (const auto& f : faces) {
      const auto base = static_cast<unsigned>(mesh.vertices.size());
      for (int k : f) mesh.vertices.push_back(corner[k]);
      mesh.triangles.push_back({base, base + 1, base + 2});
    }
    mesh.vertices[0].x += offset;
    return mesh;
  };
  const double tolerance = 1e-7 * 2;  // the octahedron is 2 mm across
  for (double fraction : {0.0, 0.1, 0.3, 0.5, 0.7, 0.9, -0.5, -0.9})
    EXPECT_EQ(meshClosureFault(octahedron(fraction * tolerance)), std::nullopt) << fraction;
  const auto apart = meshClosureFault(octahedron(10 * tolerance));
  ASSERT_TRUE(apart.has_value());
  EXPECT_NE(apart->find("a hole"), std::string::npos) << *apart;
}

// PLY bodies built byte by byte: values in either byte order.
class PlyBody {
 public:
  explicit PlyBody(bool bigEndian) : big_(bigEndian) {}
  template <typename T>
  PlyBody& put(T value) {
    unsigned char b[sizeof(T)];
    std::memcpy(b, &value, sizeof(T));
    if (big_) std::reverse(b, b + sizeof(T));
    bytes_.append(reinterpret_cast<const char*>(b), sizeof(T));
    return *this;
  }
  const std::string& bytes() const { return bytes_; }

 private:
  bool big_;
  std::string bytes_;
};

// The octahedron's 6 vertices and 8 outward faces.
const double kOcta[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
const std::vector<std::vector<int>> kOctaFaces = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4},
                                                  {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};

// A binary PLY of the octahedron with what a real exporter adds: a comment,
// a per-vertex colour, a second list on the faces and an element lfi skips.
std::string binaryOcta(bool bigEndian) {
  std::string text = fmt::format(
      "ply\nformat binary_{}_endian 1.0\ncomment from a test\nelement vertex 6\nproperty double x\n"
      "property uchar red\nproperty float y\nproperty float z\nelement face 8\n"
      "property list uchar int vertex_indices\nproperty list ushort float texcoord\n"
      "element edge 1\nproperty int vertex1\nproperty int vertex2\nend_header\n",
      bigEndian ? "big" : "little");
  PlyBody body(bigEndian);
  for (const auto& v : kOcta)
    body.put(v[0]).put(std::uint8_t{200}).put(static_cast<float>(v[1])).put(static_cast<float>(v[2]));
  for (const auto& f : kOctaFaces) {
    body.put(static_cast<std::uint8_t>(f.size()));
    for (int i : f) body.put(std::int32_t{i});
    body.put(std::uint16_t{2}).put(0.25f).put(0.5f);
  }
  body.put(std::int32_t{0}).put(std::int32_t{1});
  return text + body.bytes();
}

TEST_F(SceneFile, PlyReadsAsciiAndBothBinaryByteOrdersAlike) {
  std::string ascii =
      "ply\r\nformat ascii 1.0\r\nelement vertex 6\r\nproperty float x\r\nproperty float y\r\n"
      "property float z\r\nelement face 7\r\nproperty list uchar int vertex_indices\r\nend_header\r\n";
  for (const auto& v : kOcta) ascii += fmt::format("{} {} {}\r\n", v[0], v[1], v[2]);
  ascii += "4 4 0 2 1\n";  // faces 0 and 1 as one quad, fanned from vertex 4 into (4 0 2) and (4 2 1)
  for (size_t f = 2; f < kOctaFaces.size(); ++f)
    ascii += fmt::format("3 {} {} {}\n", kOctaFaces[f][0], kOctaFaces[f][1], kOctaFaces[f][2]);
  write("octa.ply", ascii);
  write("little.ply", binaryOcta(false));
  write("big.ply", binaryOcta(true));
  for (const char* file : {"octa.ply", "little.ply", "big.ply"}) {
    SCOPED_TRACE(file);
    const TriangleMesh mesh = loadMesh(dir_ / file, std::numbers::pi);  // (no vertex repeated at a crease)
    ASSERT_EQ(mesh.vertices.size(), 6u);
    for (size_t i = 0; i < 6; ++i) EXPECT_EQ(mesh.vertices[i], Vec3(kOcta[i][0], kOcta[i][1], kOcta[i][2]));
    ASSERT_EQ(mesh.triangles.size(), 8u);
    // Every triangle winds outwards, and the smooth normals point along the vertices.
    for (const auto& t : mesh.triangles) {
      const Vec3 n = (mesh.vertices[t[1]] - mesh.vertices[t[0]]).cross(mesh.vertices[t[2]] - mesh.vertices[t[0]]);
      EXPECT_GT(n.dot(mesh.vertices[t[0]] + mesh.vertices[t[1]] + mesh.vertices[t[2]]), 0);
    }
    if (std::string(file) == "octa.ply") {
      EXPECT_EQ(mesh.triangles[0], (std::array<unsigned, 3>{4, 0, 2}));
      EXPECT_EQ(mesh.triangles[1], (std::array<unsigned, 3>{4, 2, 1}));
    }
    for (size_t f = 2; f < 8; ++f)
      EXPECT_EQ(mesh.triangles[f], (std::array<unsigned, 3>{static_cast<unsigned>(kOctaFaces[f][0]),
                                                            static_cast<unsigned>(kOctaFaces[f][1]),
                                                            static_cast<unsigned>(kOctaFaces[f][2])}));
  }
}

TEST_F(SceneFile, CorruptPlyIsAnErrorNamingFileAndPlace) {
  const std::string header =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
  const std::string vertices = "0 0 0\n1 0 0\n0 1 0\n";
  const std::string binary = binaryOcta(false);
  struct Case {
    std::string name, text;
    std::vector<std::string> fragments;
  };
  const std::vector<Case> cases = {
      // The shapes of the files that hung, aborted or crashed Debian's Assimp 5.2.5 (fuzzing, session 8).
      {"cut-in-header.ply", header.substr(0, 60), {"no 'end_header'"}},
      {"bad-end-header.ply",
       "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\n"
       "eheader\n" +
           std::string(12, '\x7f'),
       {"line 5", "unknown header keyword 'eheader'"}},
      {"missing-face.ply", header + vertices, {"line 13", "face 0", "ends before"}},
      // An ASCII instance is one line: a row short of a value, or with one more, or rows past the counts.
      {"short-row.ply", header + "0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
       {"line 10", "property 'z' of vertex 0", "its line ends before it"}},
      {"long-row.ply", header + "0 0 0 5\n1 0 0\n0 1 0\n3 0 1 2\n",
       {"line 10", "vertex 0: '5' is a value past the element's declared properties"}},
      {"long-face.ply", header + vertices + "3 0 1 2 2\n", {"line 13", "face 0: '2' is a value past"}},
      {"extra-rows.ply", header + vertices + "3 0 1 2\n3 0 2 1\n", {"line 14", "values after the last element"}},
      {"negative-length.ply", header + vertices + "-1 0 1 2\n", {"face 0", "'-1' is not an integer"}},
      {"inf-length.ply", header + vertices + "-inf 0 1 2\n", {"'-inf' is not an integer"}},
      // Counts and indices the file cannot back.
      {"count-past-end.ply",
       "ply\nformat binary_little_endian 1.0\nelement vertex 1000000000\nproperty float x\n"
       "property float y\nproperty float z\nelement face 0\n"
       "property list uchar int vertex_indices\nend_header\n0000",
       {"line 3", "'vertex' declares 1000000000 instances"}},
      {"index-out-of-range.ply", header + vertices + "3 0 1 7\n", {"vertex index 7 is not among the 3 vertices"}},
      {"long-list.ply",
       "ply\nformat binary_little_endian 1.0\nelement vertex 0\nproperty float x\nproperty float y\n"
       "property float z\nelement face 1\nproperty list int int vertex_indices\nend_header\n" +
           std::string("\xff\xff\xff\x7f", 4),
       {"byte ", "a list of 2147483647 values does not fit"}},
      {"cut-in-body.ply", binary.substr(0, binary.size() - 17), {"byte ", "texcoord' of face 7", "ends inside"}},
      {"long-body.ply", binary + "\n" + std::string(13, '\0'),
       {"14 bytes after the last element", "count in the header"}},
      // Malformed headers and values.
      {"not-a-number.ply", header + "0 0 0\n1 zero 0\n0 1 0\n3 0 1 2\n",
       {"line 11", "property 'y' of vertex 1", "'zero'"}},
      // Fewer bytes than the declared rows need (3 values and their separators each): named before reading.
      {"short-of-rows.ply", header + "0 0 0\n1 0 0\n", {"line 3", "'vertex' declares 3 instances"}},
      {"no-faces.ply",
       "ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\n"
       "property float z\nend_header\n",
       {"no 'face' element"}},
      {"no-format.ply", "ply\nelement vertex 0\nend_header\n", {"no 'format' line"}},
      {"unknown-type.ply",
       "ply\nformat ascii 1.0\nelement vertex 0\nproperty real x\nend_header\n",
       {"line 4", "unknown property type 'real'"}},
      {"binary-keyword.ply",
       "ply\nformat ascii 1.0\nelem\x01\xffnt vertex 0\nend_header\n",
       {"line 3", "'elem\\x01\\xffnt'"}},
      {"not-ply.ply", "solid cube\nendsolid cube\n", {"not a PLY file"}},
      // What only resembles PLY goes to lfi's reader, not to Assimp's PLY importer, whatever the name.
      {"upper.dat", "PLY\nformat ascii 1.0\nend_header\n", {"not a PLY file"}},
      {"bom.obj", "\xef\xbb\xbfply\nformat ascii 1.0\nend_header\n", {"not a PLY file"}},
      // Assimp would guess a file's format from its content, PLY among them: a file not named by a format it
      // knows is refused (here PLY after a newline, and a file with no extension, which Assimp also sniffs).
      {"newline-first.dat", "\nply\nformat ascii 1.0\nend_header\n", {"not a mesh format lfi reads", "'.dat'"}},
      {"no-extension", "plyX\nformat ascii 1.0\nend_header\n", {"not a mesh format lfi reads", "no extension"}},
      // A mesh must have a surface.
      {"flat.ply", header + "0 0 0\n1 0 0\n2 0 0\n3 0 1 2\n", {"none of the mesh's 1 faces has an area"}},
      // A repeated element read past its property list (fuzzing found it in the first version of the reader).
      {"two-faces.ply",
       header.substr(0, header.size() - 11) + "element face 1\nend_header\n" + vertices + "3 0 1 2\n",
       {"line 9", "a second 'face'"}},
      {"two-vertices.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                           "property float z\nelement vertex 1\nproperty float w\nend_header\n0 0 0\n1\n",
       {"line 7", "a second 'vertex'"}},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    write(c.name, c.text);
    std::vector<std::string> fragments = c.fragments;
    fragments.push_back((dir_ / c.name).string());
    EXPECT_TRUE(throwsError([&] { loadMesh(dir_ / c.name); }, Errc::InvalidFile, fragments));
  }
}

// Assimp opens the files a mesh file names itself: a glTF buffer that is a
// FIFO (or a device) is an error, not a load that blocks for ever.
TEST_F(SceneFile, AMeshFilesOwnFilesMustBeRegularFiles) {
  const std::string gltf =
      R"({"asset": {"version": "2.0"}, "buffers": [{"uri": "pipe.bin", "byteLength": 36}],
  "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36}],
  "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                 "min": [0, 0, 0], "max": [1, 1, 0]}],
  "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
  "nodes": [{"mesh": 0}], "scenes": [{"nodes": [0]}], "scene": 0})";
  write("fifo.gltf", gltf);
  ASSERT_EQ(::mkfifo((dir_ / "pipe.bin").c_str(), 0600), 0);
  EXPECT_TRUE(throwsError([&] { loadMesh(dir_ / "fifo.gltf"); }, Errc::InvalidFile,
                          {(dir_ / "fifo.gltf").string(), "not a readable mesh"}));
  // The same file with a regular buffer loads: a triangle.
  fs::remove(dir_ / "pipe.bin");
  const float triangle[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  write("pipe.bin", std::string(reinterpret_cast<const char*>(triangle), sizeof triangle));
  EXPECT_EQ(loadMesh(dir_ / "fifo.gltf").triangles.size(), 1u);
}

TEST_F(SceneFile, MutatedPlyFilesLoadCheckedOrAreNamedErrors) {
  // Seeded mutations of an ASCII and both binary octahedra (the kinds of
  // damage that crashed Assimp): byte changes, bit flips, cuts, repeated
  // bytes and repeated lines.
  // Each either loads as a mesh whose every index is in range and every
  // vertex finite, or is an lfi::Error naming the file; never a crash or hang.
  std::string ascii =
      "ply\nformat ascii 1.0\nelement vertex 6\nproperty float x\nproperty float y\n"
      "property float z\nelement face 8\nproperty list uchar int vertex_indices\nend_header\n";
  for (const auto& v : kOcta) ascii += fmt::format("{} {} {}\n", v[0], v[1], v[2]);
  for (const auto& f : kOctaFaces) ascii += fmt::format("3 {} {} {}\n", f[0], f[1], f[2]);
  const std::string seeds[] = {ascii, binaryOcta(false), binaryOcta(true)};
  std::mt19937 rng(20261122);
  int loaded = 0, refused = 0;
  for (int n = 0; n < 1500; ++n) {
    std::string bytes = seeds[n % 3];
    for (int edits = 1 + static_cast<int>(rng() % 3); edits > 0; --edits) lfi::testing_support::damage(bytes, rng);
    const fs::path file = write("m.ply", bytes);
    try {
      const TriangleMesh mesh = loadMesh(file);
      for (const auto& t : mesh.triangles)
        for (unsigned i : t) ASSERT_LT(i, mesh.vertices.size()) << "case " << n;
      for (const Vec3& v : mesh.vertices) ASSERT_TRUE(std::isfinite(v.x + v.y + v.z)) << "case " << n;
      ++loaded;
    } catch (const Error& e) {
      ASSERT_NE(std::string(e.what()).find(file.string()), std::string::npos) << "case " << n << ": " << e.what();
      ++refused;
    }
  }
  // Both outcomes occur: the mutations reach past the header checks.
  EXPECT_GT(loaded, 50);
  EXPECT_GT(refused, 500);
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

TEST_F(SceneFile, MeshAndAnalyticSphereRefractAlike) {
  // A glass ball (R = 5, n = 1.5), analytic and as a UV sphere of 96 x 48
  // facets (an OBJ with a ring of vertices at each pole, as exporters write
  // it), over a parallel back light (cone half-angle 0.05 rad), through the 1:1
  // telecentric camera (acceptance 0.01 rad, 0.1 mm pixels).
  std::string obj;
  const int nu = 96, nv = 48;
  for (int j = 0; j <= nv; ++j)
    for (int i = 0; i < nu; ++i) {
      const double th = std::numbers::pi * j / nv, ph = 2 * std::numbers::pi * i / nu;
      obj += fmt::format("v {} {} {}\n", 5 * std::sin(th) * std::cos(ph), 5 * std::sin(th) * std::sin(ph),
                         5 * std::cos(th));
    }
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      const int a = j * nu + i + 1, b = j * nu + (i + 1) % nu + 1, c = a + nu, e = b + nu;
      obj += fmt::format("f {} {} {}\nf {} {} {}\n", a, c, b, b, c, e);
    }
  write("ball.obj", obj);
  auto scene = [&](const std::string& shape) {
    return std::string("format = \"lfi-scene\"\nversion = 1\n[render]\nsamples_per_pixel = 64\nsplit_depth = 6\n") +
           kCamera + "[[object]]\nname='ball'\n" + shape +
           "material='dielectric'\nior=1.5\n[[object]]\nname='light'\nshape='rectangle'\nsize_mm=[400,400]\n"
           "position_mm=[0,0,-50]\nemitter='parallel'\nhalf_angle_rad=0.05\n";
  };
  SceneDescription analytic = loadSceneFile(write("a.toml", scene("shape='sphere'\nradius_mm=5\n")));
  SceneDescription mesh = loadSceneFile(write("m.toml", scene("shape='mesh'\nfile='ball.obj'\n")));
  // A ray along the axis at height h leaves the ball turned towards the axis
  // by h / f, f = n R / (2 (n - 1)) = 7.5 mm (paraxial). The facets' normals
  // are interpolated, so the mesh turns it by nearly as much; on the axis not
  // at all (the south pole's ring of vertices, 1e-16 apart, once kept a
  // normal each and turned the axial ray by 0.013 rad).
  {
    const Scene a(analytic.objects), m(mesh.objects);
    for (const double h : {0.0, 0.05, 0.1, 0.3, 1.0}) {
      const Ray down{{h, 0.0, 20.0}, {0, 0, -1}};
      const auto pa = refractionPath(a, down), pm = refractionPath(m, down);
      ASSERT_EQ(pa.size(), 4u);  // origin, in, out, escape
      ASSERT_EQ(pm.size(), 4u);
      const double turnA = (pa[3] - pa[2]).normalized().x, turnM = (pm[3] - pm[2]).normalized().x;
      if (h <= 0.3) {
        EXPECT_NEAR(turnA, -h / 7.5, 0.002 * h / 7.5 + 1e-12) << h;
      }
      EXPECT_NEAR(turnM, turnA, 0.08 * h / 7.5 + 1e-4) << h;  // (measured: within 7 %)
    }
  }
  // In the image, a camera ray turned by h / f finds the light when that and
  // its own slope (up to the 0.01 rad acceptance) stay within the 0.05 rad
  // cone: fully lit while h / f < 0.04 rad (h < 0.3 mm, 3 pixels), partly to
  // 0.06 rad (0.45 mm), dark beyond. At its centre the rays cross both
  // surfaces at normal incidence: (1 - R)^2 = 0.9216 of the light, R = ((n -
  // 1)/(n + 1))^2 = 0.04, and the paths reflected twice inside, turned by
  // about 2h/R, mostly stay in the cone too: T^2 / (1 - R^2) = 0.9231 at most.
  const cv::Mat ia = render(Scene(std::move(analytic.objects)), analytic.sensor, analytic.render);
  const cv::Mat im = render(Scene(std::move(mesh.objects)), mesh.sensor, mesh.render);
  const double centre = std::pow(1 - 0.04, 2);
  for (const cv::Mat& image : {ia, im}) {
    double middle = 0, outside = 0;  // the four pixels around the axis; the brightest beyond 0.6 mm
    for (int j = 0; j < 16; ++j)
      for (int i = 0; i < 16; ++i) {
        const double x = i + 0.5 - 8, y = j + 0.5 - 8, v = image.at<float>(j, i);
        if (std::abs(x) < 1 && std::abs(y) < 1) middle += v / 4;
        if (x * x + y * y > 36) outside = std::max(outside, v);
      }
    EXPECT_NEAR(middle, centre, 0.01);
    EXPECT_EQ(outside, 0);
  }
}

}  // namespace
