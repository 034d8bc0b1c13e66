// SPDX-License-Identifier: Apache-2.0
// Meshes that must bound a solid (meshClosureFault): a dielectric mesh with a
// hole or a face wound the wrong way is refused, each part is wound outwards
// but cavities, and vertices within a float's precision close a mesh.

#include "lfi/sim/scene_file.h"

#include "lfi_test_support.h"
#include "scene_file_fixture.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <array>
#include <optional>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;
using namespace lfi;
using namespace lfi::sim;
using lfi::testing_support::kCamera;
using lfi::testing_support::SceneFile;
using lfi::testing_support::throwsError;

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
                           "[[object]]\nname='m'\nshape='mesh'\nfile='" + mesh.filename().string() + "'\nmaterial='" +
                           material + "'\n" + (material == "dielectric" ? "ior=1.5\n" : ""));
  };
  obj("closed.obj", [&](int f) { return "f " + faces[f] + "\n"; });
  EXPECT_NO_THROW(loadSceneFile(scene("closed.toml", dir_ / "closed.obj", "dielectric")));
  EXPECT_EQ(meshClosureFault(loadMesh(dir_ / "closed.obj")), std::nullopt);

  obj("holed.obj", [&](int f) { return f == 7 ? std::string() : "f " + faces[f] + "\n"; });
  EXPECT_TRUE(throwsError([&] { loadSceneFile(scene("holed.toml", dir_ / "holed.obj", "dielectric")); }, Errc::Config,
                          {"holed.toml:", "object[0].file", "holed.obj", "not closed", "a hole"}));
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
  std::string ply =
      "ply\nformat ascii 1.0\nelement vertex 24\nproperty float x\nproperty float y\n"
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
                           "[[object]]\nname='m'\nshape='mesh'\nfile='" + mesh + "'\nmaterial='" + material + "'\n" +
                           (std::string(material) == "dielectric" ? "ior=1.5\n" : "") +
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

}  // namespace
