// SPDX-License-Identifier: Apache-2.0
// The scene file reader (sim/scene_file.h) on any text; the files a scene names are looked for beside it, where
// there are none.
#include "fuzz_input.h"

#include "lfi/sim/scene_file.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = lfi::fuzz::writeInput("scene.toml", data, size);
  lfi::fuzz::expectCleanRefusal([&] { lfi::sim::loadSceneFile(path); });
  return 0;
}
