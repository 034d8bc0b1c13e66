// SPDX-License-Identifier: Apache-2.0
// OBJ and STL files as the scene loader reads them through Assimp (sim::loadMesh, sim/scene_file.h), then the
// check that a dielectric mesh bounds a solid (sim::meshClosureFault). The first byte picks the file's extension
// (bit 0: .obj or .stl; STL's ASCII or binary form is Assimp's guess from the content) and the crease angle
// (bits 1-2: 30, 0, 90 or 180 degrees); the rest is the file. A mesh read must be whole: a normal per vertex,
// every corner a vertex.
#include "fuzz_input.h"

#include "lfi/sim/scene_file.h"

#include <cstdlib>
#include <numbers>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const auto path = lfi::fuzz::writeInput(data[0] & 1 ? "mesh.stl" : "mesh.obj", data + 1, size - 1);
  const double crease_deg[] = {lfi::sim::kDefaultCreaseAngle_deg, 0, 90, 180};
  lfi::fuzz::expectCleanRefusal([&] {
    const lfi::sim::TriangleMesh mesh =
        lfi::sim::loadMesh(path, crease_deg[(data[0] >> 1) & 3] * std::numbers::pi / 180);
    if (mesh.normals.size() != mesh.vertices.size()) std::abort();
    for (const auto& t : mesh.triangles)
      for (const unsigned v : t)
        if (v >= mesh.vertices.size()) std::abort();
    lfi::sim::meshClosureFault(mesh);
  });
  return 0;
}
