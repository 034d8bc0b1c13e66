// SPDX-License-Identifier: Apache-2.0
// The scene file reader (sim/scene_file.h) on any text. The files a scene names are looked for beside it, where
// the target keeps fixed meshes: an octahedron of 2 mm as closed.ply, closed.obj, closed.stl (ASCII) and
// binary.stl, and with a face missing as open.obj, so that a scene's meshes resolve and go through the mesh
// readers and the closure check.
#include "fuzz_input.h"

#include "lfi/sim/scene_file.h"

#include <fmt/format.h>

#include <cstring>
#include <string>

namespace {

constexpr float kCorner[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
constexpr int kFace[8][3] = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4}, {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};

void writeFile(const std::string& name, const std::string& bytes) {
  lfi::fuzz::writeInput(name, reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
}

void writeMeshes() {
  std::string vertices, faces, ply, stl = "solid octahedron\n", binary(80, '\0');
  for (const auto& c : kCorner) vertices += fmt::format("{} {} {}\n", c[0], c[1], c[2]);
  std::uint32_t count = 8;
  binary.append(reinterpret_cast<const char*>(&count), 4);  // (little-endian, as x86 stores it)
  for (const auto& f : kFace) {
    faces += fmt::format("3 {} {} {}\n", f[0], f[1], f[2]);
    stl += " facet normal 0 0 0\n  outer loop\n";
    binary.append(12, '\0');  // (the normal: Assimp computes its own)
    for (const int v : f) {
      stl += fmt::format("   vertex {} {} {}\n", kCorner[v][0], kCorner[v][1], kCorner[v][2]);
      binary.append(reinterpret_cast<const char*>(kCorner[v]), 12);
    }
    stl += "  endloop\n endfacet\n";
    binary.append(2, '\0');
  }
  writeFile("closed.ply",
            "ply\nformat ascii 1.0\nelement vertex 6\nproperty float x\nproperty float y\nproperty float z\n"
            "element face 8\nproperty list uchar int vertex_indices\nend_header\n" +
                vertices + faces);
  std::string obj, open;
  for (const auto& c : kCorner) obj += fmt::format("v {} {} {}\n", c[0], c[1], c[2]);
  open = obj;
  for (int k = 0; k < 8; ++k) {
    const std::string face = fmt::format("f {} {} {}\n", kFace[k][0] + 1, kFace[k][1] + 1, kFace[k][2] + 1);
    obj += face;
    if (k < 7) open += face;
  }
  writeFile("closed.obj", obj);
  writeFile("open.obj", open);
  writeFile("closed.stl", stl + "endsolid octahedron\n");
  writeFile("binary.stl", binary);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const bool meshes = (writeMeshes(), true);
  (void)meshes;
  const auto path = lfi::fuzz::writeInput("scene.toml", data, size);
  lfi::fuzz::expectCleanRefusal([&] { lfi::sim::loadSceneFile(path); });
  return 0;
}
