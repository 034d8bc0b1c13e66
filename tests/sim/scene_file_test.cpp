// Scene files: the documented keys load into the scene they describe, and
// every kind of bad input is an error naming file, line and key.

#include "lfi/core/exr_io.h"
#include "lfi/sim/scene_file.h"

#include "lfi_test_support.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>
#include <numbers>

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
  EXPECT_TRUE(throwsError(
      [&] {
        loadSceneFile(write(
            "e.toml", "format = \"lfi-scene\"\nversion = 1\n[[object]]\nname='x'\nshape='sphere'\nradius_mm=1\n"));
      },
      Errc::Config, {"exactly one sensor"}));
  EXPECT_TRUE(throwsError([&] { loadSceneFile(write("f.toml", "format = \"lfi-scene\"\nversion = [\n")); },
                          Errc::Config, {"f.toml:"}));
  EXPECT_TRUE(throwsError([&] { loadSceneFile(dir_ / "missing.toml"); }, Errc::NotFound, {"missing.toml"}));
  // A light field emitter whose file is corrupt: the EXR error names that file.
  write("lf.exr", "not an exr");
  EXPECT_TRUE(throwsError(
      [&] {
        loadSceneFile(write("g.toml", head + "[[object]]\nname='d'\nshape='rectangle'\nsize_mm=[1,1]\n"
                                             "emitter='light_field'\nlight_field='lf.exr'\n"));
      },
      Errc::InvalidFile, {"lf.exr"}));
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
    const TriangleMesh mesh = loadMesh(dir_ / file);
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
  EXPECT_THROW(loadMesh(dir_ / "bad.obj"), lfi::Error);
  write("text.ply", "this is not a mesh\n");
  EXPECT_TRUE(throwsError([&] { loadMesh(dir_ / "text.ply"); }, Errc::InvalidFile, {"text.ply"}));
  EXPECT_TRUE(throwsError([&] { loadMesh(dir_ / "none.obj"); }, Errc::NotFound, {"none.obj"}));
}

TEST_F(SceneFile, MeshAndAnalyticSphereRefractAlike) {
  // A finely tessellated glass sphere seen against a Lambertian back light
  // transmits what the analytic sphere transmits, up to tessellation error.
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
    return std::string("format = \"lfi-scene\"\nversion = 1\n[render]\nsamples_per_pixel = 16\nsplit_depth = 6\n") +
           kCamera + "[[object]]\nname='ball'\n" + shape +
           "material='dielectric'\nior=1.5\n[[object]]\nname='light'\nshape='rectangle'\nsize_mm=[400,400]\n"
           "position_mm=[0,0,-50]\nemitter='lambertian'\n";
  };
  SceneDescription analytic = loadSceneFile(write("a.toml", scene("shape='sphere'\nradius_mm=5\n")));
  SceneDescription mesh = loadSceneFile(write("m.toml", scene("shape='mesh'\nfile='ball.obj'\n")));
  const cv::Mat ia = render(Scene(std::move(analytic.objects)), analytic.sensor, analytic.render);
  const cv::Mat im = render(Scene(std::move(mesh.objects)), mesh.sensor, mesh.render);
  // Centre pixels: two interfaces at near-normal incidence, T ~ (1 - 0.04)^2 / (1 - 0.04^2).
  EXPECT_NEAR(ia.at<float>(8, 8), im.at<float>(8, 8), 0.02);
  EXPECT_NEAR(cv::mean(ia)[0], cv::mean(im)[0], 0.02);
}

}  // namespace
