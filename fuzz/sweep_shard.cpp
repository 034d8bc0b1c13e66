// SPDX-License-Identifier: Apache-2.0
// A sweep shard's record (shard.json, study/grid_sweep.h: what `lfi study merge` reads) on any text, merged
// alone: refused by name, or merged into a sweep's results when it is one whole sweep.
#include "fuzz_input.h"

#include "lfi/study/grid_sweep.h"

#include <filesystem>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  namespace fs = std::filesystem;
  const fs::path shard = lfi::fuzz::folder() / "shard";
  fs::create_directories(shard / "images" / "point-000000");
  lfi::fuzz::writeInput("shard/shard.json", data, size);
  lfi::fuzz::expectCleanRefusal([&] { lfi::study::mergeSweepShards(lfi::fuzz::folder() / "merged", {shard}, true); });
  return 0;
}
