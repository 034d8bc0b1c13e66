// SPDX-License-Identifier: Apache-2.0
// A sweep file (study/sweep_file.h: what `lfi study --sweep FILE` reads) on any text, beside the shipped
// reference bench as its bench.toml, and the grid's points and benches it makes.
#include "fuzz_input.h"

#include "lfi/study/sweep_file.h"

#include <filesystem>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const bool bench = [] {
    std::filesystem::copy_file(std::filesystem::path(LFI_SOURCE_DIR) / "data" / "benches" / "reference.toml",
                               lfi::fuzz::folder() / "bench.toml", std::filesystem::copy_options::overwrite_existing);
    return true;
  }();
  (void)bench;
  const auto path = lfi::fuzz::writeInput("sweep.toml", data, size);
  lfi::fuzz::expectCleanRefusal([&] {
    const lfi::study::SweepFile sweep = lfi::study::readSweepFile(path);
    sweep.point(sweep.pointCount() - 1);
  });
  return 0;
}
