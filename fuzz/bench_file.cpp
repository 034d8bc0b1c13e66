// SPDX-License-Identifier: Apache-2.0
// The inspection bench file reader (controller/bench_file.h) on any text.
#include "fuzz_input.h"

#include "lfi/controller/bench_file.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = lfi::fuzz::writeInput("bench.toml", data, size);
  lfi::fuzz::expectCleanRefusal([&] { lfi::readBenchFile(path); });
  return 0;
}
