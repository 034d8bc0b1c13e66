// SPDX-License-Identifier: Apache-2.0
// Mesh files (loadMesh): OBJ, PLY and glTF load where the file places them,
// at the scene's scale, with normals smooth across gentle edges and sharp
// across creases; a mesh ball refracts as the analytic one does.

#include "lfi/sim/scene_file.h"

#include "lfi_test_support.h"
#include "scene_file_fixture.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;
using namespace lfi;
using namespace lfi::sim;
using lfi::testing_support::kCamera;
using lfi::testing_support::SceneFile;
using lfi::testing_support::throwsError;

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
                                 "f 1 3 4\nf 1 4 2\nf 3 5 6\nf 3 6 4\n"   // up (+z)
                                 "f 1 4 3\nf 1 2 4\nf 3 6 5\nf 3 4 6\n",  // down
                                 c, s, c, s));
  const TriangleMesh sheet = loadMesh(dir_ / "sheet.obj");
  // Every corner on the hinge (x = 0) has its layer's smooth normal, an
  // area-weighted mean of the faces on both sides: within 10 degrees of its
  // face's normal but not along it (flat) and not blended with the other
  // layer (which would turn it by 90 degrees or more).
  int hinge = 0;
  for (const auto& t : sheet.triangles) {
    const Vec3 n =
        (sheet.vertices[t[1]] - sheet.vertices[t[0]]).cross(sheet.vertices[t[2]] - sheet.vertices[t[0]]).normalized();
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
  write("metres.obj",
        "v 0.001 0 0\nv -0.001 0 0\nv 0 0.001 0\nv 0 -0.001 0\nv 0 0 0.001\nv 0 0 -0.001\n"
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
  write("octa.obj",
        "v 1 0 0\nv -1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nv 0 0 -1\n"
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
  std::string ply = fmt::format(
      "ply\nformat ascii 1.0\nelement vertex {}\nproperty double x\nproperty double y\n"
      "property double z\nelement face {}\nproperty list uchar int vertex_indices\n"
      "end_header\n",
      points.size(), faces.size());
  for (const Vec3& q : points) ply += fmt::format("{} {} {}\n", q.x, q.y, q.z);
  for (const auto& f : faces) ply += fmt::format("3 {} {} {}\n", f[0], f[1], f[2]);
  write("sphere.ply", ply);
  const TriangleMesh sphere = loadMesh(dir_ / "sphere.ply");
  EXPECT_EQ(meshClosureFault(sphere), std::nullopt);  // (wound outwards)
  ASSERT_EQ(sphere.vertices.size(), points.size());
  for (size_t i = 0; i < points.size(); ++i) EXPECT_GT(sphere.normals[i].dot(points[i]), std::cos(0.05)) << i;

  // A glass cube of 8 shared vertices (corners (+-1, +-1, +-1)); a ray along +z through (0.3, 0.4).
  write("cube.ply",
        "ply\nformat ascii 1.0\nelement vertex 8\nproperty float x\nproperty float y\n"
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
  const Scene smoothCube({Object{"cube", loadMesh(dir_ / "cube.ply", std::numbers::pi), Rigid3{}, Dielectric{1.5, 0}}});
  const Vec3 d = Vec3(0.9, 0, -0.3).normalized(), at(-0.95, 0, -1);
  const Hit hit = smoothCube.intersect(Ray{at - d * 0.05, d});
  ASSERT_TRUE(hit.valid());
  EXPECT_NEAR(hit.point.z, -1, 1e-6);
  EXPECT_GT(hit.normal.dot(d), 0) << "leaving the cube; normal " << hit.normal;
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
  // at all (the south pole's ring of vertices, 1e-16 apart, would turn the
  // axial ray by 0.013 rad if each kept a normal of its own).
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
