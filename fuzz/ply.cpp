// SPDX-License-Identifier: Apache-2.0
// lfi's PLY reader (sim/src/scene_file/ply_mesh.h, which keeps PLY files from Assimp) on any bytes.
#include "fuzz_input.h"

#include "scene_file/ply_mesh.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = lfi::fuzz::writeInput("mesh.ply", data, size);
  lfi::fuzz::expectCleanRefusal([&] { lfi::sim::detail::readPly(path); });
  return 0;
}
