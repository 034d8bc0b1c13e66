// SPDX-License-Identifier: Apache-2.0
// The reference study's bench file reader (study/study.h, lfi::study::Bench::load: what `lfi study --bench`
// reads) on any text, and the camera and the lens's span the study derives from what it read.
#include "fuzz_input.h"

#include "lfi/study/study.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = lfi::fuzz::writeInput("bench.toml", data, size);
  lfi::fuzz::expectCleanRefusal([&] {
    const lfi::study::Bench bench = lfi::study::Bench::load(path);
    bench.lensSpan(true);
    bench.telecentricCamera();
  });
  return 0;
}
